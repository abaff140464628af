"""The world's judgement of the mission: what each agent says of itself (its status), which rovers have stalled
whatever they say (``progress``), when the mission is over (``completion``), and the statistics counted from the
ground truth the world publishes (``statistics``).
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from schemas import messages as m
from schemas.scenario import Goal, Scenario
from shared.mission import RoverMissions
from world_service.outcome import statistics as stats
from world_service.outcome.completion import FINISHED_STATES, Completion, relay_wait_s
from world_service.outcome.progress import ProgressWatch

log = logging.getLogger("lunarsim.world")


class Referee:
    """Owns the agents' statuses, the lander's, the stall watch, the mission's end and its statistics."""

    def __init__(self, scenario: Scenario, rover_ids: list[int]) -> None:
        self.scenario = scenario
        params = scenario.rover_params
        self.stall_after_s = params.watchdog.stall_after_s
        self.stats = stats.MissionStats(scenario, RoverMissions(scenario))
        self.missions = self.stats.missions  # one bookkeeping of goals, followed with the ground's commands
        self.status = {rid: m.RoverStatus(stamp=0.0, state="waiting") for rid in rover_ids}
        self.lander_status: m.LanderStatus | None = None
        self.progress = ProgressWatch(self.stall_after_s)
        self.stalled: frozenset[int] = frozenset()
        self.completion = Completion(relay_wait_s(params))

    # ---- what the agents and the ground say ----

    def note_status(self, rid: int, msg: m.RoverStatus, now: float) -> None:
        before = self.status[rid]
        if (msg.state, msg.goal_index) != (before.state, before.goal_index):  # the mission's story, for the log
            log.info("t = %.1f s: rover %d %s, goal %d%s", now, rid, msg.state, msg.goal_index + 1,
                     f" ({msg.detail})" if msg.detail else "")
        self.status[rid] = msg

    def note_lander(self, msg: m.LanderStatus) -> None:
        self.lander_status = msg

    def lander_alive(self, alive: bool, now: float) -> None:
        self.completion.note_lander(alive, now)

    def command(self, command: m.GroundCommand) -> None:
        """Follow the ground's changes to the mission, so statistics judge each rover's real final goal."""
        self.stats.command(command)

    # ---- judging ----

    def goal_of(self, rid: int) -> Goal:
        return self.missions.goal(rid, self.status[rid].goal_index)

    def judge(self, rid: int, x: float, z: float, now: float, powered: bool | None) -> tuple[float, bool]:
        """The rover's distance to its goal and whether it has stalled. One finished, charging or off for want of
        power (``powered`` False) is waiting, not stalled."""
        status = self.status[rid]
        distance = round(stats.distance_to_goal(self.scenario, self.goal_of(rid), x, z), 3)
        waiting = status.state in FINISHED_STATES or status.state == "charging" or powered is False
        return distance, self.progress.observe(rid, status.goal_index, distance, now, waiting)

    def note_stalled(self, rovers: list[m.RoverTruth], now: float) -> None:
        stalled = frozenset(r.id for r in rovers if r.stalled)
        for rid in sorted(stalled - self.stalled):
            log.warning("t = %.1f s: rover %d counted stuck: no nearer its goal for %g s", now, rid, self.stall_after_s)
        self.stalled = stalled

    def check_complete(self, now: float, moving: dict[int, bool],
                       reaches_lander: Callable[[], dict[int, bool]]) -> None:
        self.completion.check(now, self.status, moving, reaches_lander, self.stalled)

    @property
    def completed_at(self) -> float | None:
        return self.completion.at

    def agent_counters(self) -> dict:
        """``WorldCounters`` fields the agents' own statuses tell."""
        lander = (self.lander_status,) if self.lander_status is not None else ()
        return {"agent_rejected": sum(s.rejected for s in (*self.status.values(), *lander)),
                "rovers_lost": sum(s.lost for s in self.status.values()),
                "lander_map_lost": any(s.map_lost for s in lander)}
