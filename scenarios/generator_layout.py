"""Where a generated scenario's things go, kept apart from what is drawn: what has been placed so far (so each new
thing keeps clear of the rest) and the plane geometry of the report's convention (heading 0 = +z, 90 = +x)."""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

from schemas.params import CommunicationParams
from schemas.scenario import Crater, LanderSpec

Point = tuple[float, float]
LANDER_RADIUS_M = LanderSpec.model_fields["radius_m"].default
RIM_WIDTH = Crater.model_fields["rim_width"].default
ROVER_COMM_RANGE_M = CommunicationParams().comm_range
"""The rovers' radio range unless a family changes it (only the daisy chain does)."""
LANDER_COMM_RANGE_M = CommunicationParams().lander_comm_range
STATION_CLEAR_M = 14.0
"""Kept free around a waypoint: a 20-rover disc formation at 3.2 m spacing reaches about 10 m."""


@dataclass
class CraterSpot:
    x: float
    z: float
    radius: float
    depth: float
    rim: float

    @property
    def outer(self) -> float:
        return self.radius * (1 + RIM_WIDTH)  # where the rim starts to rise

    def spec(self) -> dict:
        return {"x": mm(self.x), "z": mm(self.z), "radius_m": mm(self.radius), "depth_m": mm(self.depth),
                "rim_height_m": mm(self.rim)}


@dataclass
class Layout:
    """What has been placed so far, so each new thing can keep clear of it."""

    lander: Point
    rovers: list[Point] = field(default_factory=list)
    craters: list[CraterSpot] = field(default_factory=list)
    waypoints: list[Point] = field(default_factory=list)
    walls: list[tuple[Point, Point]] = field(default_factory=list)
    fields: list[tuple[Point, float]] = field(default_factory=list)

    def clear(self, p: Point, radius: float, rover_gap: float = 3.0) -> bool:
        """Whether a disc at ``p`` keeps clear of everything placed (rovers by ``rover_gap``)."""
        return (math.dist(p, self.lander) >= radius + LANDER_RADIUS_M + 8
                and all(math.dist(p, r) >= radius + rover_gap for r in self.rovers)
                and all(math.dist(p, (c.x, c.z)) >= radius + c.outer + 5 for c in self.craters)
                and all(math.dist(p, w) >= radius + STATION_CLEAR_M for w in self.waypoints)
                and all(segment_distance(p, *w) >= radius + 4 for w in self.walls)
                and all(math.dist(p, c) >= radius + r for c, r in self.fields))

    def wall_clear(self, a: Point, b: Point) -> bool:
        """A free-standing wall keeps clear of starts, the lander, craters, waypoints, fields and other walls."""
        return all(self.clear(lerp(a, b, i / 10), 4.0) for i in range(11))


def toward(p: Point, bearing_deg: float, distance: float) -> Point:
    b = math.radians(bearing_deg)
    return p[0] + distance * math.sin(b), p[1] + distance * math.cos(b)


def bearing_of(a: Point, b: Point) -> float:
    return math.degrees(math.atan2(b[0] - a[0], b[1] - a[1]))


def local(origin: Point, theta: float, ahead: float, right: float) -> Point:
    """A point ``ahead`` along heading ``theta`` and ``right`` of it, from ``origin``."""
    return toward(toward(origin, theta, ahead), theta + 90, right)


def lerp(a: Point, b: Point, t: float) -> Point:
    return a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t


def pick_leg(rng: random.Random, route: list[Point]) -> tuple[Point, Point]:
    i = rng.randrange(len(route) - 1)
    return route[i], route[i + 1]


def segment_distance(p: Point, a: Point, b: Point) -> float:
    ex, ez = b[0] - a[0], b[1] - a[1]
    t = max(0.0, min(1.0, ((p[0] - a[0]) * ex + (p[1] - a[1]) * ez) / max(ex * ex + ez * ez, 1e-12)))
    return math.dist(p, (a[0] + t * ex, a[1] + t * ez))


def mm(value: float) -> float:
    """Millimetres: short YAML, and a value that reads back exactly."""
    return round(float(value), 3)
