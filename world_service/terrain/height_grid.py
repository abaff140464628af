"""A block of the terrain's height nodes in one array, sampled and ray-marched by compiled loops.

The camera samples the ground about 450,000 times a photo, in march steps that all rays take together. As
NumPy array passes that cost about 30 ms a photo, most of it in temporaries; the same loops compiled with
Numba walk each ray only as far as it goes and cost about 5 ms, with the same arithmetic in the same order,
so photos are byte for byte the ones the NumPy march made. Only the world's camera uses this (the rover agent
never imports it).

Sampling follows the terrain's own bilinear formula (``Heightmap``): a point's fractional node index is taken
on the whole terrain and clamped at its edge, then read from the block, so a block gives exactly the heights
the tiles give wherever it covers the point. Outside the block, reads are clamped to its edge nodes: the
caller asks for a block that covers what it samples (``Heightmap.grid_around``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np


@dataclass(frozen=True)
class HeightGrid:
    """Height nodes [j0 : j0 + rows, i0 : i0 + cols] of a terrain of ``nx`` x ``nz`` nodes, float32.

    ``ceiling`` bounds the ground height everywhere (``Heightmap.max_height_bound``; inf if unknown): a rising
    ray above it can hit nothing.
    """

    heights: np.ndarray  # (rows, cols) float32, C order
    i0: int
    j0: int
    nx: int
    nz: int
    origin_x: float
    origin_z: float
    resolution: float
    ceiling: float = math.inf

    def _geometry(self) -> tuple:
        return (self.heights, self.i0, self.j0, self.nx, self.nz, self.origin_x, self.origin_z, self.resolution)

    def height(self, x, z) -> np.ndarray:
        """Ground height at the points (any matching shapes; a scalar in gives a scalar out)."""
        x, z = np.broadcast_arrays(np.asarray(x, float), np.asarray(z, float))
        out = _heights(*self._geometry(), np.ascontiguousarray(x.ravel()), np.ascontiguousarray(z.ravel()))
        return out.reshape(x.shape)[()]

    def march(self, origin: np.ndarray, dirs: np.ndarray, max_range: float, first_step: float, min_step: float,
              growth: float) -> np.ndarray:
        """Distance along each ray (rows of ``dirs``, unit vectors) to its first crossing below the ground, inf
        if none within ``max_range``.

        Every ray samples at the same distances: ``first_step``, then steps of ``growth`` times the distance so
        far but at least ``min_step`` (a pixel's footprint grows the same way). A ray stops at its first sample
        below ground, the crossing placed by linear interpolation of the height gap between its last two
        samples; a rising ray stops once it is above ``ceiling``.
        """
        ox, oy, oz = (float(v) for v in origin)
        return _march(*self._geometry(), ox, oy, oz, np.ascontiguousarray(dirs, dtype=float), float(max_range),
                      float(self.ceiling), float(first_step), float(min_step), float(growth))

    def surface(self, origin: np.ndarray, dirs: np.ndarray, max_range: float, first_step: float, min_step: float,
                growth: float, normal_eps: float) -> tuple[np.ndarray, np.ndarray]:
        """``march``, and at each crossing the ground's unit upward normal from central differences of the height
        ``normal_eps`` either side (zero where a ray meets nothing): what the camera shades, in one compiled pass
        instead of a march and a second round of NumPy sampling, to the same bits."""
        ox, oy, oz = (float(v) for v in origin)
        return _surface(*self._geometry(), ox, oy, oz, np.ascontiguousarray(dirs, dtype=float), float(max_range),
                        float(self.ceiling), float(first_step), float(min_step), float(growth), float(normal_eps))


def warm_up() -> None:
    """Compile the loops the camera uses now, so that the first photo does not wait for it: the camera process
    calls this as it builds its ground, ahead of the first photo or at it (``Photographer.await_camera``). From
    Numba's cache on disk it takes about 0.4 s here, nearly all of it Numba readying its compiler on the first load;
    without the cache, a few seconds."""
    grid = HeightGrid(np.zeros((2, 2), np.float32), 0, 0, 2, 2, 0.0, 0.0, 1.0, 0.0)
    grid.height(np.zeros(1), np.zeros(1))
    grid.surface(np.array([0.0, 1.0, 0.0]), np.array([[0.0, -1.0, 0.0]]), 1.0, 0.2, 0.2, 0.03, 0.25)


# ---- compiled loops (error_model="numpy": division as in NumPy, no exception checks; no fastmath) ----


def _jit(func):
    """Compiled and cached on disk (next to the module, else in the user's cache directory)."""
    try:
        return numba.njit(cache=True, error_model="numpy")(func)
    except RuntimeError:  # no writable cache directory anywhere: each process compiles for itself
        return numba.njit(error_model="numpy")(func)


@_jit
def _height_at(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, x, z):
    rows, cols = heights.shape
    fx = min(max((x - origin_x) / resolution, 0.0), nx - 1)
    fz = min(max((z - origin_z) / resolution, 0.0), nz - 1)
    ix = min(int(fx), nx - 2)
    iz = min(int(fz), nz - 2)
    wx = fx - ix
    wz = fz - iz
    c = min(max(ix - i0, 0), cols - 2)
    r = min(max(iz - j0, 0), rows - 2)
    top = np.float64(heights[r, c]) * (1 - wx) + np.float64(heights[r, c + 1]) * wx
    bottom = np.float64(heights[r + 1, c]) * (1 - wx) + np.float64(heights[r + 1, c + 1]) * wx
    return top * (1 - wz) + bottom * wz


@_jit
def _heights(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, xs, zs):
    out = np.empty(xs.size)
    for k in range(xs.size):
        out[k] = _height_at(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, xs[k], zs[k])
    return out


@_jit
def _march(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, ox, oy, oz, dirs, max_range, ceiling,
           first_step, min_step, growth):
    hit = np.full(dirs.shape[0], np.inf)
    start_gap = oy - _height_at(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, ox, oz)
    for k in range(dirs.shape[0]):
        hit[k] = _march_ray(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, ox, oy, oz, dirs[k, 0],
                            dirs[k, 1], dirs[k, 2], start_gap, max_range, ceiling, first_step, min_step, growth)
    return hit


@_jit
def _surface(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, ox, oy, oz, dirs, max_range, ceiling,
             first_step, min_step, growth, eps):
    hit = np.full(dirs.shape[0], np.inf)
    normal = np.zeros(dirs.shape)
    start_gap = oy - _height_at(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, ox, oz)
    for k in range(dirs.shape[0]):
        dx, dz = dirs[k, 0], dirs[k, 2]
        t = _march_ray(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, ox, oy, oz, dx, dirs[k, 1], dz,
                       start_gap, max_range, ceiling, first_step, min_step, growth)
        hit[k] = t
        if t < np.inf:
            px, pz = ox + t * dx, oz + t * dz
            slope_x = (_height_at(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, px + eps, pz)
                       - _height_at(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, px - eps, pz)) / (2 * eps)
            slope_z = (_height_at(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, px, pz + eps)
                       - _height_at(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, px, pz - eps)) / (2 * eps)
            length = math.sqrt((slope_x * slope_x + 1.0) + slope_z * slope_z)  # np.linalg.norm's order
            normal[k, 0], normal[k, 1], normal[k, 2] = -slope_x / length, 1.0 / length, -slope_z / length
    return hit, normal


@_jit
def _march_ray(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, ox, oy, oz, dx, dy, dz, start_gap,
               max_range, ceiling, first_step, min_step, growth):
    prev_t, prev_gap = 0.0, start_gap
    t = min(first_step, max_range)
    while not (dy > 0 and oy + t * dy > ceiling):
        gap = oy + t * dy - _height_at(heights, i0, j0, nx, nz, origin_x, origin_z, resolution, ox + t * dx,
                                       oz + t * dz)
        if gap <= 0:
            return prev_t + (t - prev_t) * (prev_gap / (prev_gap - gap))
        if t >= max_range:
            break
        prev_t, prev_gap = t, gap
        t = min(max_range, t + max(min_step, growth * t))
    return np.inf
