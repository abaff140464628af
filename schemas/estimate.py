"""A rover's own estimate of where it stands and how sure it is: what its agent believes, for the ground, the ROS 2
bridge (``odom``) and the recorder. Never ground truth: the world does not read it, and no agent reads another's
from here (teammates hear ``radio.PoseEstimate`` over the radio, in range only)."""

from __future__ import annotations

import math
from typing import Annotated

from msgspec import Meta

from schemas.base import Message
from schemas.wire_limits import (
    COV_ROUNDING_M2,
    MAX_HEADING_VARIANCE_RAD2,
    MAX_VARIANCE_M2,
    Coordinate,
    Degrees,
    Stamp,
)

MAX_CROSS = math.sqrt(MAX_VARIANCE_M2 * MAX_HEADING_VARIANCE_RAD2)
"""The largest position-heading covariance two bounded variances allow (metre-radians)."""


class EstimatedPose(Message, kw_only=True):
    """The agent's localisation (``rover_agent.estimation.pose_filter``): its mean in the lander's frame and its
    3x3 covariance over (x, z, heading). ``cov_xx``, ``cov_xz``, ``cov_zz`` in square metres, ``cov_xh``, ``cov_zh``
    in metre-radians, ``cov_hh`` in square radians (heading positive to the right, as ``heading_deg``). All zero: the
    estimate is exact (a mission without navigation noise). ``moving``: an action was under way; the pose is then
    where the move has got to."""

    stamp: Stamp
    x: Coordinate
    z: Coordinate
    heading_deg: Degrees
    cov_xx: Annotated[float, Meta(ge=0, le=MAX_VARIANCE_M2)] = 0.0
    cov_xz: Annotated[float, Meta(ge=-MAX_VARIANCE_M2, le=MAX_VARIANCE_M2)] = 0.0
    cov_zz: Annotated[float, Meta(ge=0, le=MAX_VARIANCE_M2)] = 0.0
    cov_xh: Annotated[float, Meta(ge=-MAX_CROSS, le=MAX_CROSS)] = 0.0
    cov_zh: Annotated[float, Meta(ge=-MAX_CROSS, le=MAX_CROSS)] = 0.0
    cov_hh: Annotated[float, Meta(ge=0, le=MAX_HEADING_VARIANCE_RAD2)] = 0.0
    moving: bool = False

    def __post_init__(self) -> None:
        """Each off-diagonal entry within what its two variances allow (rounding aside): a receiver shows it as
        an ellipse and hands it to ROS nodes that invert it."""
        for name, off, a, b in (("cov_xz", self.cov_xz, self.cov_xx, self.cov_zz),
                                ("cov_xh", self.cov_xh, self.cov_xx, self.cov_hh),
                                ("cov_zh", self.cov_zh, self.cov_zz, self.cov_hh)):
            if abs(off) > math.sqrt((a + COV_ROUNDING_M2) * (b + COV_ROUNDING_M2)) + COV_ROUNDING_M2:
                raise ValueError(f"{name} {off} makes no covariance with its variances {a} and {b}")

    def matrix(self) -> list[list[float]]:
        """The covariance as rows and columns (x, z, heading)."""
        return [[self.cov_xx, self.cov_xz, self.cov_xh], [self.cov_xz, self.cov_zz, self.cov_zh],
                [self.cov_xh, self.cov_zh, self.cov_hh]]
