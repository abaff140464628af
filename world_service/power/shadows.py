"""Shadows: is a point's solar panel lit? Rays are traced towards the sun over the terrain and the obstacles.

What casts shadows:
- the terrain: the ray from the panel towards the sun is marched in half-cell steps (at most half a metre)
  over the heightmap, every point and a block of steps in one vectorised sample; a ray stops once it has
  risen above the highest the ground can be there (``height_bound``: the undulation's amplitude plus the rims
  of the craters within reach), and no ray is marched when the sun stands higher than the terrain's
  steepest slope (``Heightmap.max_slope_bound_deg``);
- rocks and the lander: hemispheres of their footprint radius on the ground (the scenario gives rocks a
  radius only; a boulder about as tall as it is wide is the assumption), hit exactly with a ray-sphere test;
- walls: vertical slabs of their outline and height, hit exactly with a ray-segment test.
Other rovers (30 cm tall) cast no shadow worth tracing.

A point is lit when the sun is above the horizon and no ray hit is found within ``max_shadow_m``. Results are
cached per quantised sun position (``Sun.at``) and per cell of ``CACHE_CELL_M``: a rover standing still, or
many rovers over the same ground, cost one trace. The answer for a point is the one for its cell's centre,
so it depends on the cell only and runs stay deterministic whatever the cache held.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from world_service.power.sun import SunPosition
from world_service.scene import CircleGrid, Scene
from world_service.terrain.heightmap import Heightmap

CACHE_CELL_M = 0.25
MAX_CACHED_CELLS = 200_000
"""Cells remembered at most (about 30 MB); past that the cache starts afresh (a fixed sun never changes step)."""
CHUNK_POINTS = 2048
"""Points traced together: bounds the (points x steps) sample array to a few MB."""
MARCH_BLOCK = 32
"""Steps sampled at once; between blocks the rays already shaded or above any ground are dropped."""


@dataclass(frozen=True)
class Occluders:
    """Rocks and the lander as hemispheres standing on the ground, walls as slabs: arrays built once."""

    cx: np.ndarray
    cy: np.ndarray  # ground height under the centre
    cz: np.ndarray
    r: np.ndarray
    grid: CircleGrid
    edges: np.ndarray  # (K, 4) wall outlines x0, z0, x1, z1
    edge_top: np.ndarray  # (K,) height of the wall's top: ground at the edge's middle plus the wall's height

    @classmethod
    def from_scene(cls, scene: Scene, terrain: Heightmap) -> Occluders:
        cy = terrain.height(scene.circle_x, scene.circle_z) if len(scene.circle_x) else np.zeros(0)
        e = scene.edges
        top = (terrain.height((e[:, 0] + e[:, 2]) / 2, (e[:, 1] + e[:, 3]) / 2) + scene.edge_height
               if len(e) else np.zeros(0))
        return cls(scene.circle_x, np.atleast_1d(cy), scene.circle_z, scene.circle_r, scene.grid, e,
                   np.atleast_1d(top))



def lit(terrain: Heightmap, occluders: Occluders, sun: SunPosition, xs, zs, panel_height_m: float,
        max_shadow_m: float) -> np.ndarray:
    """Bool per point: whether a panel ``panel_height_m`` above the ground at (xs, zs) sees the sun."""
    xs, zs = np.atleast_1d(np.asarray(xs, float)), np.atleast_1d(np.asarray(zs, float))
    out = np.zeros(xs.shape, bool)
    if not sun.up or xs.size == 0:
        return out
    for start in range(0, xs.size, CHUNK_POINTS):
        px, pz = xs[start:start + CHUNK_POINTS], zs[start:start + CHUNK_POINTS]
        py = np.atleast_1d(terrain.height(px, pz)) + panel_height_m
        shadow = _circle_shadow(occluders, sun, px, py, pz, max_shadow_m)
        shadow |= _wall_shadow(occluders, sun, px, py, pz, max_shadow_m)
        todo = ~shadow
        if np.any(todo) and sun.elevation_deg <= terrain.max_slope_bound_deg():
            top = height_bound(terrain, px[todo], pz[todo], max_shadow_m)
            shadow[todo] = _terrain_shadow(terrain, sun, px[todo], py[todo], pz[todo], max_shadow_m, top)
        out[start:start + CHUNK_POINTS] = ~shadow
    return out


def height_bound(terrain: Heightmap, px, pz, reach_m: float) -> float:
    """The highest the ground can stand within ``reach_m`` of the points (inf for a mesh surface)."""
    if terrain.base is not None:
        return math.inf
    top = terrain.undulation.amplitude if terrain.undulation is not None else 0.0
    near = terrain.craters.reaching(float(px.min()) - reach_m, float(px.max()) + reach_m,
                                    float(pz.min()) - reach_m, float(pz.max()) + reach_m)
    return top + sum(terrain.craters.craters[i].rim_height for i in near)  # a bowl never rises above its rim


def _terrain_shadow(terrain: Heightmap, sun: SunPosition, px, py, pz, max_shadow_m: float,
                    top: float = math.inf) -> np.ndarray:
    """March the ray over the heightmap: shadowed where the ground rises above it at any step."""
    step = min(0.5, terrain.resolution / 2)
    s = step * np.arange(1, math.ceil(max_shadow_m / step) + 1)
    az, tan_el = math.radians(sun.azimuth_deg), math.tan(math.radians(sun.elevation_deg))
    shadow = np.zeros(px.shape, bool)
    active = np.arange(px.size)
    for start in range(0, s.size, MARCH_BLOCK):
        seg, i = s[start:start + MARCH_BLOCK], active
        x = px[i, None] + seg[None, :] * math.sin(az)
        z = pz[i, None] + seg[None, :] * math.cos(az)
        hit = np.any(terrain.height(x, z) > py[i, None] + seg[None, :] * tan_el, axis=1)
        shadow[i[hit]] = True
        active = i[~hit & (py[i] + seg[-1] * tan_el <= top)]
        if active.size == 0:
            break
    return shadow


def _circle_shadow(occ: Occluders, sun: SunPosition, px, py, pz, max_shadow_m: float) -> np.ndarray:
    """Ray-sphere test against the rocks and lander near enough to shade: the ray meets a hemisphere."""
    shadow = np.zeros(px.shape, bool)
    if occ.r.size == 0:
        return shadow
    tan_el = max(math.tan(math.radians(sun.elevation_deg)), 1e-9)
    r_max = float(occ.r.max())
    rise = float(occ.cy.max()) + r_max - float(py.min())
    reach = min(max_shadow_m, max(rise, 0.0) / tan_el + r_max)
    point, circle = occ.grid.pairs(px, pz, reach)
    if point.size == 0:
        return shadow
    d = sun.vector
    ox, oy, oz = px[point] - occ.cx[circle], py[point] - occ.cy[circle], pz[point] - occ.cz[circle]
    b = ox * d[0] + oy * d[1] + oz * d[2]
    c = ox * ox + oy * oy + oz * oz - occ.r[circle] ** 2
    disc = b * b - c
    t_exit = -b + np.sqrt(np.maximum(disc, 0.0))
    exit_y = oy + t_exit * d[1]  # relative to the ground under the centre: the dome is above it
    hit = (disc >= 0) & (t_exit > 0) & (exit_y >= 0) & (t_exit <= max_shadow_m)
    shadow[point[hit]] = True
    return shadow


def _wall_shadow(occ: Occluders, sun: SunPosition, px, py, pz, max_shadow_m: float) -> np.ndarray:
    """Ray-segment test in the ground plane against every wall edge, then compare heights at the crossing."""
    if occ.edges.size == 0:
        return np.zeros(px.shape, bool)
    az, tan_el = math.radians(sun.azimuth_deg), math.tan(math.radians(sun.elevation_deg))
    ux, uz = math.sin(az), math.cos(az)
    e = occ.edges
    ax, az0 = e[None, :, 0] - px[:, None], e[None, :, 1] - pz[:, None]
    bx, bz = e[None, :, 2] - e[None, :, 0], e[None, :, 3] - e[None, :, 1]
    denom = ux * bz - uz * bx
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (ax * bz - az0 * bx) / denom  # distance along the ray
        t = (ax * uz - az0 * ux) / denom  # position along the edge
    crossing = (np.abs(denom) > 1e-12) & (s > 0) & (s <= max_shadow_m) & (t >= 0) & (t <= 1)
    below = py[:, None] + s * tan_el < occ.edge_top[None, :]
    return np.any(crossing & below, axis=1)


class ShadowCache:
    """``lit`` for points, cached per quantised sun position and per ``CACHE_CELL_M`` cell."""

    def __init__(self, terrain: Heightmap, occluders: Occluders, panel_height_m: float, max_shadow_m: float,
                 cell_m: float = CACHE_CELL_M) -> None:
        self.terrain, self.occluders = terrain, occluders
        self.panel_height_m, self.max_shadow_m, self.cell_m = panel_height_m, max_shadow_m, cell_m
        self._sun: SunPosition | None = None
        self._cells: dict[tuple[int, int], bool] = {}
        self.traced = 0

    def lit(self, sun: SunPosition, xs, zs) -> np.ndarray:
        if sun != self._sun or len(self._cells) > MAX_CACHED_CELLS:
            self._sun, self._cells = sun, {}
        ix = np.floor(np.asarray(xs, float) / self.cell_m + 0.5).astype(np.int64)
        iz = np.floor(np.asarray(zs, float) / self.cell_m + 0.5).astype(np.int64)
        keys = list(zip(ix.tolist(), iz.tolist(), strict=True))
        missing = sorted({k for k in keys if k not in self._cells})
        if missing:
            mi, mz = (np.array(v, float) * self.cell_m for v in zip(*missing, strict=True))
            found = lit(self.terrain, self.occluders, sun, mi, mz, self.panel_height_m, self.max_shadow_m)
            self._cells.update(zip(missing, found.tolist(), strict=True))
            self.traced += len(missing)
        return np.array([self._cells[k] for k in keys], bool)
