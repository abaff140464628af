"""Stations: where each rover of a team stands at a waypoint they share (need N7, a configurable formation).

The report sends every rover to the same waypoint and stops each once the goal is in view (6.6); with
20 rovers the first arrivals ring the goal and the later ones, outside the ring, never see it free. The
lander instead gives each rover its own station, laid out in the scenario's formation around the
waypoint (a hexagonal disc, or a line abreast across the direction of travel). Stations are handed out
far side first, in the order the rovers are sent, so a rover rarely has to squeeze between others
already standing. Pure logic: offsets in metres from the waypoint, in the lander's frame.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal

Shape = Literal["disc", "line"]


def station_offsets(count: int, spacing: float, travel_bearing_deg: float, shape: Shape = "disc",
                    allowed: Callable[[tuple[float, float]], bool] | None = None) -> list[tuple[float, float]]:
    """``count`` offsets ``spacing`` apart, far side (along the direction of travel) first.

    ``allowed`` rules offsets out (one on the lander's body, say); the disc then takes the next nearest.
    """
    if count <= 0:
        return []
    rad = math.radians(travel_bearing_deg)
    fx, fz = math.sin(rad), math.cos(rad)  # forward: the direction of travel
    rx, rz = fz, -fx  # right of it

    def world(p: tuple[float, float]) -> tuple[float, float]:
        a, f = p
        return round(spacing * (a * rx + f * fx), 3), round(spacing * (a * rz + f * fz), 3)

    lattice = _line(count) if shape == "line" else _hex_disc(count + 16)
    chosen = [p for p in lattice if allowed is None or allowed(world(p))][:count]
    rows = sorted(chosen, key=lambda p: (-round(p[1], 6), abs(p[0]), p[0]))
    return [world(p) for p in rows]


def _hex_disc(count: int) -> list[tuple[float, float]]:
    """The ``count`` points of a unit hexagonal lattice nearest its centre, nearest first, as (across, along)."""
    rings = math.ceil(math.sqrt(count)) + 1
    row = math.sqrt(3) / 2
    points = [(i + (j % 2) / 2, j * row) for j in range(-rings, rings + 1) for i in range(-rings, rings + 1)]
    return sorted(points, key=lambda p: (round(math.hypot(*p), 6), -p[1], abs(p[0])))[:count]


def _line(count: int) -> list[tuple[float, float]]:
    return [((i - (count - 1) / 2), 0.0) for i in range(count)]
