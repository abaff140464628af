"""Vectorised 2-D geometry on the x/z ground plane: rays against circles and segments, distances.

Every function broadcasts: rays of shape (R,) against shapes of shape (S,) give (R, S).
Headings follow the report: 0 = +z, 90 = +x, so a heading h points along (sin h, cos h).
"""

from __future__ import annotations

import itertools

import numpy as np

INF = np.inf


def direction(heading_deg: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
    h = np.radians(heading_deg)
    return np.sin(h), np.cos(h)


def ray_circle(ox, oz, dx, dz, cx, cz, r) -> np.ndarray:
    """Distance along unit rays to where each enters its circle, with ordinary NumPy broadcasting (ray i against
    circle i); inf if it misses or starts inside."""
    fx, fz = ox - cx, oz - cz
    b = fx * dx + fz * dz
    c = fx * fx + fz * fz - np.asarray(r, float) ** 2
    disc = b * b - c
    t = -b - np.sqrt(np.maximum(disc, 0.0))
    hit = (disc >= 0) & (c > 0) & (t >= 0)
    return np.where(hit, t, INF)


def ray_segments(ox, oz, dx, dz, ax, az, bx, bz) -> np.ndarray:
    """Distance along unit rays to each segment a-b; inf where they do not cross."""
    ox, oz, dx, dz = (np.asarray(a, float)[..., None] for a in (ox, oz, dx, dz))
    return ray_segment(ox, oz, dx, dz, ax, az, bx, bz)


def ray_segment(ox, oz, dx, dz, ax, az, bx, bz) -> np.ndarray:
    """Elementwise ``ray_segments``."""
    ex, ez = np.asarray(bx, float) - ax, np.asarray(bz, float) - az
    denom = dx * ez - dz * ex
    wx, wz = ax - ox, az - oz
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (wx * ez - wz * ex) / denom
        u = (wx * dz - wz * dx) / denom
    hit = (np.abs(denom) > 1e-12) & (t >= 0) & (u >= 0) & (u <= 1)
    return np.where(hit, t, INF)


def point_segment_distance(px, pz, ax, az, bx, bz) -> np.ndarray:
    """Distance from points (P,) to segments (S,): shape (P, S)."""
    px, pz = np.asarray(px, float)[..., None], np.asarray(pz, float)[..., None]
    ex, ez = np.asarray(bx, float) - ax, np.asarray(bz, float) - az
    length2 = np.maximum(ex * ex + ez * ez, 1e-12)
    u = np.clip(((px - ax) * ex + (pz - az) * ez) / length2, 0.0, 1.0)
    return np.hypot(px - (ax + u * ex), pz - (az + u * ez))


def segment_segment_distance(p0x, p0z, p1x, p1z, ax, az, bx, bz) -> np.ndarray:
    """Smallest distance between one segment p0-p1 and each segment a-b (S,)."""
    crossing = np.isfinite(_segment_crossing(p0x, p0z, p1x, p1z, ax, az, bx, bz))
    d = np.minimum.reduce([
        point_segment_distance(p0x, p0z, ax, az, bx, bz),
        point_segment_distance(p1x, p1z, ax, az, bx, bz),
        point_segment_distance(ax, az, p0x, p0z, p1x, p1z)[..., 0],
        point_segment_distance(bx, bz, p0x, p0z, p1x, p1z)[..., 0],
    ])
    return np.where(crossing, 0.0, d)


def _segment_crossing(p0x, p0z, p1x, p1z, ax, az, bx, bz) -> np.ndarray:
    length = float(np.hypot(p1x - p0x, p1z - p0z))
    if length < 1e-12:
        return np.full(np.shape(ax), INF)
    t = ray_segments(p0x, p0z, (p1x - p0x) / length, (p1z - p0z) / length, ax, az, bx, bz)
    return np.where(t <= length, t, INF)


def wall_edges(points: list[tuple[float, float]], thickness: float) -> np.ndarray:
    """The outline of a thick polyline as segments (K, 4): each piece becomes a rectangle's four sides."""
    edges = []
    half = thickness / 2
    for (x0, z0), (x1, z1) in itertools.pairwise(points):
        length = np.hypot(x1 - x0, z1 - z0)
        if length < 1e-9:
            continue
        nx, nz = -(z1 - z0) / length * half, (x1 - x0) / length * half
        ux, uz = (x1 - x0) / length * half, (z1 - z0) / length * half
        a = (x0 - ux + nx, z0 - uz + nz)
        b = (x1 + ux + nx, z1 + uz + nz)
        c = (x1 + ux - nx, z1 + uz - nz)
        d = (x0 - ux - nx, z0 - uz - nz)
        edges += [(*a, *b), (*b, *c), (*c, *d), (*d, *a)]
    return np.asarray(edges, float).reshape(-1, 4)
