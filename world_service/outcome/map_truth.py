"""Ground truth for the lander's traverse map, and how well a map matches it.

Only the world's side (the launcher's report, ``lunarsim report``) uses this: the lander never sees truth.
Every function takes the map's grid (origin, cell size, shape) and class codes as plain arrays, so the same
code scores ``map.npz`` after a run and the last ``lander/map`` sample of a recording.

Truth on the map's grid:
- obstacle: a cell any part of which a rock (rock fields included), a wall or the lander covers, found by
  sampling ``SUBSAMPLES`` x ``SUBSAMPLES`` points per cell;
- crater: a cell whose centre lies within a crater's outer rim (radius x (1 + rim_width)).

The corridor A-B: cells whose centre lies within ``CORRIDOR_HALF_WIDTH_M`` of the path from A, the centroid of
the rovers' start positions, through each goal in order, a crater goal ending at the crest point nearest the
leg's start (as for the relative path length in ``statistics``).

Figures (each None when what it divides by is empty):
- ``corridor_mapped``: share of the corridor's cells the map knows (any class but unknown);
- ``obstacles_found``: share of the truth's obstacle cells in the corridor that have a mapped obstacle cell
  within ``MATCH_TOLERANCE_M``;
- ``obstacle_precision``: share of the map's obstacle cells (anywhere) that have a truth obstacle cell within
  ``MATCH_TOLERANCE_M``.
The tolerance forgives the cell a surface point falls in by rounding and a little dead-reckoning drift; a map
that put obstacles where there are none, or missed them, still scores low.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from schemas.scenario import Scenario
from world_service import geometry as geo
from world_service.outcome.statistics import arrival_point
from world_service.scene import scatter_rock_fields

CORRIDOR_HALF_WIDTH_M = 10.0
"""Half the corridor's width: the default perception radius, what a rover on the path sees to either side."""
MATCH_TOLERANCE_M = 1.0
SUBSAMPLES = 4
UNKNOWN, OBSTACLE_CODE = 0, 2
"""Class codes of the map (``lander_agent.mapping.CLASSES``) this module reads."""


class Grid(Protocol):
    """The map's grid (``lander_agent.mapping.GridSpec``): cell (row j, column i) covers
    [origin_x + i * cell_m, ...) x [origin_z + j * cell_m, ...)."""

    origin_x: float
    origin_z: float
    cell_m: float
    width: int
    height: int


def _centres(grid: Grid) -> tuple[np.ndarray, np.ndarray]:
    """Cell-centre x (1, width) and z (height, 1), broadcastable to the grid."""
    return (grid.origin_x + (np.arange(grid.width)[None, :] + 0.5) * grid.cell_m,
            grid.origin_z + (np.arange(grid.height)[:, None] + 0.5) * grid.cell_m)


@dataclass(frozen=True)
class MapFigures:
    corridor_mapped: float | None
    obstacles_found: float | None
    obstacle_precision: float | None
    corridor_cells: int
    truth_obstacle_cells: int
    map_obstacle_cells: int

    def report_fields(self) -> dict[str, float | None]:
        """The ``MissionReport`` fields these figures fill."""
        return {"map_corridor_mapped": self.corridor_mapped, "map_obstacles_found": self.obstacles_found,
                "map_obstacle_precision": self.obstacle_precision}


def truth_obstacles(scenario: Scenario, grid: Grid) -> np.ndarray:
    """Bool (height, width): cells that rocks, walls or the lander cover."""
    out = np.zeros((grid.height, grid.width), bool)
    rocks = list(scenario.obstacles.rocks) + scatter_rock_fields(scenario)
    discs = [(r.x, r.z, r.radius_m) for r in rocks] + [(scenario.lander.x, scenario.lander.z,
                                                         scenario.lander.radius_m)]
    for x, z, r in discs:
        _mark(out, grid, (x - r, x + r, z - r, z + r), lambda px, pz, x=x, z=z, r=r: np.hypot(px - x, pz - z) <= r)
    for wall in scenario.obstacles.walls:
        half = wall.thickness_m / 2
        for (x0, z0), (x1, z1) in zip(wall.points, wall.points[1:], strict=False):
            box = (min(x0, x1) - half, max(x0, x1) + half, min(z0, z1) - half, max(z0, z1) + half)
            _mark(out, grid, box, lambda px, pz, a=(x0, z0, x1, z1), h=half:
                  geo.point_segment_distance(px, pz, *a)[..., 0] <= h)
    return out


def _mark(out: np.ndarray, grid: Grid, box: tuple[float, float, float, float], inside) -> None:
    """Set the cells of ``box`` (x0, x1, z0, z1) in which any of their sample points is ``inside``."""
    c = grid.cell_m
    i0, i1 = max(0, math.floor((box[0] - grid.origin_x) / c)), min(grid.width, math.floor((box[1] - grid.origin_x)
                                                                                          / c) + 1)
    j0, j1 = max(0, math.floor((box[2] - grid.origin_z) / c)), min(grid.height, math.floor((box[3] - grid.origin_z)
                                                                                           / c) + 1)
    if i0 >= i1 or j0 >= j1:
        return
    sub = (np.arange(SUBSAMPLES) + 0.5) / SUBSAMPLES
    px = grid.origin_x + (np.arange(i0, i1)[:, None] + sub[None, :]).ravel() * c
    pz = grid.origin_z + (np.arange(j0, j1)[:, None] + sub[None, :]).ravel() * c
    hit = inside(px[None, :], pz[:, None]).reshape(j1 - j0, SUBSAMPLES, i1 - i0, SUBSAMPLES)
    out[j0:j1, i0:i1] |= hit.any(axis=(1, 3))


def corridor_path(scenario: Scenario) -> list[tuple[float, float]]:
    """A (the rovers' start centroid), then where each goal is reached, in order."""
    here = (sum(r.x for r in scenario.rovers) / len(scenario.rovers),
            sum(r.z for r in scenario.rovers) / len(scenario.rovers))
    path = [here]
    for goal in scenario.mission:
        path.append(arrival_point(scenario, goal, path[-1]))
    return path


def corridor(scenario: Scenario, grid: Grid, half_width_m: float = CORRIDOR_HALF_WIDTH_M) -> np.ndarray:
    """Bool (height, width): cells whose centre is within ``half_width_m`` of the A-B path."""
    path = np.array(corridor_path(scenario))
    x, z = _centres(grid)
    px, pz = np.broadcast_arrays(x, z)
    d = geo.point_segment_distance(px.ravel(), pz.ravel(), path[:-1, 0], path[:-1, 1], path[1:, 0], path[1:, 1])
    return (d.min(axis=1) <= half_width_m).reshape(grid.height, grid.width)


def dilate(mask: np.ndarray, cells: int) -> np.ndarray:
    """Cells within ``cells`` cells (a square neighbourhood) of a set cell."""
    if cells <= 0:
        return mask.copy()
    padded = np.pad(mask, cells)
    out = np.zeros_like(mask)
    h, w = mask.shape
    for dj in range(2 * cells + 1):
        for di in range(2 * cells + 1):
            out |= padded[dj:dj + h, di:di + w]
    return out


def map_figures(scenario: Scenario, grid: Grid, classes: np.ndarray,
                half_width_m: float = CORRIDOR_HALF_WIDTH_M, tolerance_m: float = MATCH_TOLERANCE_M) -> MapFigures:
    """Score a map (class codes on ``grid``) against the scenario's truth."""
    if classes.shape != (grid.height, grid.width):
        raise ValueError(f"map classes {classes.shape} do not match the grid {(grid.height, grid.width)}")
    lane = corridor(scenario, grid, half_width_m)
    truth = truth_obstacles(scenario, grid)
    mapped = classes == OBSTACLE_CODE
    reach = math.ceil(tolerance_m / grid.cell_m - 1e-9)
    wanted = truth & lane
    return MapFigures(
        corridor_mapped=_share((classes != UNKNOWN) & lane, lane),
        obstacles_found=_share(wanted & dilate(mapped, reach), wanted),
        obstacle_precision=_share(mapped & dilate(truth, reach), mapped),
        corridor_cells=int(lane.sum()), truth_obstacle_cells=int(wanted.sum()), map_obstacle_cells=int(mapped.sum()))


def _share(part: np.ndarray, whole: np.ndarray) -> float | None:
    n = int(whole.sum())
    return round(int(part.sum()) / n, 4) if n else None
