"""A pose: where a rover is and which way it faces, and where an action done from it ends.

The rover dead-reckons its own pose in the lander's frame from its completed actions (it never receives ground
truth): it starts from the pose the lander deployed it at (the Calibration message) and adds what its actions did.
A completed move ends on its goal facing along it, a completed rotate adds its angle, and a move that ended early
lands where its CancelResult says. The ROS 2 bridge does the same for the odometry it publishes, and the twin
places a real rover by its driver's telemetry the same way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from schemas.frames import bearing_deg, to_world

__all__ = ["Pose"]


@dataclass(frozen=True)
class Pose:
    """``heading`` in degrees, 0 along +z, growing to the right (``schemas.frames``)."""

    x: float
    z: float
    heading: float

    def after_move(self, rel_x: float, rel_z: float) -> Pose:
        x, z = to_world(self.x, self.z, self.heading, rel_x, rel_z)
        moved = math.hypot(rel_x, rel_z) > 1e-9
        return Pose(x, z, bearing_deg(x - self.x, z - self.z) if moved else self.heading)

    def after_rotate(self, degrees: float) -> Pose:
        return Pose(self.x, self.z, (self.heading + degrees) % 360.0)

    def after_partial(self, rel_x: float, rel_z: float, angle_deg: float) -> Pose:
        """Where an action that started at this pose actually stopped (CancelResult), or where a driver's odometry,
        relative to the pose it started at, puts the rover."""
        x, z = to_world(self.x, self.z, self.heading, rel_x, rel_z)
        return Pose(x, z, (self.heading + angle_deg) % 360.0)
