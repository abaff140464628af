"""Dead reckoning: the rover's pose in the lander's frame, from its own completed actions only.

The rover never receives ground truth (design doc). It starts from the pose the lander deployed it at
(the Calibration message) and adds what its actions did: a completed move ends on its goal facing along
it, a completed rotate adds its angle, and a move that ended early lands where its CancelResult says.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from schemas.frames import bearing_deg, to_world


@dataclass(frozen=True)
class Pose:
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
        """Where an action that started at this pose actually stopped (CancelResult)."""
        x, z = to_world(self.x, self.z, self.heading, rel_x, rel_z)
        return Pose(x, z, (self.heading + angle_deg) % 360.0)
