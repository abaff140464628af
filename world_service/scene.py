"""What stands on the ground: rocks, walls, the lander, crater rims, and the rovers themselves.

Perception (report 10.1), the move check (10.2) and collision detection all ask the same question,
"what does this line or this disc meet?", so they share one set of arrays built once per scenario.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from schemas.messages import HIT_KINDS
from schemas.params import RoverParams
from schemas.scenario import Scenario
from world_service import geometry as geo

KIND_CODE = {kind: i for i, kind in enumerate(HIT_KINDS)}
ROVER, OBSTACLE, LANDER, CRATER = (KIND_CODE[k] for k in ("rover", "obstacle", "lander", "crater_terrain"))


@dataclass
class Scene:
    circle_x: np.ndarray  # solid circles: rocks and the lander
    circle_z: np.ndarray
    circle_r: np.ndarray
    circle_kind: np.ndarray
    edges: np.ndarray  # wall outlines, (K, 4)
    crater_x: np.ndarray  # crater terrain, perceived from outside, walkable
    crater_z: np.ndarray
    crater_r: np.ndarray

    @classmethod
    def from_scenario(cls, scenario: Scenario) -> Scene:
        rocks = scenario.obstacles.rocks
        lander = scenario.lander
        cx = np.array([r.x for r in rocks] + [lander.x], float)
        cz = np.array([r.z for r in rocks] + [lander.z], float)
        cr = np.array([r.radius_m for r in rocks] + [lander.radius_m], float)
        kinds = np.array([OBSTACLE] * len(rocks) + [LANDER], int)
        walls = [geo.wall_edges(w.points, w.thickness_m) for w in scenario.obstacles.walls]
        edges = np.concatenate(walls) if walls else np.zeros((0, 4))
        craters = scenario.craters
        return cls(cx, cz, cr, kinds, edges,
                   np.array([c.x for c in craters], float), np.array([c.z for c in craters], float),
                   np.array([c.outer_radius for c in craters], float))

    # ---- perception ----

    def scan(self, rover_x: np.ndarray, rover_z: np.ndarray, headings: np.ndarray, index: int,
             params: RoverParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One perception scan of rover ``index``: (angles_deg, distances_m, kind codes) of the rays that hit.

        Rays fan over the field of view in the rover's plane; each reports the nearest thing it meets.
        """
        p = params.perception
        radius = p.perception_radius
        ox, oz = rover_x[index], rover_z[index]
        rel = np.linspace(-p.field_of_view_degrees / 2, p.field_of_view_degrees / 2, p.perception_granularity)
        dx, dz = geo.direction(headings[index] + rel)
        others = np.arange(len(rover_x)) != index
        near = np.hypot(rover_x - ox, rover_z - oz) <= radius + params.behaviour.rover_radius
        rover_mask = others & near
        best = np.full(rel.shape, np.inf)
        kind = np.full(rel.shape, -1)
        for t, k in self._solid_hits(ox, oz, dx, dz, radius, rover_x[rover_mask], rover_z[rover_mask],
                                     params.behaviour.rover_radius):
            closer = t < best
            best = np.where(closer, t, best)
            kind = np.where(closer, k, kind)
        # Crater terrain is walkable ground, not a screen: it shows only on rays that meet nothing solid.
        crater = self._crater_hits(ox, oz, dx, dz, radius)
        use_crater = (best > radius) & (crater <= radius)
        best = np.where(use_crater, crater, best)
        kind = np.where(use_crater, CRATER, kind)
        hit = best <= radius
        return rel[hit], best[hit], kind[hit]

    def _solid_hits(self, ox, oz, dx, dz, radius, rx, rz, rover_radius):
        """(distance, kind) per ray for each family of solid shapes, culled to what is within reach."""
        reach = radius + 1e-6
        near = np.hypot(self.circle_x - ox, self.circle_z - oz) <= reach + self.circle_r
        if near.any():
            t = geo.ray_circles(ox, oz, dx, dz, self.circle_x[near], self.circle_z[near], self.circle_r[near])
            j = np.argmin(t, axis=1)
            yield t[np.arange(len(t)), j], self.circle_kind[near][j]
        if len(rx):
            t = geo.ray_circles(ox, oz, dx, dz, rx, rz, np.full(len(rx), rover_radius)).min(axis=1)
            yield t, ROVER
        if len(self.edges):
            e = self.edges
            t = geo.ray_segments(ox, oz, dx, dz, e[:, 0], e[:, 1], e[:, 2], e[:, 3]).min(axis=1)
            yield t, OBSTACLE

    def _crater_hits(self, ox, oz, dx, dz, radius) -> np.ndarray:
        near = np.hypot(self.crater_x - ox, self.crater_z - oz) <= radius + self.crater_r
        if not near.any():
            return np.full(np.shape(dx), np.inf)
        t = geo.ray_circles(ox, oz, dx, dz, self.crater_x[near], self.crater_z[near], self.crater_r[near])
        return t.min(axis=1)

    # ---- move check and contacts ----

    def line_blocked(self, x0: float, z0: float, x1: float, z1: float, clearance: float,
                     other_x: np.ndarray, other_z: np.ndarray, rover_radius: float) -> bool:
        """Whether a disc of radius ``clearance`` swept from (x0, z0) to (x1, z1) meets anything solid."""
        if len(self.circle_x):
            d = geo.point_segment_distance(self.circle_x, self.circle_z, x0, z0, x1, z1)[:, 0]
            if np.any(d < self.circle_r + clearance):
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

    def obstacle_contact(self, x: float, z: float, rover_radius: float) -> bool:
        """Whether a rover standing at (x, z) touches a rock, the lander or a wall."""
        if len(self.circle_x) and np.any(np.hypot(self.circle_x - x, self.circle_z - z) < self.circle_r + rover_radius):
            return True
        if len(self.edges):
            e = self.edges
            return bool(np.any(geo.point_segment_distance(x, z, e[:, 0], e[:, 1], e[:, 2], e[:, 3]) < rover_radius))
        return False


def in_view(rel_x: float, rel_z: float, fov_deg: float) -> bool:
    return abs(math.degrees(math.atan2(rel_x, rel_z))) <= fov_deg / 2 + 1e-6
