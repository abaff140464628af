"""ROS 2 messages into LunarSim: what a ROS node may ask of a rover or of the ground, as LunarSim's messages.

Pure: a decoded ROS dict in, LunarSim messages out, or ``ValueError`` saying why it is refused (a frame other than
the one the topic takes, a value outside the message model's bounds, a non-finite number). Each message is built
from a ROS node's values, so each goes through ``codec.checked`` (a Struct checks nothing when built). Action ids
are the caller's (``ros2_bridge.translator``): the world matches each action's answers to its id.
"""

from __future__ import annotations

import math
import uuid
from dataclasses import dataclass
from typing import Any

from ros2_bridge import frames as fr
from schemas import codec
from schemas import messages as m
from schemas.frames import wrap_deg

Fields = dict[str, Any]
MIN_MOVE_M = 0.01
"""A goal closer than this is a rotation on the spot."""
MIN_TURN_DEG = 0.5
"""A goal's orientation this close to the rover's heading after the move asks for no rotation."""


@dataclass(frozen=True)
class Goal:
    """A move goal as LunarSim actions: a move (or none), then a rotation (or none)."""

    move: tuple[float, float] | None
    """Rover-relative (x right, z ahead), metres."""
    rotate_deg: float | None
    """Positive to the right."""


def _finite(*values: Any) -> list[float]:
    out = [float(v) for v in values]
    if not all(math.isfinite(v) for v in out):
        raise ValueError("a coordinate is not a finite number")
    return out


def _frame(fields: Fields, expected: str) -> None:
    given = fields["header"]["frame_id"]
    if given != expected:
        raise ValueError(f"frame {given[:40]!r}: this topic takes {expected!r}")


def move_goal(fields: Fields, rover_id: int) -> Goal:
    """A ``PoseStamped`` in ``rover_<id>/base_link``: its position is a move (the rover ends it facing along it),
    its orientation the heading to turn to after it; an all-zero quaternion asks for no particular heading."""
    _frame(fields, fr.base_link(rover_id))
    pose = fields["pose"]
    x, y = _finite(pose["position"]["x"], pose["position"]["y"])
    q = pose["orientation"]
    wanted = None if not any(float(q[k]) for k in ("x", "y", "z", "w")) else math.degrees(fr.yaw_of(q))
    if math.hypot(x, y) < MIN_MOVE_M:
        if wanted is None:
            raise ValueError("a goal at the rover's own place with no orientation asks for nothing")
        return Goal(None, _check_turn(-wanted))
    rel_x, rel_z = fr.base_link_to_relative(x, y)
    codec.checked(m.MoveAction(x=rel_x, z=rel_z))  # the model's bounds, refused here rather than by the world
    turn = None
    if wanted is not None:
        after = wrap_deg(-(wanted - math.degrees(math.atan2(y, x))))
        turn = after if abs(after) >= MIN_TURN_DEG else None
    return Goal((rel_x, rel_z), turn)


def _check_turn(degrees: float) -> float:
    return codec.checked(m.RotateAction(degrees=wrap_deg(degrees))).degrees


def speed(fields: Fields) -> m.SpeedAction:
    """``std_msgs/UInt8``: the speed level, 1 to 3."""
    return codec.checked(m.SpeedAction(level=int(fields["data"])))


def photo_request(fields: Fields) -> m.PhotoAction:
    """``std_msgs/String``: the photo's label (printable, at most ``MAX_LABEL`` characters)."""
    return codec.checked(m.PhotoAction(label=fields["data"]))


def ground_goal(fields: Fields) -> m.GroundCommand:
    """``PointStamped`` in ``map``: the ground's new target for every rover (``set_target``, a waypoint)."""
    _frame(fields, fr.MAP_FRAME)
    x, y = _finite(fields["point"]["x"], fields["point"]["y"])
    return codec.checked(m.GroundCommand(request_id=f"ros2-{uuid.uuid4().hex[:12]}", command="set_target", x=x,
                                         z=y))
