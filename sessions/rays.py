"""Where perception's rays point: a scan reports its hits only, so a viewer that draws every ray (a ROS
``LaserScan``, Foxglove's) finds the rays that met nothing from the layout. One layout for the ROS 2 bridge, its
rosbag2 export and ``lunarsim view --foxglove``."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from schemas.params import PerceptionParams


@dataclass(frozen=True)
class RayLayout:
    """Where perception's rays point (``schemas.params.PerceptionParams``): a scan reports hits only, so the rays
    with none are found from the layout."""

    fov_deg: float = 210.0
    rays: int = 50
    radius_m: float = 10.0
    period_s: float = 0.2

    @classmethod
    def of(cls, p: PerceptionParams) -> RayLayout:
        return cls(p.field_of_view_degrees, p.perception_granularity, p.perception_radius, 1.0 / p.publish_frequency)

    @property
    def step_rad(self) -> float:
        return math.radians(self.fov_deg) / (self.rays - 1)

    def indices(self, angles_deg: list[float]) -> list[int]:
        """The ``LaserScan`` index of each hit's ray; ValueError when no ray of this layout points there."""
        place = (np.radians(-np.asarray(angles_deg, float)) + math.radians(self.fov_deg) / 2) / self.step_rad
        index = np.rint(place)
        off = (np.abs(place - index) > 0.25) | (index < 0) | (index >= self.rays)
        if off.any():
            angle = float(np.asarray(angles_deg)[off][0])
            raise ValueError(f"a hit at {angle:g} deg is on no ray of a {self.fov_deg:g} deg, {self.rays}-ray "
                             "scan (is the bridge's --params the world's?)")
        return index.astype(int).tolist()
