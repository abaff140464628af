"""Where the sun stands over the site, as simulation time goes on.

A scenario's ``sun`` block fixes it (azimuth and elevation) or gives the site's latitude and the local time
of the lunar day; the sun then follows the Moon's rotation relative to the sun, one synodic day
(29.53 Earth days) per turn. The Moon's axis is tilted only 1.54 degrees to the ecliptic, so the sun's
declination stays within that and is taken as constant over a mission; at the report's far-side polar sites
the sun therefore never climbs more than a few degrees and circles the horizon, which is what makes long
shadows there.

Map axes as everywhere in LunarSim: +z north, +x east, y up; an azimuth is a heading (0 = the sun shines
from +z, 90 = from +x). Positions are quantised to ``step_deg`` so shadow results can be cached per step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from schemas.scenario import SunSpec

SYNODIC_DAY_S = 29.530589 * 86400.0
"""The lunar day: from one local noon to the next."""


@dataclass(frozen=True)
class SunPosition:
    azimuth_deg: float
    elevation_deg: float

    @property
    def up(self) -> bool:
        return self.elevation_deg > 0.0

    @property
    def vector(self) -> np.ndarray:
        """Unit vector (x, y, z) from the ground towards the sun."""
        az, el = math.radians(self.azimuth_deg), math.radians(self.elevation_deg)
        return np.array([math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el)])


def from_site(latitude_deg: float, declination_deg: float, hour_angle_deg: float) -> SunPosition:
    """Sun position for an observer at ``latitude_deg`` when the sun's hour angle is ``hour_angle_deg``
    (0 at local noon, positive in the afternoon): the standard horizon-coordinates formulas."""
    phi, dec, h = (math.radians(v) for v in (latitude_deg, declination_deg, hour_angle_deg))
    elevation = math.asin(max(-1.0, min(1.0, math.sin(phi) * math.sin(dec)
                                        + math.cos(phi) * math.cos(dec) * math.cos(h))))
    azimuth = math.atan2(-math.cos(dec) * math.sin(h),
                         math.sin(dec) * math.cos(phi) - math.cos(dec) * math.sin(phi) * math.cos(h))
    return SunPosition(math.degrees(azimuth) % 360.0, math.degrees(elevation))


class Sun:
    """The sun of one scenario: ``at(t)`` is its quantised position ``t`` simulated seconds in."""

    def __init__(self, spec: SunSpec) -> None:
        self.spec = spec

    def exact(self, sim_time: float) -> SunPosition:
        s = self.spec
        if s.latitude_deg is None:
            return SunPosition(s.azimuth_deg % 360.0, s.elevation_deg)
        hour_angle = 360.0 * (s.hours_after_noon * 3600.0 + sim_time) / SYNODIC_DAY_S
        return from_site(s.latitude_deg, s.declination_deg, hour_angle)

    def at(self, sim_time: float) -> SunPosition:
        """The position rounded to the step, so every tick within one step shares shadow results."""
        exact, step = self.exact(sim_time), self.spec.step_deg
        return SunPosition(round(exact.azimuth_deg / step) * step % 360.0,
                           round(exact.elevation_deg / step) * step)
