"""The lander's mission plan (report 3.4): dispatch, calibration, then one goal after another per rover.

Pure logic. The lander knows where it set each rover down (dispatch) and the goals of the mission, all
in its own frame (lander at the origin, axes as the world's). Each rover is told its deployment pose
(Calibration) and the bearing and distance of its current goal from the lander (MissionDirection);
when a rover reports a goal done, it is given the next one.
"""

from __future__ import annotations

import math

from schemas import messages as m
from schemas.frames import bearing_deg
from schemas.radio import GoalReport
from schemas.scenario import Scenario


class MissionPlan:
    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        lx, lz = scenario.lander.x, scenario.lander.z
        self.calibration = {i + 1: m.Calibration(x=r.x - lx, z=r.z - lz, heading_deg=r.heading_deg)
                            for i, r in enumerate(scenario.rovers)}
        total = len(scenario.mission)
        self.directions = [
            m.MissionDirection(goal_index=i, goals_total=total, kind=g.kind,
                               bearing_deg=round(bearing_deg(g.x - lx, g.z - lz), 6),
                               distance_m=round(math.hypot(g.x - lx, g.z - lz), 6))
            for i, g in enumerate(scenario.mission)
        ]
        self.goal_of = dict.fromkeys(self.calibration, 0)
        self.outcome: dict[int, str] = {}

    @property
    def rover_ids(self) -> list[int]:
        return list(self.calibration)

    def direction_for(self, rover_id: int) -> m.MissionDirection:
        return self.directions[self.goal_of[rover_id]]

    def on_report(self, rover_id: int, report: GoalReport) -> bool:
        """Advance a rover past a finished goal; True if it now has a new goal to be told about."""
        if rover_id not in self.goal_of or report.goal_index != self.goal_of[rover_id]:
            return False
        if report.outcome == "stuck" or report.goal_index + 1 >= len(self.directions):
            self.outcome[rover_id] = report.outcome
            return False
        self.goal_of[rover_id] += 1
        return True

    @property
    def phase(self) -> str:
        if len(self.outcome) == len(self.goal_of):
            return "complete"
        return "observation" if any(self.scenario.mission[g].kind == "crater" and r in self.outcome
                                    for r, g in self.goal_of.items()) else "migration"

    def status(self, stamp: float, connected: list[int]) -> m.LanderStatus:
        return m.LanderStatus(stamp=stamp, phase=self.phase, rover_goals=dict(self.goal_of), connected=connected)
