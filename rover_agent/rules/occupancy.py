"""The rover's memory of the static things it has seen: a sparse occupancy grid in its own (lander) frame, which
the planner (``planner``) searches. Pure standard library: it runs on the flight computer."""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from rover_agent.decisions import Hit
    from shared.pose import Pose

Cell = tuple[int, int]
Point = tuple[float, float]

TIE = 1e-9
"""Slack in comparisons of cell distances, so a point exactly on a boundary counts the same every time."""
STATIC_KINDS = frozenset({"obstacle", "terrain", "lander"})
"""Perceived kinds worth remembering: they stay put. Rovers move and crater terrain is walkable."""


class OccupancyGrid:
    """Sparse, unbounded grid of cells ``cell_m`` wide; cell (i, j) is centred on (i * cell_m, j * cell_m).

    Each cell that ever had a hit keeps two counts: scans that hit something in it and scans whose free rays
    crossed it. It is blocked while it has hits and has not been seen free more often, so one noisy hit (or
    a wall placed slightly wrong by dead-reckoning drift) can be outvoted by looking through it again, while
    a wall seen many times is not erased by one grazing ray. Only cells with hits are counted, which keeps
    the memory proportional to the obstacles seen, not to the ground covered.
    """

    def __init__(self, cell_m: float = 1.0) -> None:
        if cell_m <= 0:
            raise ValueError("cell_m must be positive")
        self.cell_m = float(cell_m)
        self._hits: dict[Cell, int] = {}
        self._free: dict[Cell, int] = {}
        self._blocked: set[Cell] = set()
        self._version = 0
        self._inflated: dict[float, frozenset[Cell]] = {}
        self._inflated_version = -1

    def cell_of(self, x: float, z: float) -> Cell:
        """Rounded, not floored, so points on whole cell centres do not flip cells on float noise."""
        c = self.cell_m
        return math.floor(x / c + 0.5), math.floor(z / c + 0.5)

    def centre_of(self, i: int, j: int) -> Point:
        return i * self.cell_m, j * self.cell_m

    def blocked(self, i: int, j: int) -> bool:
        return (i, j) in self._blocked

    def block(self, cells: Iterable[Cell]) -> None:
        """Mark cells as hit once each: for a map known in advance (and for tests)."""
        cells = set(cells)
        for cell in cells:
            self._hits[cell] = self._hits.get(cell, 0) + 1
        self._refresh(cells)

    def observe(self, pose: Pose, hits: Iterable[Hit], radius: float, free_angles: Iterable[float] = ()) -> None:
        """Add one scan taken at ``pose``: static hits count against their cells, free rays for them.

        ``free_angles`` are the relative angles (degrees, negative left) of rays that hit nothing within
        ``radius``. A cell hit in this scan is not also counted free by it: a ray grazing a wall's cell does
        not contradict the hit inside it. A hit beyond ``radius`` is none a sensor makes: kept, one forged a
        kilometre off would stretch every plan's search over the ground between (``planner``).
        """
        hit_cells = {self.cell_of(*ray_point(pose, h.angle_deg, h.distance_m))
                     for h in hits if h.kind in STATIC_KINDS and h.distance_m <= radius}  # a forged one, not kept
        for cell in hit_cells:
            self._hits[cell] = self._hits.get(cell, 0) + 1
        seen_free: set[Cell] = set()
        if self._hits:  # only cells that ever had a hit are counted free: with none, no ray need be walked
            seen_free = {c for c in self._ray_cells(pose, free_angles, radius) if c in self._hits} - hit_cells
        for cell in seen_free:
            self._free[cell] = self._free.get(cell, 0) + 1
        self._refresh(hit_cells | seen_free)

    def _ray_cells(self, pose: Pose, angles: Iterable[float], radius: float) -> set[Cell]:
        """Cells under rays walked in half-cell steps out to ``radius``."""
        c, floor = self.cell_m, math.floor
        step = c / 2
        steps = int(radius / step + TIE)
        x, z = pose.x, pose.z
        cells: set[Cell] = set()
        for angle in angles:
            h = math.radians(pose.heading + angle)
            sx, sz = step * math.sin(h), step * math.cos(h)  # cell_of inlined: this walks thousands of points
            cells.update((floor((x + k * sx) / c + 0.5), floor((z + k * sz) / c + 0.5)) for k in range(1, steps + 1))
        return cells

    def _refresh(self, cells: Iterable[Cell]) -> None:
        for cell in cells:
            hits = self._hits.get(cell, 0)
            now = hits >= 1 and self._free.get(cell, 0) <= hits
            if now != (cell in self._blocked):
                (self._blocked.add if now else self._blocked.discard)(cell)
                self._version += 1

    def inflated(self, clearance_m: float) -> frozenset[Cell]:
        """Cells whose centre lies within ``clearance_m`` of a blocked cell's centre (cached until the map
        changes: the rover plans every decision but its map changes only when it sees something new)."""
        if self._inflated_version != self._version:
            self._inflated, self._inflated_version = {}, self._version
        cells = self._inflated.get(clearance_m)
        if cells is None:
            offsets = disc_offsets(clearance_m / self.cell_m)
            cells = frozenset((i + di, j + dj) for i, j in self._blocked for di, dj in offsets)
            self._inflated[clearance_m] = cells
        return cells


def ray_point(pose: Pose, angle_deg: float, distance_m: float) -> Point:
    """Where a perception hit at a relative angle (negative left) and distance lies in the pose's frame."""
    h = math.radians(pose.heading + angle_deg)
    return pose.x + distance_m * math.sin(h), pose.z + distance_m * math.cos(h)


def disc_offsets(radius_cells: float) -> list[Cell]:
    """Cell offsets whose centres lie within ``radius_cells`` of the origin's centre (the origin included)."""
    r = math.ceil(radius_cells)
    limit = radius_cells * radius_cells + TIE
    return [(di, dj) for di in range(-r, r + 1) for dj in range(-r, r + 1) if di * di + dj * dj <= limit]


def segment_clear(a: Point, b: Point, forbidden: frozenset[Cell] | set[Cell], cell_m: float) -> bool:
    """Whether the segment a-b crosses no forbidden cell.

    Walks every cell the segment touches (an exact grid traversal, including both neighbours where it
    passes through a cell corner) rather than sampling points, so it cannot slip past the corner of a
    forbidden cell, and it costs one step per cell crossed.
    """
    x0, z0 = a[0] / cell_m + 0.5, a[1] / cell_m + 0.5
    x1, z1 = b[0] / cell_m + 0.5, b[1] / cell_m + 0.5
    i, j = math.floor(x0), math.floor(z0)
    steps = abs(math.floor(x1) - i) + abs(math.floor(z1) - j)
    si, ti, dti = _axis(x0, x1, i)
    sj, tj, dtj = _axis(z0, z1, j)
    if (i, j) in forbidden:
        return False
    for _ in range(steps):
        if abs(ti - tj) < TIE and ((i + si, j) in forbidden or (i, j + sj) in forbidden):
            return False
        if ti < tj:
            i, ti = i + si, ti + dti
        else:
            j, tj = j + sj, tj + dtj
        if (i, j) in forbidden:
            return False
    return True


def _axis(u0: float, u1: float, cell: int) -> tuple[int, float, float]:
    """Step direction, parameter of the first cell boundary, and parameter per cell, along one axis."""
    du = u1 - u0
    if du == 0:
        return 0, math.inf, math.inf
    per_cell = 1.0 / abs(du)
    first = (cell + 1 - u0) if du > 0 else (u0 - cell)
    return (1 if du > 0 else -1), first * per_cell, per_cell
