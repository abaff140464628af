"""What stands on the ground: rocks, walls, the lander and crater rims, as arrays built once per scenario.

Perception (``perception``), the move check and collision detection all ask "what does this line or this
disc meet?", so they share these arrays. Rock fields are expanded here, from the scenario's seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from schemas.messages import HIT_KINDS
from schemas.scenario import Rock, Scenario
from world_service import geometry as geo

KIND_CODE = {kind: i for i, kind in enumerate(HIT_KINDS)}
GRID_CELL_M = 10.0
ROVER, OBSTACLE, TERRAIN, LANDER, CRATER = (KIND_CODE[k] for k in HIT_KINDS)


FEW_PAIRS = 4096
"""Up to this many (point, circle) pairs, they are all tested at once: building or searching a grid for a handful
of rovers and rocks costs ten times more than the test it saves."""


def near_pairs(px, pz, cx, cz, cr, reach: float) -> tuple[np.ndarray, np.ndarray]:
    near = np.hypot(cx[None, :] - px[:, None], cz[None, :] - pz[:, None]) <= reach + cr[None, :]
    return np.nonzero(near)


class CircleGrid:
    """Static circles bucketed on a square grid, so a rover's candidates are found by sorted look-up."""

    def __init__(self, x: np.ndarray, z: np.ndarray, r: np.ndarray, cell: float) -> None:
        self.cell = cell
        self.x, self.z, self.r = x, z, r
        keys = self._key(np.floor(x / cell), np.floor(z / cell))
        self.order = np.argsort(keys, kind="stable")
        self.keys = keys[self.order]

    @staticmethod
    def _key(cx: np.ndarray, cz: np.ndarray) -> np.ndarray:
        return cx.astype(np.int64) * 2_000_003 + cz.astype(np.int64)

    def pairs(self, px: np.ndarray, pz: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
        """(point index, circle index) for every circle within ``reach`` (+ its radius) of each point; with few
        pairs to test, all of them at once (the same pairs, in another order)."""
        if not len(self.keys):
            return np.zeros(0, int), np.zeros(0, int)
        if len(px) * len(self.x) <= FEW_PAIRS:
            return near_pairs(px, pz, self.x, self.z, self.r, reach)
        span = math.ceil((reach + float(self.r.max())) / self.cell)  # a wide circle's centre may lie farther
        offsets = np.arange(-span, span + 1)
        cx = np.floor(px / self.cell)[:, None, None] + offsets[None, :, None]
        cz = np.floor(pz / self.cell)[:, None, None] + offsets[None, None, :]
        keys = self._key(cx, cz).reshape(len(px), -1)
        lo, hi = np.searchsorted(self.keys, keys, "left"), np.searchsorted(self.keys, keys, "right")
        counts = (hi - lo).ravel()
        point = np.repeat(np.repeat(np.arange(len(px)), keys.shape[1]), counts)
        start = np.repeat(lo.ravel(), counts)
        within = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
        circle = self.order[start + within]
        near = np.hypot(self.x[circle] - px[point], self.z[circle] - pz[point]) <= reach + self.r[circle]
        return point[near], circle[near]


def circle_pairs(px: np.ndarray, pz: np.ndarray, cx: np.ndarray, cz: np.ndarray, cr: np.ndarray, reach: float,
                 cell: float) -> tuple[np.ndarray, np.ndarray]:
    """``CircleGrid(cx, cz, cr, cell).pairs(px, pz, reach)`` for circles that move (rovers), without building the
    grid when there are few pairs."""
    if len(px) * len(cx) > FEW_PAIRS:
        return CircleGrid(cx, cz, cr, cell).pairs(px, pz, reach)
    return near_pairs(px, pz, cx, cz, cr, reach)


@dataclass
class Scene:
    circle_x: np.ndarray  # solid circles: rocks and the lander
    circle_z: np.ndarray
    circle_r: np.ndarray
    circle_kind: np.ndarray
    edges: np.ndarray  # wall outlines, (K, 4)
    edge_height: np.ndarray  # height of the wall each edge belongs to, (K,)
    crater_x: np.ndarray  # crater terrain, perceived from outside, walkable
    crater_z: np.ndarray
    crater_r: np.ndarray

    def __post_init__(self) -> None:
        self.grid = CircleGrid(self.circle_x, self.circle_z, self.circle_r, GRID_CELL_M)

    @classmethod
    def from_scenario(cls, scenario: Scenario) -> Scene:
        rocks = list(scenario.obstacles.rocks) + scatter_rock_fields(scenario)
        lander = scenario.lander
        cx = np.array([r.x for r in rocks] + [lander.x], float)
        cz = np.array([r.z for r in rocks] + [lander.z], float)
        cr = np.array([r.radius_m for r in rocks] + [lander.radius_m], float)
        kinds = np.array([OBSTACLE] * len(rocks) + [LANDER], int)
        walls = [geo.wall_edges(w.points, w.thickness_m) for w in scenario.obstacles.walls]
        edges = np.concatenate(walls) if walls else np.zeros((0, 4))
        heights = np.concatenate([np.full(len(e), w.height_m) for e, w in zip(walls, scenario.obstacles.walls,
                                                                              strict=True)]) if walls else np.zeros(0)
        craters = scenario.craters
        return cls(cx, cz, cr, kinds, edges, heights,
                   np.array([c.x for c in craters], float), np.array([c.z for c in craters], float),
                   np.array([c.outer_radius for c in craters], float))

    # ---- move check and contacts ----

    def line_blocked(self, x0: float, z0: float, x1: float, z1: float, clearance: float,
                     other_x: np.ndarray, other_z: np.ndarray, rover_radius: float) -> bool:
        """Whether a disc of radius ``clearance`` swept from (x0, z0) to (x1, z1) meets anything solid."""
        _, near = self.grid.pairs(np.array([(x0 + x1) / 2]), np.array([(z0 + z1) / 2]),
                                  math.hypot(x1 - x0, z1 - z0) / 2 + clearance)
        if len(near):
            d = geo.point_segment_distance(self.circle_x[near], self.circle_z[near], x0, z0, x1, z1)[:, 0]
            if np.any(d < self.circle_r[near] + clearance):
                return True
        if len(other_x):
            d = geo.point_segment_distance(other_x, other_z, x0, z0, x1, z1)[:, 0]
            if np.any(d < rover_radius + clearance):
                return True
        if len(self.edges):
            e = self.edges
            d = geo.segment_segment_distance(x0, z0, x1, z1, e[:, 0], e[:, 1], e[:, 2], e[:, 3])
            if np.any(d < max(clearance, 1e-9)):
                return True
        return False

    def contacts(self, xs: np.ndarray, zs: np.ndarray, rover_radius: float) -> np.ndarray:
        """Bool per rover at (xs, zs): touching a rock, the lander or a wall."""
        point, circle = self.grid.pairs(xs, zs, rover_radius)
        touch = np.hypot(self.circle_x[circle] - xs[point], self.circle_z[circle] - zs[point]) < (
            self.circle_r[circle] + rover_radius)
        out = np.zeros(len(xs), bool)
        out[point[touch]] = True
        if len(self.edges):
            e = self.edges
            out |= np.any(geo.point_segment_distance(xs, zs, e[:, 0], e[:, 1], e[:, 2], e[:, 3]) < rover_radius, axis=1)
        return out


def scatter_rock_fields(scenario: Scenario) -> list[Rock]:
    """The rocks of every rock field, placed uniformly in its disc by a generator seeded from the scenario."""
    rng = np.random.default_rng([scenario.seed, 0x0C0C])  # own stream: rock fields do not shift other draws
    rocks: list[Rock] = []
    for field in scenario.obstacles.rock_fields:
        r = field.radius_m * np.sqrt(rng.random(field.count))
        a = rng.random(field.count) * 2 * np.pi
        size = rng.uniform(field.min_radius_m, field.max_radius_m, field.count)
        rocks += [Rock(x=float(field.x + ri * np.sin(ai)), z=float(field.z + ri * np.cos(ai)), radius_m=float(si))
                  for ri, ai, si in zip(r, a, size, strict=True)]
    return rocks


def in_view(rel_x: float, rel_z: float, fov_deg: float) -> bool:
    return abs(math.degrees(math.atan2(rel_x, rel_z))) <= fov_deg / 2 + 1e-6
