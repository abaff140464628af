"""Where the rover walks off the way to its goal to fix its pose estimate, and back: by the lander before a waypoint
that drift would otherwise miss (``estimation.lander_fix``), and a search for a fix at a waypoint reached by an
estimate it knows to be unsure (``estimation.fix_search``). The estimator decides; this turns its word into the
goal the behaviour walks to."""

from __future__ import annotations

from rover_agent.decisions import BaseBehaviour, Rotate
from rover_agent.estimation.estimator import Estimator
from rover_agent.mission.goals import Mission


class Detours:
    """Built by ``RoverAgent`` over its own parts."""

    def __init__(self, mission: Mission, estimator: Estimator, behaviour: BaseBehaviour) -> None:
        self.mission = mission
        self.estimator = estimator
        self.behaviour = behaviour

    def before_decision(self, now: float) -> None:
        """Take up, or end, a way by the lander; end a search for a fix that is over (sure again, or out of time)."""
        goal, est = self.mission.goal, self.estimator
        if goal is None or self.mission.finished_goal is not None or self.mission.contact.seeking:
            return
        step = est.mind_fix(goal)
        if step == "over":
            self._fix_over()
        elif step == "detour":
            self.behaviour.start_goal(est.fix.goal)
        if est.search_over(now):
            self._back_to_goal()

    def arrived(self, outcome: str, now: float) -> Rotate | bool:
        """The behaviour finished what it walked to. True: a leg of a detour, taken care of (a ``Rotate``: turn
        round to look for the lander or a teammate first); False: the goal itself, to finish."""
        est = self.estimator
        if est.fix.active:  # a leg of the way by the lander, not yet fixed
            step = est.fix_arrived(outcome)
            if step == "look":
                return Rotate(180.0)
            if step == "search":
                self.behaviour.start_goal(est.fix.goal)
            else:
                self._fix_over()
            return True
        if est.search.active:  # a leg of the search, still unsure: turn round, the next, or back to the goal
            if est.search.look_round():
                return Rotate(180.0)
            if not self._search_leg(now, begins=False):
                self._back_to_goal()
            return True
        return outcome == "reached" and self._search_leg(now, begins=True)  # at its waypoint, unsure: search

    def _fix_over(self) -> None:
        """Fixed, or where the lander was thought to be: on to the rover's own goal."""
        self.estimator.fix.active = False
        if self.mission.goal is not None:
            self.behaviour.start_goal(self.mission.goal)

    def _back_to_goal(self) -> None:
        self.estimator.search.end()
        if self.mission.goal is not None:
            self.behaviour.start_goal(self.mission.goal)

    def _search_leg(self, now: float, begins: bool) -> bool:
        if not self.estimator.search_leg(self.mission.goal, now, begins):
            return False
        self.behaviour.start_goal(self.estimator.search.goal)
        return True
