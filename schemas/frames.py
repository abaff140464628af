"""Frame conventions every process shares (report 10.2.3): headings 0 = +z, 90 = +x, positive to the right.

Rover-relative coordinates put +z straight ahead and +x to the right. Pure ``math``: the rover agent uses it.
"""

from __future__ import annotations

import math


def wrap_deg(angle: float) -> float:
    """Wrap to [-180, 180)."""
    return (angle + 180.0) % 360.0 - 180.0


def bearing_deg(dx: float, dz: float) -> float:
    """Heading that points along (dx, dz)."""
    return math.degrees(math.atan2(dx, dz)) % 360.0


def to_world(x: float, z: float, heading_deg: float, rel_x: float, rel_z: float) -> tuple[float, float]:
    """A rover-relative point, seen from a rover at (x, z) facing ``heading_deg``, in the outer frame."""
    h = math.radians(heading_deg)
    return x + rel_z * math.sin(h) + rel_x * math.cos(h), z + rel_z * math.cos(h) - rel_x * math.sin(h)


def to_relative(x: float, z: float, heading_deg: float, wx: float, wz: float) -> tuple[float, float]:
    """Inverse of ``to_world``."""
    h = math.radians(heading_deg)
    dx, dz = wx - x, wz - z
    return dx * math.cos(h) - dz * math.sin(h), dx * math.sin(h) + dz * math.cos(h)
