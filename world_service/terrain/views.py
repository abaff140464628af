"""Views of a ``Heightmap`` for the camera, which samples it hundreds of thousands of times a photo: the whole grid
held at once (``DenseView``), or the tiles sampled without touching the cache the world's thread uses
(``UncachedView``, safe beside it)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from world_service.terrain.heightmap import Heightmap

if TYPE_CHECKING:
    from world_service.terrain.height_grid import HeightGrid


class DenseView:
    """The whole height grid held at once, sampled by compiled loops (``HeightGrid``): for the camera's hundreds
    of thousands of samples a photo. Same bilinear formula, so the same values as the Heightmap's; only for
    terrains small enough to assemble (``FULL_GRID_LIMIT``)."""

    def __init__(self, terrain: Heightmap) -> None:
        self._grid = terrain.grid(0, terrain.nx - 1, 0, terrain.nz - 1, cache=False)

    def height(self, x, z) -> np.ndarray:
        return self._grid.height(x, z)

    def grid_around(self, x: float, z: float, reach: float) -> HeightGrid:
        return self._grid


class UncachedView:
    """``height(x, z)`` of a Heightmap, sampled with ``cache=False`` (the camera renders off the world thread)."""

    def __init__(self, terrain: Heightmap) -> None:
        self._terrain = terrain

    def height(self, x, z) -> np.ndarray:
        return self._terrain.height(x, z, cache=False)

    def grid_around(self, x: float, z: float, reach: float) -> HeightGrid:
        return self._terrain.grid_around(x, z, reach, cache=False)
