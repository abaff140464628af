"""Perception (report 10.1) for many rovers at once: every ray of every rover scanned this tick in one go.

Rays fan over the field of view in each rover's plane; each reports the nearest thing it meets within
the perception radius. Solid things (rovers, rocks, walls, the lander, ground rising more steeply than a
rover can climb) come first; crater terrain is walkable ground, so it shows only on rays that meet
nothing solid. Rocks are found through a grid over their centres (when they are many), everything else by
culled pairs, so cost grows with what is near the rovers, not with everything in the world; every circle in
reach (rock, lander, rover, crater) is then met by all the rays in one pass, since with a rover or two scanning
a tick NumPy's cost per call is most of the cost.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from schemas.params import RoverParams
from world_service import geometry as geo
from world_service.scene import (
    CRATER,
    FEW_PAIRS,
    LANDER,
    OBSTACLE,
    ROVER,
    TERRAIN,
    CircleGrid,
    Scene,
    circle_pairs,
    near_pairs,
)

TERRAIN_STEP_M = 1.0
"""Spacing of the samples along each ray that look for ground too steep to climb."""


SOURCES = (OBSTACLE, LANDER, ROVER, CRATER)
"""The kinds of circle a ray may meet (rocks, the lander's, other rovers, craters), in the order that wins a tie."""
SOURCE_KINDS = np.array([*SOURCES, -1])
"""A source's kind by its index; the last, -1, for a ray that met none."""
_ROCKS, _LANDER, _ROVERS, _CRATERS = range(len(SOURCES))
Rays = np.ndarray
"""One value per rover and ray: shape (rovers, rays)."""


@dataclass
class Scan:
    angles_deg: np.ndarray
    distances_m: np.ndarray
    kinds: np.ndarray


@dataclass
class Scans:
    """The hits of several rovers' scans end to end, rover after rover, each rover's rays in order: ``counts[i]``
    of them are the ``i``-th scanning rover's. One array of each for all, so what a tick publishes is rounded and
    made lists in one NumPy call each rather than three a rover."""

    angles_deg: np.ndarray
    distances_m: np.ndarray
    kinds: np.ndarray
    counts: np.ndarray

    def spans(self) -> list[tuple[int, int]]:
        """Where each rover's hits start and end in the arrays."""
        ends = np.cumsum(self.counts)
        return list(zip((ends - self.counts).tolist(), ends.tolist(), strict=True))

    def split(self) -> list[Scan]:
        return [Scan(self.angles_deg[a:b], self.distances_m[a:b], self.kinds[a:b]) for a, b in self.spans()]


class Perceiver:
    def __init__(self, scene: Scene, terrain, params: RoverParams) -> None:
        self.scene = scene
        self.terrain = terrain
        self.params = params
        p = params.perception
        self.rel = np.linspace(-p.field_of_view_degrees / 2, p.field_of_view_degrees / 2, p.perception_granularity)
        rocks = scene.circle_kind == OBSTACLE
        widest = float(scene.circle_r[rocks].max()) if rocks.any() else 0.0
        self.rocks = CircleGrid(scene.circle_x[rocks], scene.circle_z[rocks], scene.circle_r[rocks],
                                cell=max(p.perception_radius + widest, 5.0))  # a scan looks one cell around
        others = (np.concatenate([scene.circle_x[~rocks], scene.crater_x]),
                  np.concatenate([scene.circle_z[~rocks], scene.crater_z]),
                  np.concatenate([scene.circle_r[~rocks], scene.crater_r]),
                  np.repeat([_LANDER, _CRATERS], [int((~rocks).sum()), len(scene.crater_x)]))
        self.others = others  # the lander's circles and the craters: a handful, tested without a grid
        self.fixed = tuple(np.concatenate([part, other]) for part, other in
                           zip((self.rocks.x, self.rocks.z, self.rocks.r, np.full(len(self.rocks.x), _ROCKS)),
                               others, strict=True))
        self.max_rise = math.tan(math.radians(params.navigation.max_slope_deg))
        self.may_be_steep = terrain.max_slope_bound_deg() > params.navigation.max_slope_deg

    def scan(self, xs: np.ndarray, zs: np.ndarray, hs: np.ndarray, which: np.ndarray) -> list[Scan]:
        """Scans of the rovers ``which`` (indices into xs/zs/hs, which hold every rover)."""
        return self.scans(xs, zs, hs, which).split()

    def scans(self, xs: np.ndarray, zs: np.ndarray, hs: np.ndarray, which: np.ndarray) -> Scans:
        """The scans of the rovers ``which``, end to end (``Scans``)."""
        if not len(which):
            return Scans(np.zeros(0), np.zeros(0), np.zeros(0, int), np.zeros(0, int))
        radius = self.params.perception.perception_radius
        ox, oz = xs[which], zs[which]
        dx, dz = geo.direction(hs[which][:, None] + self.rel[None, :])
        point, cx, cz, cr, source = self._circles(ox, oz, xs, zs, which, radius)
        t = _rays_circles(ox, oz, dx, dz, point, cx, cz, cr)
        n = len(which)  # craters show only where nothing solid is met: they go on rows of their own, n on
        nearest, kinds = _nearest((2 * n, dx.shape[1]), point + n * (source == _CRATERS), t, source)
        best, kind, crater = nearest[:n], kinds[:n], nearest[n:]
        for t_other, k in self._flat_solids(ox, oz, dx, dz, radius):
            closer = t_other < best
            best[closer], kind[closer] = t_other[closer], k
        use = (best > radius) & (crater <= radius)
        best[use], kind[use] = crater[use], CRATER
        hit = best <= radius
        return Scans(self.rel[np.nonzero(hit)[1]], best[hit], kind[hit], hit.sum(axis=1))

    def _circles(self, ox, oz, xs, zs, which, radius):
        """Every circle within reach of each scanning rover, as (rover, x, z, radius, source), its source the index
        into ``SOURCES``, which is the order a tie goes by. A circle out of reach is met, if at all, beyond
        the perception radius, so leaving it out changes no scan."""
        point, cx, cz, cr, source = self._fixed_circles(ox, oz, radius)
        rr = self.params.behaviour.rover_radius
        rover_point, other = circle_pairs(ox, oz, xs, zs, np.full(len(xs), rr), radius, max(radius + rr, 5.0))
        keep = other != which[rover_point]
        rover_point, other = rover_point[keep], other[keep]
        return (np.concatenate([point, rover_point]), np.concatenate([cx, xs[other]]),
                np.concatenate([cz, zs[other]]), np.concatenate([cr, np.full(len(other), rr)]),
                np.concatenate([source, np.full(len(other), _ROVERS)]))

    def _fixed_circles(self, ox, oz, radius):
        """The rocks, the lander and the craters within reach: tested all at once when they are few, the rocks
        through their grid when they are many."""
        if len(ox) * len(self.fixed[0]) <= FEW_PAIRS:
            point, c = near_pairs(ox, oz, *self.fixed[:3], radius)
            return (point, *(a[c] for a in self.fixed))
        point, rock = self.rocks.pairs(ox, oz, radius)
        other_point, other = near_pairs(ox, oz, *self.others[:3], radius)
        rocks = (self.rocks.x[rock], self.rocks.z[rock], self.rocks.r[rock], np.full(len(rock), _ROCKS))
        return (np.concatenate([point, other_point]),
                *(np.concatenate([a, b[other]]) for a, b in zip(rocks, self.others, strict=True)))

    def _flat_solids(self, ox, oz, dx, dz, radius):
        yield self._walls(ox, oz, dx, dz, radius), OBSTACLE
        if self.may_be_steep:
            yield self._steep_ground(ox, oz, dx, dz, radius), TERRAIN

    def _walls(self, ox, oz, dx, dz, radius):
        e = self.scene.edges
        if not len(e):
            return np.full(dx.shape, np.inf)
        d = geo.point_segment_distance(ox, oz, e[:, 0], e[:, 1], e[:, 2], e[:, 3])
        point, edge = np.nonzero(d <= radius)
        if not len(point):
            return np.full(dx.shape, np.inf)
        t = geo.ray_segment(ox[point, None], oz[point, None], dx[point], dz[point],
                            e[edge, 0, None], e[edge, 1, None], e[edge, 2, None], e[edge, 3, None])
        return _min_per_rover(dx.shape, point, t)

    def _steep_ground(self, ox, oz, dx, dz, radius):
        """Where the ground along a ray first rises faster than the rover can climb: a 'terrain' hit."""
        steps = np.arange(0.0, radius + 1e-9, TERRAIN_STEP_M)
        px = ox[:, None, None] + dx[..., None] * steps
        pz = oz[:, None, None] + dz[..., None] * steps
        heights = self.terrain.height(px.ravel(), pz.ravel()).reshape(px.shape)
        steep = np.diff(heights, axis=-1) / TERRAIN_STEP_M > self.max_rise
        first = np.argmax(steep, axis=-1)
        return np.where(steep.any(axis=-1), steps[first], np.inf)


def _rays_circles(ox, oz, dx, dz, point, cx, cz, cr) -> np.ndarray:
    """Entry distance of each pair's rover rays into its circle: shape (pairs, rays)."""
    if not len(point):
        return np.zeros((0, dx.shape[1]))
    return geo.ray_circle(ox[point, None], oz[point, None], dx[point], dz[point], cx[:, None], cz[:, None],
                          cr[:, None])


def _nearest(shape: tuple[int, int], point: np.ndarray, t: np.ndarray, source: np.ndarray) -> tuple[Rays, Rays]:
    """Each rover's nearest pair along each ray, and its kind: of equal distances, the earlier source's; -1 where
    the ray met nothing."""
    best = _min_per_rover(shape, point, t)
    if not len(point):
        return best, np.full(shape, -1)
    met = np.where((t == best[point]) & (t < np.inf), source[:, None], len(SOURCES))
    first = np.full(shape, len(SOURCES))
    np.minimum.at(first, point, met)
    return best, SOURCE_KINDS[first]


def _min_per_rover(shape: tuple[int, int], point: np.ndarray, t: np.ndarray) -> np.ndarray:
    out = np.full(shape, np.inf)
    if len(point):
        np.minimum.at(out, point, t)
    return out
