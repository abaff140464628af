"""LunarSim's axes as ROS's (REP 103, REP 105), the conversion ``sessions.foxglove`` makes for Foxglove.

LunarSim's ground plane is x/z with the height along y, headings 0 = +z and 90 = +x, positive to the right;
rover-relative points put +z ahead and +x to the right; pitch is positive nose up. ROS is x forward, y left, z up,
angles counter-clockwise. So a map point (x, z, height) is ROS (x, y, z) = (x, z, height), a heading h is the yaw
90 deg - h, a rover-relative (x right, z ahead) is ``base_link`` (z, -x), an angle to the right is a negative yaw,
and a nose-up pitch is a negative rotation about ``base_link``'s y axis.

Frames: ``map`` is the scenario's map frame (the lander's traverse map, the ground's goals, ground truth);
``rover_<id>/odom`` is where the rover's odometry starts (the lander-centred frame its calibration gives, map
axes); ``rover_<id>/base_link`` is the rover itself.
"""

from __future__ import annotations

import math
from typing import Any

MAP_FRAME = "map"


def base_link(rover_id: int) -> str:
    return f"rover_{rover_id}/base_link"


def odom_frame(rover_id: int) -> str:
    return f"rover_{rover_id}/odom"


def yaw_of_heading(heading_deg: float) -> float:
    """ROS yaw (radians, counter-clockwise from +x) of a LunarSim heading (degrees, clockwise from +z)."""
    return math.radians(90.0 - heading_deg)


def heading_of_yaw(yaw_rad: float) -> float:
    return (90.0 - math.degrees(yaw_rad)) % 360.0


def quaternion(roll: float = 0.0, pitch: float = 0.0, yaw: float = 0.0) -> dict[str, float]:
    """A ROS quaternion from roll, pitch and yaw (radians, fixed axes x, y, z in that order)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return {"x": sr * cp * cy - cr * sp * sy, "y": cr * sp * cy + sr * cp * sy,
            "z": cr * cp * sy - sr * sp * cy, "w": cr * cp * cy + sr * sp * sy}


def yaw_of(q: dict[str, Any]) -> float:
    """The yaw (rotation about z) of a ROS quaternion; ValueError for one that is not a rotation."""
    x, y, z, w = (float(q[k]) for k in ("x", "y", "z", "w"))
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if not math.isfinite(norm) or norm < 1e-6:
        raise ValueError("orientation is not a rotation (zero or non-finite quaternion)")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def relative_to_base_link(rel_x: float, rel_z: float) -> tuple[float, float]:
    """A rover-relative point (x right, z ahead) in ``base_link`` (x ahead, y left)."""
    return rel_z, -rel_x


def base_link_to_relative(x: float, y: float) -> tuple[float, float]:
    """The inverse: ``base_link`` (x ahead, y left) -> rover-relative (x right, z ahead)."""
    return -y, x


def ray_angle(angle_deg: float) -> float:
    """A perception angle (degrees, negative left) as a ``base_link`` bearing (radians, positive left)."""
    return -math.radians(angle_deg)


def pitch_angle(pitch_deg: float) -> float:
    """A nose-up pitch (degrees) as the rotation about ``base_link``'s y axis (radians)."""
    return -math.radians(pitch_deg)


def stamp(seconds: float) -> dict[str, int]:
    """``builtin_interfaces/Time`` of a simulated time (non-negative: the clock starts at 0)."""
    ns = max(0, round(seconds * 1e9))
    return {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}


def seconds(time: dict[str, Any]) -> float:
    return int(time["sec"]) + int(time["nanosec"]) * 1e-9


def header(seconds_: float, frame_id: str) -> dict[str, Any]:
    return {"stamp": stamp(seconds_), "frame_id": frame_id}
