"""Perception (report 10.1) for many rovers at once: every ray of every rover scanned this tick in one go.

Rays fan over the field of view in each rover's plane; each reports the nearest thing it meets within
the perception radius. Solid things (rovers, rocks, walls, the lander, ground rising more steeply than a
rover can climb) come first; crater terrain is walkable ground, so it shows only on rays that meet
nothing solid. Rocks are found through a grid over their centres, everything else by culled pairs, so
cost grows with what is near the rovers, not with everything in the world.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from schemas.params import RoverParams
from world_service import geometry as geo
from world_service.scene import CRATER, LANDER, OBSTACLE, ROVER, TERRAIN, CircleGrid, Scene, circle_pairs

TERRAIN_STEP_M = 1.0
"""Spacing of the samples along each ray that look for ground too steep to climb."""


@dataclass
class Scan:
    angles_deg: np.ndarray
    distances_m: np.ndarray
    kinds: np.ndarray


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
        self.lander = (scene.circle_x[~rocks], scene.circle_z[~rocks], scene.circle_r[~rocks])
        self.max_rise = math.tan(math.radians(params.navigation.max_slope_deg))
        self.may_be_steep = terrain.max_slope_bound_deg() > params.navigation.max_slope_deg

    def scan(self, xs: np.ndarray, zs: np.ndarray, hs: np.ndarray, which: np.ndarray) -> list[Scan]:
        """Scans of the rovers ``which`` (indices into xs/zs/hs, which hold every rover)."""
        if not len(which):
            return []
        radius = self.params.perception.perception_radius
        ox, oz = xs[which], zs[which]
        dx, dz = geo.direction(hs[which][:, None] + self.rel[None, :])
        best = np.full(dx.shape, np.inf)
        kind = np.full(dx.shape, -1)
        for t, k in self._solid(ox, oz, dx, dz, xs, zs, which, radius):
            closer = t < best
            best[closer], kind[closer] = t[closer], k
        crater = self._craters(ox, oz, dx, dz, radius)
        use = (best > radius) & (crater <= radius)
        best[use], kind[use] = crater[use], CRATER
        return [Scan(self.rel[hit], best[i][hit], kind[i][hit]) for i in range(len(which))
                for hit in [best[i] <= radius]]

    def _solid(self, ox, oz, dx, dz, xs, zs, which, radius):
        point, circle = self.rocks.pairs(ox, oz, radius)
        yield _min_per_rover(dx.shape, point, _rays_circles(ox, oz, dx, dz, point, self.rocks.x[circle],
                                                            self.rocks.z[circle], self.rocks.r[circle])), OBSTACLE
        lx, lz, lr = self.lander
        if len(lx):
            t = np.min([geo.ray_circle(ox[:, None], oz[:, None], dx, dz, x, z, r)
                        for x, z, r in zip(lx, lz, lr, strict=True)], axis=0)
            yield t, LANDER
        yield self._rovers(ox, oz, dx, dz, xs, zs, which, radius), ROVER
        yield self._walls(ox, oz, dx, dz, radius), OBSTACLE
        if self.may_be_steep:
            yield self._steep_ground(ox, oz, dx, dz, radius), TERRAIN

    def _rovers(self, ox, oz, dx, dz, xs, zs, which, radius):
        rr = self.params.behaviour.rover_radius
        point, other = circle_pairs(ox, oz, xs, zs, np.full(len(xs), rr), radius, max(radius + rr, 5.0))
        keep = other != which[point]
        point, other = point[keep], other[keep]
        return _min_per_rover(dx.shape, point, _rays_circles(ox, oz, dx, dz, point, xs[other], zs[other],
                                                             np.full(len(other), rr)))

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

    def _craters(self, ox, oz, dx, dz, radius):
        s = self.scene
        if not len(s.crater_x):
            return np.full(dx.shape, np.inf)
        d = np.hypot(s.crater_x[None, :] - ox[:, None], s.crater_z[None, :] - oz[:, None])
        point, c = np.nonzero(d <= radius + s.crater_r[None, :])
        return _min_per_rover(dx.shape, point, _rays_circles(ox, oz, dx, dz, point, s.crater_x[c], s.crater_z[c],
                                                             s.crater_r[c]))

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


def _min_per_rover(shape: tuple[int, int], point: np.ndarray, t: np.ndarray) -> np.ndarray:
    out = np.full(shape, np.inf)
    if len(point):
        np.minimum.at(out, point, t)
    return out
