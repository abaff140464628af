"""Stations: where each rover of a team stands at a goal they share (need N7, a configurable formation).

The report sends every rover to the same waypoint and stops each once the goal is in view (6.6); with
20 rovers the first arrivals ring the goal and the later ones, outside the ring, never see it free. The
lander instead gives each rover its own station, laid out in the scenario's formation around the
waypoint (a hexagonal disc, or a line abreast across the direction of travel).

A rover asks for its station as it comes near (``radio.StationRequest``), so stations go out in the order
rovers arrive, and the formation fills from the inside out: each rover gets the free station nearest the
waypoint, and of those equally near, the one nearest itself. A later rover's station is then never behind
rovers already standing, whichever side it comes from (rovers leaving a crater rim arrive from all round).

At a crater the team shares the stations stand all round the crest (``rim_offsets``), and each rover takes
the free one nearest itself, so the crest fills outwards from the side the team comes from.
Pure logic: offsets in metres from the goal, in the lander's frame.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection
from typing import Literal

Shape = Literal["disc", "line"]
Offset = tuple[float, float]

SAME_RING = 0.05
"""Stations whose distances from the waypoint differ by less than this share of the spacing are equally near."""
WITHIN = 0.6
"""Every station lies within this share of the perception radius of the waypoint where the spacing allows: a
rover is at a waypoint within the perception radius, and stops within ``STATION_CLOSE_M`` of its station, so
this leaves some metres for the drift of its pose estimate. The scenario's spacing would put the outer stations
of a 20-rover disc 8.5 m out (3.2 m apart), at the edge of a 10 m radius."""


def station_offsets(count: int, spacing: float, travel_bearing_deg: float, shape: Shape = "disc",
                    allowed: Callable[[Offset], bool] | None = None) -> list[Offset]:
    """``count`` offsets ``spacing`` apart, nearest the waypoint first.

    ``allowed`` rules offsets out (one on the lander's body, say); the disc then takes the next nearest.
    """
    if count <= 0:
        return []
    rad = math.radians(travel_bearing_deg)
    fx, fz = math.sin(rad), math.cos(rad)  # forward: the direction of travel
    rx, rz = fz, -fx  # right of it

    def world(p: tuple[float, float]) -> Offset:
        a, f = p
        return round(spacing * (a * rx + f * fx), 3), round(spacing * (a * rz + f * fz), 3)

    lattice = _line(count) if shape == "line" else _hex_disc(count + 16)
    return [o for o in map(world, lattice) if allowed is None or allowed(o)][:count]


def fitted_offsets(count: int, spacing: float, travel_bearing_deg: float, shape: Shape, radius: float,
                   least_spacing: float, allowed: Callable[[Offset], bool] | None = None) -> tuple[list[Offset], float]:
    """``station_offsets`` drawn closer together, down to ``least_spacing``, where the scenario's ``spacing``
    would put a station farther than ``WITHIN`` x ``radius`` from the waypoint; and the spacing used."""
    offsets = station_offsets(count, spacing, travel_bearing_deg, shape, allowed)
    outer = max((math.hypot(*o) for o in offsets), default=0.0)
    if outer <= WITHIN * radius or spacing <= least_spacing:
        return offsets, spacing
    tighter = max(least_spacing, spacing * WITHIN * radius / outer)
    return station_offsets(count, tighter, travel_bearing_deg, shape, allowed), tighter


def pick_station(offsets: list[Offset], taken: Collection[Offset], near: Offset, spacing: float) -> Offset:
    """The station for a rover asking from ``near`` (an offset from the waypoint, like the stations): the free
    one nearest the waypoint, then nearest the rover. With every station taken (more rovers than stations),
    the nearest to the rover."""
    free = [o for o in offsets if o not in taken] or offsets
    inner = min(math.hypot(*o) for o in free)
    ring = [o for o in free if math.hypot(*o) - inner < SAME_RING * spacing]
    return min(ring, key=lambda o: (round(math.dist(o, near), 6), o))


def _hex_disc(count: int) -> list[tuple[float, float]]:
    """The ``count`` points of a unit hexagonal lattice nearest its centre, nearest first, as (across, along)."""
    rings = math.ceil(math.sqrt(count)) + 1
    row = math.sqrt(3) / 2
    points = [(i + (j % 2) / 2, j * row) for j in range(-rings, rings + 1) for i in range(-rings, rings + 1)]
    return sorted(points, key=lambda p: (round(math.hypot(*p), 6), -p[1], abs(p[0])))[:count]


def _line(count: int) -> list[tuple[float, float]]:
    """Centre first, then outwards, alternating sides."""
    half = (count - 1) / 2
    return sorted(((i - half, 0.0) for i in range(count)), key=lambda p: (abs(p[0]), p[0]))


def rim_offsets(count: int, radius: float, spacing: float, least_spacing: float) -> tuple[list[Offset], float]:
    """Stations on a crater's crest, all round it, ``spacing`` apart along the crest, as offsets from the crater's
    centre; drawn closer, down to ``least_spacing``, where the team would not fit round the crest; and the spacing
    used. A team heading for the same crest point crowds it, and the rovers held behind those on the crest stand
    off it (short of the goal): on a 12 m crater a 20-rover team's first arrivals took the near crest, 1.6 m
    apart, and the later ones stopped 3 m outside it."""
    circumference = 2 * math.pi * radius
    if count * spacing > circumference:
        spacing = max(least_spacing, circumference / count)
    fit = max(1, math.floor(circumference / spacing + 1e-9))
    step = 2 * math.pi / fit
    return [(round(radius * math.sin(k * step), 3), round(radius * math.cos(k * step), 3)) for k in range(fit)], spacing


def pick_rim_station(offsets: list[Offset], taken: Collection[Offset], near: Offset) -> Offset:
    """The free crest station nearest the asking rover (``near``, from the same point as ``offsets``): rovers
    arriving from one side fill the crest outwards from where they come, each walking the least way round. A
    team larger than the crest holds (``rim_offsets`` at its least spacing) shares stations."""
    free = [o for o in offsets if o not in taken] or offsets
    return min(free, key=lambda o: (round(math.dist(o, near), 6), o))
