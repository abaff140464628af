"""The world's judgement of which rovers have stopped making progress, whatever their agents say.

An agent may never say it is stuck: it may wait for a sample that was lost, drive in circles, or have died. The
world knows the truth, so it counts such a rover stuck (``RoverTruth.stalled``) once it has come no closer to its
goal for ``stall_after_s`` simulated seconds, and the mission can end without it. A rover off for want of power
(empty battery, too cold) is waiting for the sun, not stalled.
"""

from __future__ import annotations

from dataclasses import dataclass

MIN_PROGRESS_M = 1.0
"""Closer to the goal than ever before by this much, or a new goal, counts as progress."""


@dataclass
class _Mark:
    goal_index: int
    best_m: float
    since: float


class ProgressWatch:
    def __init__(self, stall_after_s: float) -> None:
        self.stall_after_s = stall_after_s
        self._marks: dict[int, _Mark] = {}

    def observe(self, rover: int, goal_index: int, distance_to_goal_m: float, now: float, waiting: bool) -> bool:
        """Note where the rover stands; True if it is stalled. ``waiting``: finished, or off for want of power,
        so not expected to move (its clock restarts)."""
        mark = self._marks.get(rover)
        if (mark is None or waiting or goal_index != mark.goal_index
                or distance_to_goal_m < mark.best_m - MIN_PROGRESS_M):
            self._marks[rover] = _Mark(goal_index, distance_to_goal_m, now)
            return False
        return now - mark.since >= self.stall_after_s
