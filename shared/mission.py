"""Each rover's list of goals, and how ground commands change it (needs N5 and N6 of the report).

The lander uses it to tell rovers where to go; the world service uses the same bookkeeping to judge
which goal is each rover's final one. One implementation, so the two never disagree.
"""

from __future__ import annotations

import bisect
from collections import defaultdict

from schemas.errors import LunarSimError
from schemas.messages import Calibration, GroundCommand
from schemas.scenario import Goal, LanderSpec, RoverSpawn, Scenario
from schemas.scenario_limits import MAX_GOALS


def calibration(scenario: Scenario, rover_id: int) -> Calibration:
    """Where the lander sets rover ``rover_id`` down, relative to itself: what it tells the rover (dispatch)."""
    return dispatch_pose(scenario.lander, scenario.rovers[rover_id - 1])


def dispatch_pose(lander: LanderSpec, spawn: RoverSpawn) -> Calibration:
    """A spawn relative to the lander: the lander's calibration, and what a rover's own mission file says when that
    word never comes (``rover_agent.mission.contact``)."""
    return Calibration(x=spawn.x - lander.x, z=spawn.z - lander.z, heading_deg=spawn.heading_deg)


class CommandRefused(LunarSimError, ValueError):
    """A ground command that cannot be carried out; the message says why, for the operator."""


COMMANDED_GOALS = MAX_GOALS
"""Goals the ground may add to one rover's mission beyond the scenario's (as many as a scenario's mission may hold):
each is kept for the mission's statistics and in the lander's saved state, so a stream of commands must end."""
REQUESTS_KEPT = 4096
"""Request ids whose outcome is remembered, to answer a resend with the first outcome; the oldest is forgotten first
(the ground resends within seconds, not thousands of commands later)."""


class RoverMissions:
    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.goals: dict[int, list[Goal]] = {i + 1: list(scenario.mission) for i in range(len(scenario.rovers))}
        self.outcomes: dict[str, list[int] | CommandRefused] = {}  # request id -> what applying it gave
        self._sharing: dict[tuple[int, Goal], list[int]] | None = None  # (index, goal) -> rovers; None: not built

    def final_index(self, rover_id: int) -> int:
        return len(self.goals[rover_id]) - 1

    def goal(self, rover_id: int, index: int) -> Goal:
        goals = self.goals[rover_id]
        return goals[min(max(index, 0), len(goals) - 1)]

    def sharing(self, index: int, goal: Goal) -> list[int]:
        """The rovers whose goal ``index`` is ``goal``, from an index kept as goals are added: the lander asks on
        every broadcast for every rover, and a scan of all the rovers' goals for each would make a broadcast
        quadratic in the number of rovers."""
        return list(self._index().get((index, goal), ()))

    def _index(self) -> dict[tuple[int, Goal], list[int]]:
        if self._sharing is None:  # built once (also for a state saved before it was kept)
            self._sharing = defaultdict(list)
            for rid, goals in self.goals.items():
                for i, g in enumerate(goals):
                    self._sharing[(i, g)].append(rid)
        return self._sharing

    def apply(self, command: GroundCommand) -> list[int]:
        """Carry out a command; returns the rovers whose mission changed. Raises CommandRefused.

        The ground sends a command again until it hears the answer, so a repeat (same request id) gives the
        first outcome again and changes nothing. A command without a request id is always carried out."""
        if not command.request_id:
            return self._apply(command)
        if command.request_id not in self.outcomes:
            try:
                self.outcomes[command.request_id] = self._apply(command)
            except CommandRefused as exc:
                self.outcomes[command.request_id] = exc
            if len(self.outcomes) > REQUESTS_KEPT:
                del self.outcomes[next(iter(self.outcomes))]
        outcome = self.outcomes[command.request_id]
        if isinstance(outcome, CommandRefused):
            raise outcome
        return list(outcome)

    def _apply(self, command: GroundCommand) -> list[int]:
        rovers = self._rovers(command)
        if command.command == "stop":
            return rovers
        goal = self._new_goal(command)
        limit = len(self.scenario.mission) + COMMANDED_GOALS
        if full := [rid for rid in rovers if len(self.goals[rid]) >= limit]:
            raise CommandRefused(f"rover {full[0]} has had {COMMANDED_GOALS} goals from the ground, the most a "
                                 "mission takes" + (f" (and {len(full) - 1} more rovers)" if len(full) > 1 else ""))
        index = self._index()
        for rid in rovers:
            self.goals[rid].append(goal)
            bisect.insort(index[(len(self.goals[rid]) - 1, goal)], rid)  # in id order, as built
        return rovers

    def _rovers(self, command: GroundCommand) -> list[int]:
        if command.rover_id is None:
            if command.command != "set_target":
                raise CommandRefused(f"'{command.command}' needs a rover id")
            return list(self.goals)
        if command.rover_id not in self.goals:
            raise CommandRefused(f"there is no rover {command.rover_id} (rovers are 1..{len(self.goals)})")
        return [command.rover_id]

    def _new_goal(self, command: GroundCommand) -> Goal:
        if command.command == "return":
            return Goal(x=self.scenario.lander.x, z=self.scenario.lander.z, kind="waypoint")
        if command.x is None or command.z is None:
            raise CommandRefused("set_target needs the target's x and z")
        try:
            goal = Goal(x=command.x, z=command.z, kind=command.kind)
        except ValueError as exc:  # pydantic's ValidationError: a target no scenario could hold
            raise CommandRefused(f"({command.x}, {command.z}) cannot be a goal: {exc}") from None
        if goal.kind == "crater" and self.scenario.crater_of(goal) is None:
            raise CommandRefused(f"({command.x}, {command.z}) lies in no known crater: send it as a waypoint")
        return goal
