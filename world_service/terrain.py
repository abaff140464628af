"""Heightmap terrain on a regular grid: a flat (optionally rough) plain with crater bowls and raised rims.

The crater profile, with r = distance / radius: inside, a parabolic bowl rising to the crest
(``rim_height`` at r = 1); outside, the rim falls off with a half cosine to the plain at 1 + rim_width.
The crest is the highest point on any radial line, which is what the gyroscope-based climb seeks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from schemas.scenario import Crater, Scenario, TerrainSpec


def crater_profile(r: np.ndarray, crater: Crater) -> np.ndarray:
    """Height added by one crater at normalised radius ``r`` (0 at the centre, 1 on the crest)."""
    bowl = crater.rim_height - crater.depth * (1.0 - r * r)
    u = np.clip((r - 1.0) / crater.rim_width, 0.0, 1.0)
    rim = crater.rim_height * 0.5 * (1.0 + np.cos(np.pi * u))
    return np.where(r < 1.0, bowl, rim)


@dataclass
class Heightmap:
    origin_x: float
    origin_z: float
    resolution: float
    heights: np.ndarray  # shape (nz, nx), row = z index
    slope_x: np.ndarray
    slope_z: np.ndarray

    @classmethod
    def build(cls, spec: TerrainSpec, craters: list[Crater], rng: np.random.Generator) -> Heightmap:
        nx = int(np.ceil(spec.size_m[0] / spec.resolution_m)) + 1
        nz = int(np.ceil(spec.size_m[1] / spec.resolution_m)) + 1
        xs = spec.origin[0] + np.arange(nx) * spec.resolution_m
        zs = spec.origin[1] + np.arange(nz) * spec.resolution_m
        gx, gz = np.meshgrid(xs, zs)
        heights = np.zeros((nz, nx))
        if spec.roughness_m > 0:
            heights += _undulation(gx, gz, spec.roughness_m, rng)
        for crater in craters:
            r = np.hypot(gx - crater.x, gz - crater.z) / crater.radius_m
            near = r < 1.0 + crater.rim_width
            heights[near] += crater_profile(r[near], crater)
        slope_z, slope_x = np.gradient(heights, spec.resolution_m)
        return cls(spec.origin[0], spec.origin[1], spec.resolution_m, heights, slope_x, slope_z)

    @classmethod
    def from_scenario(cls, scenario: Scenario, rng: np.random.Generator) -> Heightmap:
        return cls.build(scenario.terrain_spec(), scenario.craters, rng)

    def _sample(self, grid: np.ndarray, x, z) -> np.ndarray:
        """Bilinear sample, clamped at the edges."""
        fx = np.clip((np.asarray(x, float) - self.origin_x) / self.resolution, 0, grid.shape[1] - 1.000001)
        fz = np.clip((np.asarray(z, float) - self.origin_z) / self.resolution, 0, grid.shape[0] - 1.000001)
        ix, iz = fx.astype(int), fz.astype(int)
        tx, tz = fx - ix, fz - iz
        top = grid[iz, ix] * (1 - tx) + grid[iz, ix + 1] * tx
        bottom = grid[iz + 1, ix] * (1 - tx) + grid[iz + 1, ix + 1] * tx
        return top * (1 - tz) + bottom * tz

    def height(self, x, z) -> np.ndarray:
        return self._sample(self.heights, x, z)

    def pitch_deg(self, x, z, heading_deg) -> np.ndarray:
        """Nose-up angle of a rover standing at (x, z) facing ``heading_deg``: the slope along its heading."""
        h = np.radians(heading_deg)
        along = self._sample(self.slope_x, x, z) * np.sin(h) + self._sample(self.slope_z, x, z) * np.cos(h)
        return np.degrees(np.arctan(along))


def _undulation(gx: np.ndarray, gz: np.ndarray, amplitude: float, rng: np.random.Generator) -> np.ndarray:
    """Gentle seeded ground roll: a few random long-wavelength sinusoids."""
    out = np.zeros_like(gx)
    for _ in range(6):
        wavelength = rng.uniform(20.0, 120.0)
        angle = rng.uniform(0, 2 * np.pi)
        phase = rng.uniform(0, 2 * np.pi)
        k = 2 * np.pi / wavelength
        out += np.sin(k * (gx * np.cos(angle) + gz * np.sin(angle)) + phase)
    return out * (amplitude / 6)
