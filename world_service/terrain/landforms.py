"""The landforms a terrain is made of, each a pure function of (x, z) and the seed, so a tile can be generated on its
own and still join its neighbours exactly: a seeded undulation (``roughness_m``) and crater bowls with raised rims.

The crater profile, with r = distance / radius: inside, a parabolic bowl rising to the crest (``rim_height`` at
r = 1); outside, the rim falls off with a half cosine to the plain at 1 + rim_width. The crest is the highest
point on any radial line, which is what the gyroscope-based climb seeks.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from schemas.scenario import Crater


def crater_profile(r: np.ndarray, crater: Crater) -> np.ndarray:
    """Height added by one crater at normalised radius ``r`` (0 at the centre, 1 on the crest)."""
    bowl = crater.rim_height - crater.depth * (1.0 - r * r)
    u = np.clip((r - 1.0) / crater.rim_width, 0.0, 1.0)
    rim = crater.rim_height * 0.5 * (1.0 + np.cos(np.pi * u))
    return np.where(r < 1.0, bowl, rim)


class HeightSource(Protocol):
    """A base surface under the procedural layers (an imported mesh, a raster): heights on a node block."""

    def block(self, x0: float, z0: float, resolution: float, nx: int, nz: int) -> np.ndarray:
        """Heights, shape (nz, nx), at nodes (x0 + i * resolution, z0 + j * resolution)."""
        ...


@dataclass(frozen=True)
class Undulation:
    """Gentle seeded ground roll: a few long-wavelength sinusoids, a pure function of (x, z)."""

    k: np.ndarray
    cos_a: np.ndarray
    sin_a: np.ndarray
    phase: np.ndarray
    amplitude: float

    @classmethod
    def draw(cls, amplitude: float, rng: np.random.Generator, waves: int = 6) -> Undulation:
        """Draw the waves in the same order the untiled generator did, so seeded worlds are unchanged."""
        params = []
        for _ in range(waves):
            wavelength = rng.uniform(20.0, 120.0)
            angle = rng.uniform(0, 2 * np.pi)
            phase = rng.uniform(0, 2 * np.pi)
            params.append((2 * np.pi / wavelength, np.cos(angle), np.sin(angle), phase))
        k, c, s, p = (np.array(v) for v in zip(*params, strict=True))
        return cls(k, c, s, p, amplitude)

    def grid(self, xs: np.ndarray, zs: np.ndarray) -> np.ndarray:
        """Values on the grid xs (columns) x zs (rows).

        Each wave is separable, sin(a(x) + b(z)) = sin a cos b + cos a sin b, so a tile costs sines of its
        rows and columns plus two outer products per wave instead of a sine per node (10x faster).
        """
        out = np.zeros((zs.size, xs.size))
        for k, c, s, p in zip(self.k, self.cos_a, self.sin_a, self.phase, strict=True):
            a, b = k * c * xs + p, k * s * zs
            out += np.cos(b)[:, None] * np.sin(a)[None, :]
            out += np.sin(b)[:, None] * np.cos(a)[None, :]
        return out * (self.amplitude / self.k.size)


@dataclass(frozen=True)
class CraterSet:
    """Craters as arrays, so finding the ones that reach a tile is one vectorised test."""

    craters: tuple[Crater, ...]
    x: np.ndarray
    z: np.ndarray
    reach: np.ndarray  # outer radius: where the rim meets the plain

    @classmethod
    def of(cls, craters: Iterable[Crater]) -> CraterSet:
        cs = tuple(craters)
        return cls(cs, np.array([c.x for c in cs]), np.array([c.z for c in cs]),
                   np.array([c.radius_m * (1.0 + c.rim_width) for c in cs]))

    def reaching(self, x0: float, x1: float, z0: float, z1: float) -> np.ndarray:
        """Indices of craters whose rim reaches the rectangle [x0, x1] x [z0, z1]."""
        dx = np.maximum(np.maximum(x0 - self.x, self.x - x1), 0.0)
        dz = np.maximum(np.maximum(z0 - self.z, self.z - z1), 0.0)
        return np.flatnonzero(np.hypot(dx, dz) < self.reach)

    def add_to(self, out: np.ndarray, xs: np.ndarray, zs: np.ndarray) -> None:
        """Add every crater reaching the block to ``out`` (rows zs, columns xs), only over its own footprint."""
        for index in self.reaching(xs[0], xs[-1], zs[0], zs[-1]):
            c, reach = self.craters[index], self.reach[index]
            i0, i1 = np.searchsorted(xs, [c.x - reach, c.x + reach], side="left")
            j0, j1 = np.searchsorted(zs, [c.z - reach, c.z + reach], side="left")
            i1, j1 = min(i1 + 1, xs.size), min(j1 + 1, zs.size)
            r = np.hypot(xs[None, i0:i1] - c.x, zs[j0:j1, None] - c.z) / c.radius_m
            near = r < 1.0 + c.rim_width
            out[j0:j1, i0:i1][near] += crater_profile(r[near], c)
