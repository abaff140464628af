"""A real rover as the twin knows it: where its driver's telemetry puts it on the map, the path it has covered, and
whether its telemetry has gone quiet.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

from schemas import messages as m
from shared.pose import Pose

log = logging.getLogger("lunarsim.world")

STALE_AFTER_S = 2.0
"""A rover whose driver has sent no telemetry for this long is marked stale (its last pose is kept)."""


def compose(start: Pose, telemetry: m.Telemetry) -> Pose:
    """Where a rover is on the map: its start pose moved by the driver's odometry (relative to that start)."""
    return start.after_partial(telemetry.x, telemetry.z, telemetry.heading_deg)


@dataclass
class TwinRover:
    """One real rover as the twin knows it: the last pose its driver reported, and the path summed so far.

    The driver's frame starts at the rover's start pose, so the path is counted from its origin: a twin
    that starts (or a sample that arrives) late bridges the gap with a straight line instead of losing it.
    """

    id: int
    start: Pose
    pose: Pose = field(init=False)
    distance_covered: float = 0.0
    moving: bool = False
    odometry: tuple[float, float] = (0.0, 0.0)  # last (x, z) in the driver's own frame
    last_sample_at: float = 0.0
    stale: bool = False

    def __post_init__(self) -> None:
        self.pose = self.start

    def follow(self, telemetry: m.Telemetry, now: float) -> None:
        here = (telemetry.x, telemetry.z)
        self.distance_covered += math.dist(self.odometry, here)
        self.odometry, self.pose, self.moving = here, compose(self.start, telemetry), telemetry.moving
        self.last_sample_at = now
        if self.stale:
            self.stale = False
            log.warning("rover %d: telemetry again after a gap", self.id)

    def check_stale(self, now: float) -> None:
        """Mark the rover stale once its telemetry stops, and say so once per gap."""
        if not self.stale and now - self.last_sample_at > STALE_AFTER_S:
            self.stale = True
            log.warning("rover %d: no telemetry for %g s; keeping its last pose until its driver reports again",
                        self.id, STALE_AFTER_S)

    @property
    def in_motion(self) -> bool:
        """Moving as far as the twin knows: a stale rover's last word does not hold the mission open."""
        return self.moving and not self.stale


def rover_truth(rover: TwinRover, status: m.RoverStatus, goal_distance_m: float, alive: bool) -> m.RoverTruth:
    pose = rover.pose
    return m.RoverTruth(id=rover.id, x=round(pose.x, 4), z=round(pose.z, 4), heading_deg=round(pose.heading, 3),
                        action="move" if rover.in_motion else "idle", state=status.state,
                        goal_index=status.goal_index, distance_to_goal_m=round(goal_distance_m, 3),
                        distance_covered_m=round(rover.distance_covered, 3), alive=alive,
                        telemetry_stale=rover.stale)
