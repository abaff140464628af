"""The lander's mission plan (report 3.4): dispatch, calibration, then one goal after another per rover.

Pure logic. The lander knows where it set each rover down (dispatch) and each rover's goals, all in
its own frame (lander at the origin, axes as the map's). Each rover is told its deployment pose
(Calibration) and the bearing and distance of its current goal from the lander (MissionDirection);
when a rover reports a goal done, it is given the next one. Ground commands change the goals.
"""

from __future__ import annotations

import math
from collections import defaultdict

from schemas import messages as m
from schemas.frames import bearing_deg
from schemas.mission import RoverMissions
from schemas.radio import GoalReport
from schemas.scenario import Scenario


class MissionPlan:
    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        lx, lz = scenario.lander.x, scenario.lander.z
        self.calibration = {i + 1: m.Calibration(x=r.x - lx, z=r.z - lz, heading_deg=r.heading_deg)
                            for i, r in enumerate(scenario.rovers)}
        self.missions = RoverMissions(scenario)
        self.goal_of = dict.fromkeys(self.calibration, 0)
        self.outcome: dict[int, str] = {}

    @property
    def rover_ids(self) -> list[int]:
        return list(self.calibration)

    def direction_for(self, rover_id: int) -> m.MissionDirection:
        index = self.goal_of[rover_id]
        goal = self.missions.goal(rover_id, index)
        lx, lz = self.scenario.lander.x, self.scenario.lander.z
        return m.MissionDirection(goal_index=index, goals_total=self.missions.final_index(rover_id) + 1,
                                  kind=goal.kind, bearing_deg=round(bearing_deg(goal.x - lx, goal.z - lz), 6),
                                  distance_m=round(math.hypot(goal.x - lx, goal.z - lz), 6))

    def directions(self) -> dict[m.MissionDirection, list[int]]:
        """Each distinct direction with the rovers it is for, so one transmission serves them all."""
        grouped: dict[m.MissionDirection, list[int]] = defaultdict(list)
        for rid in self.goal_of:
            grouped[self.direction_for(rid)].append(rid)
        return dict(grouped)

    def on_report(self, rover_id: int, report: GoalReport) -> bool:
        """Advance a rover past a finished goal; True if it now has a new goal to be told about."""
        if rover_id not in self.goal_of or report.goal_index != self.goal_of[rover_id]:
            return False
        if report.outcome == "stuck" or report.goal_index >= self.missions.final_index(rover_id):
            self.outcome[rover_id] = report.outcome
            return False
        self.goal_of[rover_id] += 1
        return True

    def on_command(self, command: m.GroundCommand) -> list[int]:
        """Apply a ground command (raises CommandRefused); returns the rovers it concerns."""
        rovers = self.missions.apply(command)
        if command.command != "stop":
            for rid in rovers:
                self.goal_of[rid] = self.missions.final_index(rid)
                self.outcome.pop(rid, None)
        return rovers

    @property
    def phase(self) -> str:
        if len(self.outcome) == len(self.goal_of):
            return "complete"
        observing = any(self.missions.goal(r, g).kind == "crater" and r in self.outcome
                        for r, g in self.goal_of.items())
        return "observation" if observing else "migration"

    def status(self, stamp: float, connected: list[int]) -> m.LanderStatus:
        return m.LanderStatus(stamp=stamp, phase=self.phase, rover_goals=dict(self.goal_of), connected=connected)
