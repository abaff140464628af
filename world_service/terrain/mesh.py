"""Terrain meshes: import an OBJ/STL/PLY/GLB surface into the heightmap (``export`` writes one back out).

Import: the mesh (y up, x/z the ground plane, as Unity and NASA's lunar models) is loaded with trimesh and
kept as triangles binned on a coarse grid. A terrain tile asks for the heights of its node block and only
the triangles whose bins touch it are rasterised, vectorised over (triangle, node) pairs in bounded
batches: each node takes the highest surface above it (overhangs and vertical faces resolve to the top),
and nodes no triangle covers take the mesh's lowest height. Rasterising per tile keeps a large model's
grid out of memory just as procedural tiles do.
"""

from __future__ import annotations

import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import trimesh

from schemas.scenario_files import read_mesh

BATCH_PAIRS = 2_000_000
"""(triangle, node) pairs rasterised at once: bounds the temporary arrays to a few tens of MB."""
EDGE_TOLERANCE = 1e-9
"""Barycentric slack so nodes exactly on a shared edge are covered by both triangles."""


def load_vertices_faces(path: str | Path, scale: float | Sequence[float] = 1.0,
                        offset: Sequence[float] = (0.0, 0.0, 0.0)) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (scaled, then offset) and triangle faces of a mesh file; a multi-part scene is flattened.

    The file is read as the scenario's files are (``schemas.scenario_files``): a regular file of bounded size."""
    data, kind = read_mesh(Path(path))
    mesh = trimesh.load(io.BytesIO(data), file_type=kind, force="mesh")
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise ValueError(f"{path}: no triangles to make a terrain from")
    vertices = np.asarray(mesh.vertices, float) * np.broadcast_to(np.asarray(scale, float), 3)
    return vertices + np.asarray(offset, float), np.asarray(mesh.faces, np.int64)


@dataclass(frozen=True)
class _Triangles:
    """Per-triangle data for barycentric rasterisation in the x/z plane."""

    ax: np.ndarray
    az: np.ndarray
    ay: np.ndarray
    e1x: np.ndarray  # B - A
    e1z: np.ndarray
    e2x: np.ndarray  # C - A
    e2z: np.ndarray
    dy1: np.ndarray  # By - Ay
    dy2: np.ndarray  # Cy - Ay
    inv_det: np.ndarray
    lo: np.ndarray  # (n, 2) min x, z
    hi: np.ndarray  # (n, 2) max x, z

    @classmethod
    def of(cls, vertices: np.ndarray, faces: np.ndarray) -> _Triangles:
        """Triangles of the mesh, dropping those seen edge-on from above (vertical faces cover no node)."""
        a, b, c = (vertices[faces[:, k]] for k in range(3))
        e1, e2 = b - a, c - a
        det = e1[:, 0] * e2[:, 2] - e2[:, 0] * e1[:, 2]
        span = np.maximum(np.abs(e1[:, [0, 2]]).max(axis=1), np.abs(e2[:, [0, 2]]).max(axis=1))
        keep = np.abs(det) > 1e-12 * np.maximum(span * span, 1e-300)
        a, b, c, e1, e2, det = a[keep], b[keep], c[keep], e1[keep], e2[keep], det[keep]
        xz = np.stack([a[:, [0, 2]], b[:, [0, 2]], c[:, [0, 2]]])
        return cls(a[:, 0], a[:, 2], a[:, 1], e1[:, 0], e1[:, 2], e2[:, 0], e2[:, 2], e1[:, 1], e2[:, 1], 1.0 / det,
                   xz.min(axis=0), xz.max(axis=0))

    def __len__(self) -> int:
        return self.ax.size


class MeshSurface:
    """A triangle surface answering height blocks for terrain tiles (``landforms.HeightSource``)."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, bin_size_m: float = 256.0) -> None:
        self.triangles = _Triangles.of(np.asarray(vertices, float), np.asarray(faces, np.int64))
        if len(self.triangles) == 0:
            raise ValueError("the mesh has no triangles facing up or down")
        self.fill_height = float(np.min(vertices[:, 1]))
        self.bin_size = float(bin_size_m)
        self.bin_origin = self.triangles.lo.min(axis=0)
        self._bin_triangles()

    @classmethod
    def load(cls, path: str | Path, scale: float | Sequence[float] = 1.0, offset: Sequence[float] = (0.0, 0.0, 0.0),
             bin_size_m: float = 256.0) -> MeshSurface:
        return cls(*load_vertices_faces(path, scale, offset), bin_size_m=bin_size_m)

    def _bin_range(self, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        first = np.floor((lo - self.bin_origin) / self.bin_size).astype(np.int64)
        last = np.floor((hi - self.bin_origin) / self.bin_size).astype(np.int64)
        return np.clip(first, 0, self.bins - 1), np.clip(last, 0, self.bins - 1)

    def _bin_triangles(self) -> None:
        """CSR index bin -> triangles whose bounding box touches it, so a tile rasterises only its own."""
        t = self.triangles
        self.bins = (np.floor((t.hi.max(axis=0) - self.bin_origin) / self.bin_size).astype(np.int64) + 1)
        first, last = self._bin_range(t.lo, t.hi)
        width = last - first + 1
        tri, local = _expand(width[:, 0] * width[:, 1], 0, int((width[:, 0] * width[:, 1]).sum()))
        bx = first[tri, 0] + local % width[tri, 0]
        bz = first[tri, 1] + local // width[tri, 0]
        ids = bz * self.bins[0] + bx
        order = np.argsort(ids, kind="stable")
        self._bin_tris = tri[order]
        self._bin_start = np.searchsorted(ids[order], np.arange(self.bins[0] * self.bins[1] + 1))

    def _candidates(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """Triangles whose bounding box meets the rectangle lo..hi (x, z)."""
        if np.any(hi < self.triangles.lo.min(axis=0)) or np.any(lo > self.triangles.hi.max(axis=0)):
            return np.empty(0, np.int64)
        first, last = self._bin_range(lo, hi)
        rows = [self._bin_tris[self._bin_start[bz * self.bins[0] + first[0]]:
                               self._bin_start[bz * self.bins[0] + last[0] + 1]]
                for bz in range(first[1], last[1] + 1)]
        seen = np.zeros(len(self.triangles), bool)  # dedupe by marking: cheaper than np.unique's hashing
        seen[np.concatenate(rows)] = True
        cand = np.flatnonzero(seen)
        t = self.triangles
        meets = np.all(t.lo[cand] <= hi, axis=1) & np.all(t.hi[cand] >= lo, axis=1)
        return cand[meets]

    def block(self, x0: float, z0: float, resolution: float, nx: int, nz: int) -> np.ndarray:
        """Highest surface over each node of the block; uncovered nodes get the mesh's lowest height."""
        out = np.full((nz, nx), -np.inf)
        lo = np.array([x0, z0])
        hi = lo + resolution * np.array([nx - 1, nz - 1])
        cand = self._candidates(lo, hi)
        if cand.size:
            t = self.triangles
            first = np.ceil((t.lo[cand] - lo) / resolution - 1e-9).astype(np.int64).clip(0, [nx - 1, nz - 1])
            last = np.floor((t.hi[cand] - lo) / resolution + 1e-9).astype(np.int64).clip(-1, [nx - 1, nz - 1])
            width = np.maximum(last - first + 1, 0)
            counts = width[:, 0] * width[:, 1]
            total = int(counts.sum())
            for start in range(0, total, BATCH_PAIRS):
                tri, local = _expand(counts, start, min(start + BATCH_PAIRS, total))
                ix = first[tri, 0] + local % width[tri, 0]
                iz = first[tri, 1] + local // width[tri, 0]
                self._raster(out, cand[tri], ix, iz, x0 + ix * resolution, z0 + iz * resolution)
        out[np.isneginf(out)] = self.fill_height
        return out

    def _raster(self, out: np.ndarray, tri: np.ndarray, ix: np.ndarray, iz: np.ndarray,
                px: np.ndarray, pz: np.ndarray) -> None:
        """Barycentric test and interpolated height for (triangle, node) pairs; keep the max per node."""
        t = self.triangles
        dx, dz = px - t.ax[tri], pz - t.az[tri]
        u = (dx * t.e2z[tri] - t.e2x[tri] * dz) * t.inv_det[tri]
        v = (t.e1x[tri] * dz - dx * t.e1z[tri]) * t.inv_det[tri]
        inside = (u >= -EDGE_TOLERANCE) & (v >= -EDGE_TOLERANCE) & (u + v <= 1 + EDGE_TOLERANCE)
        y = t.ay[tri] + u * t.dy1[tri] + v * t.dy2[tri]
        np.maximum.at(out.reshape(-1), iz[inside] * out.shape[1] + ix[inside], y[inside])


def _expand(counts: np.ndarray, start: int, stop: int) -> tuple[np.ndarray, np.ndarray]:
    """Pairs start..stop of the flattened (item, k < counts[item]) enumeration, as (item, k) arrays."""
    ends = np.cumsum(counts)
    pair = np.arange(start, stop, dtype=np.int64)
    item = np.searchsorted(ends, pair, side="right")
    return item, pair - (ends[item] - counts[item])


# ---- export ----
