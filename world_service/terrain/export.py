"""Export the terrain as a GLB mesh for viewers (Foxglove, Blender, the web twin).

``export_glb`` samples the terrain on its own grid (downsampled by a step for big areas) and writes a y-up
triangle mesh viewers can load; tiles it needs but has not loaded are generated without entering the LRU, so an
export does not evict the rovers' working set.

    python -m world_service.terrain.export SCENARIO.yaml OUT.glb [--step N] [--bounds X0 Z0 X1 Z1]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import IO

import numpy as np
import trimesh

from world_service.terrain.heightmap import Heightmap

Bounds = tuple[float, float, float, float]


def export_glb(terrain: Heightmap, path_or_file: str | Path | IO[bytes], bounds: Bounds | str | None = None,
               step: int | None = None, max_vertices: int = 1_000_000) -> trimesh.Trimesh:
    """Write the terrain as a GLB triangle mesh (y up, x/z ground) and return the mesh.

    ``bounds`` is (x0, z0, x1, z1), ``"loaded"`` for the loaded tiles, or None for the whole terrain.
    ``step`` keeps every step-th grid node (the area's edge node is always kept); by default the smallest
    step that stays within ``max_vertices``, so a 50 km² area exports as a viewer-sized mesh.
    """
    ii, jj = _export_nodes(terrain, bounds, step, max_vertices)
    xs = terrain.origin_x + ii * terrain.resolution
    zs = terrain.origin_z + jj * terrain.resolution
    heights = terrain.height(xs[None, :], zs[:, None], cache=False)
    gx, gz = np.meshgrid(xs, zs)
    vertices = np.column_stack([gx.ravel(), heights.ravel(), gz.ravel()])
    mesh = trimesh.Trimesh(vertices=vertices, faces=_grid_faces(zs.size, xs.size), process=False)
    data = mesh.export(file_type="glb")
    if isinstance(path_or_file, (str, Path)):
        Path(path_or_file).write_bytes(data)
    else:
        path_or_file.write(data)
    return mesh


def _export_nodes(terrain: Heightmap, bounds: Bounds | str | None, step: int | None,
                  max_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid node indices along x and z covering the bounds, every ``step``-th plus the far edge."""
    if bounds == "loaded":
        if not terrain.loaded_tiles:
            raise ValueError("no tiles are loaded to export")
        boxes = np.array([terrain.tile_bounds(k) for k in terrain.loaded_tiles])
        bounds = (*boxes[:, :2].min(axis=0), *boxes[:, 2:].max(axis=0))
    elif bounds is None:
        bounds = (terrain.origin_x, terrain.origin_z, math.inf, math.inf)
    elif isinstance(bounds, str):
        raise ValueError(f"bounds must be (x0, z0, x1, z1), 'loaded' or None, not {bounds!r}")
    x0, z0, x1, z1 = bounds
    i0, i1 = _node_range(x0, x1, terrain.origin_x, terrain.resolution, terrain.nx)
    j0, j1 = _node_range(z0, z1, terrain.origin_z, terrain.resolution, terrain.nz)
    if step is None:
        step = max(1, math.ceil(math.sqrt((i1 - i0 + 1) * (j1 - j0 + 1) / max_vertices)))
    if step < 1:
        raise ValueError(f"step must be at least 1, got {step}")
    return (np.unique(np.append(np.arange(i0, i1 + 1, step), i1)),
            np.unique(np.append(np.arange(j0, j1 + 1, step), j1)))


def _node_range(lo: float, hi: float, origin: float, resolution: float, n: int) -> tuple[int, int]:
    """First and last node covering [lo, hi], clamped to the grid, at least two nodes apart by one."""
    first = int(np.clip(math.floor((lo - origin) / resolution + 1e-9), 0, n - 2))
    last = int(np.clip(math.ceil((min(hi, 1e300) - origin) / resolution - 1e-9), first + 1, n - 1))
    return first, last


def _grid_faces(rows: int, cols: int) -> np.ndarray:
    """Two triangles per grid cell, wound so their normals point up (+y) for rows along +z, columns +x."""
    a = (np.arange(rows - 1)[:, None] * cols + np.arange(cols - 1)[None, :]).ravel()
    return np.concatenate([np.column_stack([a, a + cols, a + 1]), np.column_stack([a + 1, a + cols, a + cols + 1])])


def main(argv: list[str] | None = None) -> int:
    """Export a scenario's terrain as GLB (a mesh path in the scenario is read relative to the file)."""
    from schemas.scenario import load_scenario

    parser = argparse.ArgumentParser(prog="python -m world_service.terrain.export", description=main.__doc__)
    parser.add_argument("scenario", type=Path)
    parser.add_argument("output", type=Path)
    parser.add_argument("--step", type=int, default=None, help="keep every N-th grid node (default: fit 1M vertices)")
    parser.add_argument("--bounds", type=float, nargs=4, metavar=("X0", "Z0", "X1", "Z1"), default=None)
    args = parser.parse_args(argv)
    scenario = load_scenario(args.scenario)
    terrain = Heightmap.from_scenario(scenario, np.random.default_rng(scenario.seed), base_dir=args.scenario.parent)
    mesh = export_glb(terrain, args.output, tuple(args.bounds) if args.bounds else None, args.step)
    print(f"wrote {args.output}: {len(mesh.vertices)} vertices, {len(mesh.faces)} triangles")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
