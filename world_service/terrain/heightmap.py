"""Heightmap terrain on a regular grid, split into square tiles that are generated on first use.

The surface is a flat plain (or an imported mesh, see ``world_service.terrain.mesh``) plus a seeded
undulation of ``roughness_m`` plus crater bowls with raised rims. Every layer is a pure function of
(x, z) and the seed, so a tile can be generated on its own and still join its neighbours exactly: this is
what lets a 50 km² terrain run while only the tiles near rovers are in memory (the report's 10.7.1 chunk
activation). Tiles live in an LRU with a cap (``TerrainSpec.max_tiles_in_memory``); ``keep_near`` loads
the tiles around the rovers and drops the far ones.

The layers themselves (undulation, craters) are in ``world_service.terrain.landforms``.

Grid node (i, j) sits at (origin_x + i * resolution, origin_z + j * resolution); arrays are indexed
[j, i] (row = z). Tile (tz, tx) holds nodes tx*T .. tx*T + T along x (T cells per tile, edge nodes shared
with the neighbour) so bilinear sampling never needs a second tile. Heights and gradients are stored as
float32; gradients are central differences computed with a one-node halo, so they match an untiled grid.
"""

from __future__ import annotations

import logging
import math
from collections import OrderedDict
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from schemas.scenario import Crater, Scenario, TerrainSpec
from world_service.terrain.landforms import CraterSet, HeightSource, Undulation

if TYPE_CHECKING:
    from world_service.terrain.height_grid import HeightGrid

log = logging.getLogger("lunarsim.terrain")

FULL_GRID_LIMIT = 25_000_000
"""Most nodes ``heights``/``slope_x``/``slope_z`` will assemble into one array (100 MB of float32)."""

FIELDS = ("heights", "slope_x", "slope_z")
FEW_POINTS = 8
"""At most this many points are sampled in plain Python (``_sample_few``): below it that is the faster way."""
TileKey = tuple[int, int]
"""(tz, tx): tile row along z, tile column along x."""


@dataclass
class Tile:
    """One loaded tile: float32 heights and gradients on nodes starting at global index (i0, j0)."""

    key: TileKey
    i0: int
    j0: int
    heights: np.ndarray
    slope_x: np.ndarray
    slope_z: np.ndarray

    @property
    def nbytes(self) -> int:
        return self.heights.nbytes + self.slope_x.nbytes + self.slope_z.nbytes


class Heightmap:
    """Tiled heightmap with lazy tile generation, vectorised bilinear sampling and an LRU of tiles."""

    def __init__(self, spec: TerrainSpec, craters: Iterable[Crater] = (), undulation: Undulation | None = None,
                 base: HeightSource | None = None) -> None:
        self.spec = spec
        self.origin_x, self.origin_z = float(spec.origin[0]), float(spec.origin[1])
        self.resolution = float(spec.resolution_m)
        self.nx = int(np.ceil(spec.size_m[0] / spec.resolution_m)) + 1
        self.nz = int(np.ceil(spec.size_m[1] / spec.resolution_m)) + 1
        self.tile_cells = max(1, round(spec.tile_size_m / spec.resolution_m))
        self.tiles_x = math.ceil((self.nx - 1) / self.tile_cells)
        self.tiles_z = math.ceil((self.nz - 1) / self.tile_cells)
        self.max_tiles = spec.max_tiles_in_memory
        self.craters = CraterSet.of(craters)
        self.undulation = undulation
        self.base = base
        self._tiles: OrderedDict[TileKey, Tile] = OrderedDict()
        self.tiles_generated = 0
        self.tiles_evicted = 0

    def __getstate__(self) -> dict:
        """The tiles' keys without their arrays: each tile is a pure function of its key and the layers, and the
        arrays were nearly all of a saved world (``world_service.resume``), written every simulated second."""
        state = self.__dict__.copy()
        state["_tiles"] = list(self._tiles)
        return state

    def __setstate__(self, state: dict) -> None:
        """The same tiles generated again, in the same LRU order, and the tallies as they were saved."""
        keys = state.pop("_tiles")
        self.__dict__.update(state)
        generated = self.tiles_generated
        self._tiles = OrderedDict((key, self._generate(key)) for key in keys)
        self.tiles_generated = generated

    # ---- construction ----

    @classmethod
    def build(cls, spec: TerrainSpec, craters: list[Crater], rng: np.random.Generator,
              base_dir: str | Path | None = None) -> Heightmap:
        """The scenario's terrain; nothing is generated until a tile is first sampled.

        The undulation draws from ``rng`` exactly as the untiled generator did (only when rough), so the
        rest of a seeded world is unchanged. A mesh terrain replaces the plain and is not carved by craters:
        its relief is the real one, and the scenario's craters still mark the mission goals.
        """
        undulation = Undulation.draw(spec.roughness_m, rng) if spec.roughness_m > 0 else None
        if spec.mesh is None:
            return cls(spec, craters, undulation)
        from world_service.terrain.mesh import MeshSurface

        path = Path(spec.mesh)
        if base_dir is not None and not path.is_absolute():
            path = Path(base_dir) / path
        base = MeshSurface.load(path, spec.mesh_scale, spec.mesh_offset, bin_size_m=spec.tile_size_m)
        return cls(spec, (), undulation, base)

    @classmethod
    def from_scenario(cls, scenario: Scenario, rng: np.random.Generator,
                      base_dir: str | Path | None = None) -> Heightmap:
        return cls.build(scenario.terrain_spec(), scenario.craters, rng, base_dir)

    # ---- tiles ----

    @property
    def loaded_tiles(self) -> list[TileKey]:
        """Keys of the tiles in memory, least recently used first."""
        return list(self._tiles)

    @property
    def tile_bytes(self) -> int:
        """Memory held by loaded tiles."""
        return sum(t.nbytes for t in self._tiles.values())

    def full_grid_bytes(self, dtype: np.dtype | type = np.float32) -> int:
        """What heights plus both gradients would take held as whole grids (computed, never allocated)."""
        return 3 * self.nx * self.nz * np.dtype(dtype).itemsize

    def tile_bounds(self, key: TileKey) -> tuple[float, float, float, float]:
        """(x0, z0, x1, z1) of a tile, m."""
        (i0, i1), (j0, j1) = self._span(key[1], self.nx), self._span(key[0], self.nz)
        res = self.resolution
        return self.origin_x + i0 * res, self.origin_z + j0 * res, self.origin_x + i1 * res, self.origin_z + j1 * res

    def _span(self, t: int, n: int) -> tuple[int, int]:
        """First and last node index (inclusive) of tile column/row ``t`` along an axis of ``n`` nodes."""
        return t * self.tile_cells, min((t + 1) * self.tile_cells, n - 1)

    def tile(self, key: TileKey, cache: bool = True) -> Tile:
        """The tile, generated if not loaded; ``cache=False`` leaves the LRU untouched (exports, surveys)."""
        tile = self._tiles.get(key)
        if tile is not None:
            if cache:
                self._tiles.move_to_end(key)
            return tile
        tile = self._generate(key)
        if cache:
            self._tiles[key] = tile
            while len(self._tiles) > self.max_tiles:
                self._tiles.popitem(last=False)
                self.tiles_evicted += 1
        return tile

    def _generate(self, key: TileKey) -> Tile:
        """Heights of the tile plus a one-node halo (clipped at the terrain edge), gradients, then crop."""
        (i0, i1), (j0, j1) = self._span(key[1], self.nx), self._span(key[0], self.nz)
        hi0, hi1 = max(i0 - 1, 0), min(i1 + 1, self.nx - 1)
        hj0, hj1 = max(j0 - 1, 0), min(j1 + 1, self.nz - 1)
        heights = self._block(hi0, hi1 + 1, hj0, hj1 + 1)
        slope_z, slope_x = np.gradient(heights, self.resolution)
        crop = np.s_[j0 - hj0:j1 - hj0 + 1, i0 - hi0:i1 - hi0 + 1]
        self.tiles_generated += 1
        return Tile(key, i0, j0, *(np.ascontiguousarray(a[crop], dtype=np.float32)
                                   for a in (heights, slope_x, slope_z)))

    def _block(self, i0: int, i1: int, j0: int, j1: int) -> np.ndarray:
        """float64 heights of nodes [j0:j1, i0:i1], every layer evaluated from global coordinates."""
        xs = self.origin_x + np.arange(i0, i1) * self.resolution
        zs = self.origin_z + np.arange(j0, j1) * self.resolution
        if self.base is not None:
            out = np.asarray(self.base.block(xs[0], zs[0], self.resolution, xs.size, zs.size), dtype=float)
        else:
            out = np.zeros((zs.size, xs.size))
        if self.undulation is not None:
            out += self.undulation.grid(xs, zs)
        if self.craters.craters:
            self.craters.add_to(out, xs, zs)
        return out

    def keep_near(self, points_xz: np.ndarray, radius_m: float) -> set[TileKey]:
        """Chunk activation: load every tile within ``radius_m`` of a point, drop every other tile.

        If more tiles are near than the cap allows, the nearest ones are kept (and a warning logged).
        Returns the keys of the tiles near the points.
        """
        keys, dist = self._tiles_near(np.asarray(points_xz, float).reshape(-1, 2), float(radius_m))
        near = set(zip(keys[:, 0].tolist(), keys[:, 1].tolist(), strict=True))
        for key in [k for k in self._tiles if k not in near]:
            del self._tiles[key]
            self.tiles_evicted += 1
        if len(keys) > self.max_tiles:
            log.warning("%d tiles lie within %.0f m of the points but only %d may be loaded; keeping the nearest",
                        len(keys), radius_m, self.max_tiles)
        for tz, tx in keys[np.argsort(dist, kind="stable")][:self.max_tiles].tolist():
            self.tile((tz, tx))
        return near

    def _tiles_near(self, points: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
        """Distinct tiles whose rectangle lies within ``radius`` of a point, with each one's nearest distance."""
        if points.size == 0:
            return np.empty((0, 2), int), np.empty(0)
        side = self.tile_cells * self.resolution
        reach = int(np.ceil(radius / side)) + 1
        offsets = np.arange(-reach, reach + 1)
        ptx = np.floor((points[:, 0] - self.origin_x) / side).astype(int)
        ptz = np.floor((points[:, 1] - self.origin_z) / side).astype(int)
        tx = (ptx[:, None, None] + offsets[None, None, :]).repeat(offsets.size, axis=1)
        tz = (ptz[:, None, None] + offsets[None, :, None]).repeat(offsets.size, axis=2)
        px, pz = points[:, 0, None, None], points[:, 1, None, None]
        x0, z0 = self.origin_x + tx * side, self.origin_z + tz * side
        x1 = np.minimum(x0 + side, self.origin_x + (self.nx - 1) * self.resolution)
        z1 = np.minimum(z0 + side, self.origin_z + (self.nz - 1) * self.resolution)
        dist = np.hypot(np.maximum(np.maximum(x0 - px, px - x1), 0), np.maximum(np.maximum(z0 - pz, pz - z1), 0))
        ok = (dist <= radius) & (tx >= 0) & (tx < self.tiles_x) & (tz >= 0) & (tz < self.tiles_z)
        ids, dist = (tz * self.tiles_x + tx)[ok], dist[ok]
        order = np.lexsort((dist, ids))
        ids, first = np.unique(ids[order], return_index=True)
        return np.stack([ids // self.tiles_x, ids % self.tiles_x], axis=1), dist[order][first]

    # ---- sampling ----

    def _sample(self, fields: tuple[str, ...], x, z, cache: bool = True) -> list[np.ndarray]:
        """Bilinear samples of tile fields at points, clamped at the terrain edge, grouped by tile.

        Points are sorted by tile once; the only Python loop is over the distinct tiles touched. Up to
        ``FEW_POINTS`` points are sampled one by one in plain Python instead, to the same bits.
        """
        x, z = np.asarray(x, float), np.asarray(z, float)
        if x.shape != z.shape:
            x, z = np.broadcast_arrays(x, z)
        if x.size <= FEW_POINTS:
            out = self._sample_few(fields, x.ravel().tolist(), z.ravel().tolist(), cache)
        else:
            out = self._sample_many(fields, x.ravel(), z.ravel(), cache)
        return [o.reshape(x.shape)[()] for o in out]  # a scalar in gives a scalar out

    def _sample_many(self, fields: tuple[str, ...], x: np.ndarray, z: np.ndarray, cache: bool) -> list[np.ndarray]:
        fx = np.minimum(np.maximum((x - self.origin_x) / self.resolution, 0.0), self.nx - 1)
        fz = np.minimum(np.maximum((z - self.origin_z) / self.resolution, 0.0), self.nz - 1)
        ix, iz = np.minimum(fx.astype(int), self.nx - 2), np.minimum(fz.astype(int), self.nz - 2)
        tx, tz = fx - ix, fz - iz
        ids = (iz // self.tile_cells) * self.tiles_x + ix // self.tile_cells
        out = [np.empty(ids.size) for _ in fields]
        for tile_id, sel in _groups(ids):
            tile = self.tile(divmod(tile_id, self.tiles_x), cache)
            cols = tile.heights.shape[1]
            corner = (iz[sel] - tile.j0) * cols + (ix[sel] - tile.i0)
            wx, wz = tx[sel], tz[sel]
            for k, name in enumerate(fields):
                g = getattr(tile, name).ravel()
                top = g[corner] * (1 - wx) + g[corner + 1] * wx
                bottom = g[corner + cols] * (1 - wx) + g[corner + cols + 1] * wx
                out[k][sel] = top * (1 - wz) + bottom * wz
        return out

    def _sample_few(self, fields: tuple[str, ...], xs: list[float], zs: list[float], cache: bool) -> list[np.ndarray]:
        """``_sample`` point by point in Python floats, the same arithmetic in the same order (so the same bits),
        tiles visited in the same order: for a handful of points (a lockstep tick of five rovers samples its
        slopes twice) NumPy's cost per call is most of the cost."""
        res, ox, oz, tiles_x, tc = self.resolution, self.origin_x, self.origin_z, self.tiles_x, self.tile_cells
        points = []
        for x, z in zip(xs, zs, strict=True):
            fx = min(max((x - ox) / res, 0.0), self.nx - 1)
            fz = min(max((z - oz) / res, 0.0), self.nz - 1)
            ix, iz = min(int(fx), self.nx - 2), min(int(fz), self.nz - 2)
            points.append(((iz // tc) * tiles_x + ix // tc, ix, iz, fx - ix, fz - iz))
        out = [np.empty(len(points)) for _ in fields]
        for tile_id in sorted({p[0] for p in points}):
            tile = self.tile(divmod(tile_id, tiles_x), cache)
            grids = [getattr(tile, name) for name in fields]
            for n, (pid, ix, iz, wx, wz) in enumerate(points):
                if pid != tile_id:
                    continue
                r, c = iz - tile.j0, ix - tile.i0
                for k, g in enumerate(grids):
                    top = g.item(r, c) * (1 - wx) + g.item(r, c + 1) * wx
                    bottom = g.item(r + 1, c) * (1 - wx) + g.item(r + 1, c + 1) * wx
                    out[k][n] = top * (1 - wz) + bottom * wz
        return out

    def height(self, x, z, *, cache: bool = True) -> np.ndarray:
        return self._sample(("heights",), x, z, cache)[0]

    def max_slope_bound_deg(self) -> float:
        """An upper bound on the steepest slope anywhere, from the terrain's recipe (90 for a mesh).

        Gradients of the layers add, so the bound sums each layer's steepest slope: each wave's
        amplitude x wavenumber, and each crater's steeper of bowl wall (2 depth / R at the crest) and rim.
        Perception uses it to skip looking for too-steep ground where there can be none.
        """
        if self.base is not None:
            return 90.0
        rise = 0.0
        if self.undulation is not None:
            rise += float(np.sum(self.undulation.k)) * self.undulation.amplitude / self.undulation.k.size
        rise += max((max(2 * c.depth / c.radius_m, np.pi * c.rim_height / (2 * c.rim_width * c.radius_m))
                     for c in self.craters.craters), default=0.0)
        return float(np.degrees(np.arctan(rise)))

    def max_height_bound(self) -> float:
        """An upper bound on the ground height anywhere (inf for a mesh), from the terrain's recipe.

        Each wave of the undulation adds at most ``amplitude / waves``; craters add at most their rim height,
        and overlapping rims add up. The camera drops a rising ray once it is above this: it can hit nothing.
        """
        if self.base is not None:
            return math.inf
        roll = self.undulation.amplitude if self.undulation is not None else 0.0
        return roll + sum(max(c.rim_height, 0.0) for c in self.craters.craters)

    def gradient(self, x, z) -> tuple[np.ndarray, np.ndarray]:
        """(dh/dx, dh/dz) at the points: the ground's rise per metre along +x and +z."""
        gx, gz = self._sample(("slope_x", "slope_z"), x, z)
        return gx, gz

    def pitch_deg(self, x, z, heading_deg) -> np.ndarray:
        """Nose-up angle of a rover standing at (x, z) facing ``heading_deg``: the slope along its heading."""
        x, z, heading = np.broadcast_arrays(np.asarray(x, float), np.asarray(z, float), np.asarray(heading_deg, float))
        gx, gz = self.gradient(x, z)
        h = np.radians(heading)
        return np.degrees(np.arctan(gx * np.sin(h) + gz * np.cos(h)))

    # ---- whole grids (small terrains only) and blocks of nodes ----

    @property
    def heights(self) -> np.ndarray:
        """Whole height grid (nz, nx), float32; refused for terrains too large to hold at once."""
        return self._assemble("heights", 0, self.nx - 1, 0, self.nz - 1)

    @property
    def slope_x(self) -> np.ndarray:
        return self._assemble("slope_x", 0, self.nx - 1, 0, self.nz - 1)

    @property
    def slope_z(self) -> np.ndarray:
        return self._assemble("slope_z", 0, self.nx - 1, 0, self.nz - 1)

    def grid_around(self, x: float, z: float, reach: float, *, cache: bool = True) -> HeightGrid:
        """The height nodes that bilinear samples within ``reach`` of (x, z) read, as one block: the camera
        marches in it (it never samples beyond its range)."""
        i0, i1 = self._node_span(x - self.origin_x, reach, self.nx)
        j0, j1 = self._node_span(z - self.origin_z, reach, self.nz)
        return self.grid(i0, i1, j0, j1, cache=cache)

    def grid(self, i0: int, i1: int, j0: int, j1: int, *, cache: bool = True) -> HeightGrid:
        """Height nodes [j0..j1] x [i0..i1] (inclusive) as one block, with the height bound as its ceiling."""
        from world_service.terrain.height_grid import HeightGrid  # here: Numba loads only where photos are rendered

        return HeightGrid(self._assemble("heights", i0, i1, j0, j1, cache), i0, j0, self.nx, self.nz,
                          self.origin_x, self.origin_z, self.resolution, self.max_height_bound())

    def _node_span(self, offset: float, reach: float, n: int) -> tuple[int, int]:
        """First and last node (inclusive, at least two nodes) read by samples within ``reach`` of ``offset``."""
        first = min(max(math.floor((offset - reach) / self.resolution) - 1, 0), n - 2)
        last = max(min(math.ceil((offset + reach) / self.resolution) + 1, n - 1), first + 1)
        return first, last

    def _assemble(self, name: str, i0: int, i1: int, j0: int, j1: int, cache: bool = False) -> np.ndarray:
        """Nodes [j0..j1] x [i0..i1] (inclusive) of one field, copied from the tiles into one float32 array."""
        if (i1 - i0 + 1) * (j1 - j0 + 1) > FULL_GRID_LIMIT:
            raise MemoryError(f"{i1 - i0 + 1} x {j1 - j0 + 1} terrain nodes are too many to assemble; sample "
                              f"them (height, gradient) so only the tiles needed are loaded")
        out = np.empty((j1 - j0 + 1, i1 - i0 + 1), np.float32)
        last_tz, last_tx = self.tiles_z - 1, self.tiles_x - 1
        for tz in range(j0 // self.tile_cells, min(j1 // self.tile_cells, last_tz) + 1):
            for tx in range(i0 // self.tile_cells, min(i1 // self.tile_cells, last_tx) + 1):
                tile = self.tile((tz, tx), cache)
                g = getattr(tile, name)
                rows = slice(max(tile.j0, j0), min(tile.j0 + g.shape[0] - 1, j1) + 1)
                cols = slice(max(tile.i0, i0), min(tile.i0 + g.shape[1] - 1, i1) + 1)
                out[rows.start - j0:rows.stop - j0, cols.start - i0:cols.stop - i0] = \
                    g[rows.start - tile.j0:rows.stop - tile.j0, cols.start - tile.i0:cols.stop - tile.i0]
        return out


def _groups(ids: np.ndarray) -> list[tuple[int, np.ndarray | slice]]:
    """(id, selection) per distinct id: one stable sort, or no sort at all when every point shares a tile."""
    if ids.size == 0:
        return []
    lo, hi = int(ids.min()), int(ids.max())
    if lo == hi:
        return [(lo, slice(None))]
    order = np.argsort(ids, kind="stable")
    uniq, starts = np.unique(ids[order], return_index=True)
    ends = np.append(starts[1:], ids.size)
    return [(u, order[a:b]) for u, a, b in zip(uniq.tolist(), starts.tolist(), ends.tolist(), strict=True)]
