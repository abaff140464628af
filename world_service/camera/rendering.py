"""The rover's forward camera (report 10.5): a ray caster over the heightmap and the scene, and its PNG.

The report's simulator grabbed a frame from a Unity camera when a PhotoAction arrived. We have no engine, so the
photo is rendered here. Every pixel's ray is marched against the heightmap (compiled,
``world_service.terrain.height_grid``), then met analytically with rocks, the lander, other rovers and walls; the
nearest hit wins and is shaded with a low sun, as at the report's polar sites, over a black sky. The functions are
pure: the same world state gives the same image byte for byte, which is what makes photos comparable across runs.

Frames follow ``schemas.frames``: heading 0 looks along +z, 90 along +x; y is up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from schemas.params import CameraParams
from shared import png
from world_service.scene import LANDER, Scene

if TYPE_CHECKING:
    from world_service.terrain.height_grid import HeightGrid

SKY, TERRAIN, ROCK, LANDER_BODY, ROVER_BODY, WALL = range(6)

# Surface colours (linear reflectance) per hit kind. Rovers are gold so that they stand out in any photo.
ALBEDO = np.array([
    [0.00, 0.00, 0.00],  # sky: no atmosphere, black even in daylight
    [0.55, 0.55, 0.55],  # regolith: neutral grey
    [0.42, 0.37, 0.32],  # rocks: a darker, warm grey
    [0.95, 0.95, 0.92],  # lander: white-ish
    [1.00, 0.78, 0.15],  # rovers: gold
    [0.40, 0.44, 0.50],  # walls: a cool grey, unlike both terrain and rocks
])
AMBIENT = 0.08  # earthshine and scattered light, so shadowed sides are not pure black
SUN_GAIN = 2.2  # a grazing sun lights flat ground at sin(15 deg) ~ 0.26; the gain brings that to mid grey
EXPOSURE = 1.5  # tone curve 1 - exp(-exposure * radiance): sunlit faces saturate softly and keep their hue

FIRST_STEP_M = 0.2  # the march starts this far out: a level camera's lowest rays meet the ground ~0.7 m out
MIN_STEP_M = 0.2  # near the camera steps stay this long; linear refinement places the crossing within them
STEP_GROWTH = 0.03  # each step is 3% of the distance so far: far away, a pixel covers more ground
NORMAL_EPS_M = 0.25  # finite-difference half-width for terrain normals
WALL_HEIGHT_M = 2.0
PAIR_BUDGET = 4_000_000  # (pixel, wall edge) pairs tested at once, to bound memory on long walls


class HeightField(Protocol):
    """All the camera needs of the terrain: vectorised ground height, and the height nodes within its range as
    one block to march rays in. Any tiling of the terrain satisfies it."""

    def height(self, x, z) -> np.ndarray: ...

    def grid_around(self, x: float, z: float, reach: float) -> HeightGrid: ...


def sun_direction(azimuth_deg: float, elevation_deg: float) -> tuple[float, float, float]:
    """Unit vector towards the sun, azimuth measured like headings (0 = +z, 90 = +x)."""
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    return (math.sin(az) * math.cos(el), math.sin(el), math.cos(az) * math.cos(el))


DEFAULT_SUN_DIR = sun_direction(120.0, 15.0)  # polar sites: the sun never climbs far above the horizon


@dataclass
class _Camera:
    """Where the camera is and how pixels map to directions; rows of ``basis`` are right, up, forward."""

    origin: np.ndarray  # (3,)
    basis: np.ndarray  # (3, 3)
    width: int
    height: int
    scale: float  # tan(horizontal fov / 2)
    max_range: float

    def col(self, u: float) -> float:
        """Pixel column (continuous) of the image-plane coordinate u = right / forward."""
        return (u / self.scale + 1.0) * self.width / 2 - 0.5

    def row(self, v: float) -> float:
        """Pixel row (continuous, 0 at the top) of the image-plane coordinate v = up / forward."""
        return self.height / 2 - 0.5 - v * (self.width / 2) / self.scale


@dataclass
class _Hits:
    """Per pixel: distance to the nearest surface so far, what it is, and its unit normal."""

    t: np.ndarray  # (H, W)
    kind: np.ndarray  # (H, W) int
    normal: np.ndarray  # (H, W, 3)

    def take_nearer(self, region: tuple[slice, slice], t: np.ndarray, kind: int, normal: np.ndarray) -> None:
        """Keep the new surface wherever it is nearer than what the pixels in ``region`` already see."""
        t_view, kind_view, normal_view = self.t[region], self.kind[region], self.normal[region]
        closer = t < t_view
        t_view[closer] = t[closer]
        kind_view[closer] = kind
        normal_view[closer] = normal[closer]


# ---- the whole picture ----


def render(terrain: HeightField, scene: Scene, rovers_x: np.ndarray, rovers_z: np.ndarray, rover_radius: float,
           x: float, z: float, heading_deg: float, params: CameraParams,
           sun_dir: tuple[float, float, float] = DEFAULT_SUN_DIR, tilt_deg: float = 0.0) -> np.ndarray:
    """What the forward camera of a rover at (x, z) facing ``heading_deg`` sees: (height, width, 3) uint8 RGB.

    The camera sits ``params.mount_height_m`` above the ground and looks level (``tilt_deg`` > 0 looks down), so
    on flat ground the horizon runs through the middle of the image. ``rovers_x``/``rovers_z`` may include the
    camera's own rover: any rover within 1 cm of (x, z) is taken to be it and left out.
    """
    cam = _make_camera(terrain, x, z, heading_deg, params, tilt_deg)
    dirs = _pixel_directions(cam)
    hits = _terrain_hits(terrain, cam, dirs)
    circle_kind = np.where(np.asarray(scene.circle_kind) == LANDER, LANDER_BODY, ROCK)
    _sphere_hits(hits, terrain, cam, dirs, scene.circle_x, scene.circle_z, scene.circle_r, circle_kind)
    others = np.hypot(np.asarray(rovers_x, float) - x, np.asarray(rovers_z, float) - z) > 0.01
    rx, rz = np.asarray(rovers_x, float)[others], np.asarray(rovers_z, float)[others]
    _sphere_hits(hits, terrain, cam, dirs, rx, rz, np.full(len(rx), rover_radius), np.full(len(rx), ROVER_BODY))
    _wall_hits(hits, terrain, cam, dirs, np.asarray(scene.edges, float).reshape(-1, 4))
    return _shade(hits, np.asarray(sun_dir, float))


def _make_camera(terrain: HeightField, x: float, z: float, heading_deg: float, params: CameraParams,
                 tilt_deg: float) -> _Camera:
    """Place the camera on the ground under (x, z) and orient it: forward along the heading, tilted down."""
    h, tilt = math.radians(heading_deg), math.radians(tilt_deg)
    right = (math.cos(h), 0.0, -math.sin(h))
    up = (math.sin(h) * math.sin(tilt), math.cos(tilt), math.cos(h) * math.sin(tilt))
    forward = (math.sin(h) * math.cos(tilt), -math.sin(tilt), math.cos(h) * math.cos(tilt))
    ground = float(np.asarray(terrain.height(np.array([x]), np.array([z])))[0])
    origin = np.array([x, ground + params.mount_height_m, z])
    return _Camera(origin, np.array([right, up, forward]), params.width, params.height,
                   math.tan(math.radians(params.horizontal_fov_deg) / 2), params.max_range_m)


def _pixel_directions(cam: _Camera) -> np.ndarray:
    """Unit ray direction through every pixel centre, (H, W, 3); square pixels, so the vertical fov follows."""
    half_w = cam.width / 2
    u = (np.arange(cam.width) + 0.5 - half_w) / half_w * cam.scale
    v = (cam.height / 2 - np.arange(cam.height) - 0.5) / half_w * cam.scale
    right, up, forward = cam.basis
    d = forward + u[None, :, None] * right + v[:, None, None] * up
    return d / np.linalg.norm(d, axis=2, keepdims=True)


# ---- terrain ----


def _terrain_hits(terrain: HeightField, cam: _Camera, dirs: np.ndarray) -> _Hits:
    """Start the per-pixel record from the terrain: where each ray first meets the ground, and its normal there
    (central differences of the height ``NORMAL_EPS_M`` either side).

    Rays march in a block of the height grid around the camera, compiled (``HeightGrid.surface``): a rising ray
    stops once it is above the highest ground the terrain can have, so the sky costs a few steps, not 170.
    """
    shape = dirs.shape[:2]
    grid = terrain.grid_around(float(cam.origin[0]), float(cam.origin[2]), cam.max_range)
    t, normal = grid.surface(cam.origin, dirs.reshape(-1, 3), cam.max_range, FIRST_STEP_M, MIN_STEP_M, STEP_GROWTH,
                             NORMAL_EPS_M)
    kind = np.where(np.isfinite(t), TERRAIN, SKY)
    return _Hits(t.reshape(shape), kind.reshape(shape), normal.reshape(*shape, 3))


# ---- rocks, the lander and rovers: spheres centred on the ground ----


def _sphere_hits(hits: _Hits, terrain: HeightField, cam: _Camera, dirs: np.ndarray, cx: np.ndarray,
                 cz: np.ndarray, radius: np.ndarray, kinds: np.ndarray) -> None:
    """Meet every ray with spheres centred on the ground at (cx, cz).

    Spheres out of range or behind the camera are dropped; each remaining one is tested only on the pixels of
    its screen-space bounding box, so a field of many small rocks costs little more than the pixels they cover.
    """
    cx, cz, radius = (np.asarray(a, float).reshape(-1) for a in (cx, cz, radius))
    if not len(cx):
        return
    centres = np.stack([cx, terrain.height(cx, cz), cz], axis=1)
    rel = centres - cam.origin
    in_range = np.linalg.norm(rel, axis=1) - radius <= cam.max_range
    in_front = rel @ cam.basis[2] + radius > 0
    for i in np.flatnonzero(in_range & in_front):
        region = _screen_box(cam, rel[i], radius[i])
        if region is not None:
            t, normal = _ray_sphere(dirs[region], rel[i], radius[i])
            hits.take_nearer(region, t, int(kinds[i]), normal)


def _screen_box(cam: _Camera, rel: np.ndarray, radius: float) -> tuple[slice, slice] | None:
    """Pixel rows and columns that a sphere at ``rel`` from the camera can cover (conservative), or None."""
    right, up, forward = cam.basis @ rel
    full = (slice(0, cam.height), slice(0, cam.width))
    if forward - radius <= 1e-6:  # the sphere reaches beside or behind the camera: no finite box
        return full
    near, far = forward - radius, forward + radius
    us = [(right - radius) / near, (right - radius) / far, (right + radius) / near, (right + radius) / far]
    vs = [(up - radius) / near, (up - radius) / far, (up + radius) / near, (up + radius) / far]
    c0, c1 = math.floor(cam.col(min(us))), math.ceil(cam.col(max(us))) + 1
    r0, r1 = math.floor(cam.row(max(vs))), math.ceil(cam.row(min(vs))) + 1
    c0, c1, r0, r1 = max(c0, 0), min(c1, cam.width), max(r0, 0), min(r1, cam.height)
    if c0 >= c1 or r0 >= r1:
        return None
    return (slice(r0, r1), slice(c0, c1))


def _ray_sphere(dirs: np.ndarray, rel: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Distance to the near side of a sphere (inf on a miss) and the outward normal there.

    A camera inside the sphere sees nothing of it, as in the perception rays of ``geometry.ray_circle``.
    """
    b = dirs @ rel
    c = float(rel @ rel) - radius * radius
    if c <= 0:
        return np.full(dirs.shape[:-1], np.inf), np.zeros_like(dirs)
    disc = b * b - c
    root = np.sqrt(np.maximum(disc, 0.0))
    t = np.where((disc >= 0) & (b - root > 0), b - root, np.inf)
    normal = (np.where(np.isfinite(t), t, 0.0)[..., None] * dirs - rel) / radius
    return t, normal


# ---- walls: vertical rectangles standing on the ground ----


def _wall_hits(hits: _Hits, terrain: HeightField, cam: _Camera, dirs: np.ndarray, edges: np.ndarray) -> None:
    """Meet every ray with the wall outlines, each edge a vertical face from the ground up to 2 m."""
    edges = _edges_in_view(cam, edges)
    if not len(edges):
        return
    ground = np.stack([terrain.height(edges[:, 0], edges[:, 1]), terrain.height(edges[:, 2], edges[:, 3])], axis=1)
    flat = dirs.reshape(-1, 3)
    chunk = max(1, PAIR_BUDGET // len(flat))
    full = (slice(None), slice(None))
    for k in range(0, len(edges), chunk):
        t, normal = _ray_walls(cam.origin, flat, edges[k:k + chunk], ground[k:k + chunk])
        hits.take_nearer(full, t.reshape(hits.t.shape), WALL, normal.reshape(hits.normal.shape))


def _edges_in_view(cam: _Camera, edges: np.ndarray) -> np.ndarray:
    """The wall edges that could be seen: some part within range and not wholly behind the camera."""
    if not len(edges):
        return edges
    ax, az, bx, bz = edges.T
    ox, oz = cam.origin[0], cam.origin[2]
    ex, ez = bx - ax, bz - az
    s = np.clip(((ox - ax) * ex + (oz - az) * ez) / np.maximum(ex * ex + ez * ez, 1e-12), 0.0, 1.0)
    near = np.hypot(ax + s * ex - ox, az + s * ez - oz) <= cam.max_range
    fwd_x, fwd_z = cam.basis[2][0], cam.basis[2][2]
    ahead = ((ax - ox) * fwd_x + (az - oz) * fwd_z > 0) | ((bx - ox) * fwd_x + (bz - oz) * fwd_z > 0)
    return edges[near & ahead]


def _ray_walls(origin: np.ndarray, dirs: np.ndarray, edges: np.ndarray,
               ground: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest wall face per ray over a batch of edges: (distance (P,), unit normal facing the ray (P, 3)).

    The 2D ray/segment crossing uses the 3D ray parameter, so its ``t`` is the 3D distance; the face's bottom
    follows the ground linearly between the edge's end points.
    """
    ox, oy, oz = origin
    dx, dy, dz = dirs[:, 0:1], dirs[:, 1:2], dirs[:, 2:3]
    ax, az, bx, bz = edges.T
    ex, ez = bx - ax, bz - az
    wx, wz = ax - ox, az - oz
    denom = dx * ez - dz * ex
    safe = np.where(np.abs(denom) > 1e-12, denom, np.nan)
    with np.errstate(invalid="ignore"):
        t = (wx * ez - wz * ex) / safe
        s = (wx * dz - wz * dx) / safe
        top = ground[:, 0] + s * (ground[:, 1] - ground[:, 0]) + WALL_HEIGHT_M
        ok = (t > 0) & (s >= 0) & (s <= 1) & (oy + t * dy <= top)
    t = np.where(ok, t, np.inf)
    j = np.argmin(t, axis=1)
    best = t[np.arange(len(t)), j]
    length = np.maximum(np.hypot(ex, ez), 1e-12)
    normal = np.stack([-ez[j] / length[j], np.zeros(len(j)), ex[j] / length[j]], axis=1)
    facing = np.sum(normal * dirs, axis=1) > 0
    normal[facing] *= -1
    return best, normal


# ---- shading ----


def _shade(hits: _Hits, sun_dir: np.ndarray) -> np.ndarray:
    """Lambert under one low sun plus a little ambient light, through a soft tone curve; the sky stays black.

    At a polar site the sun grazes the ground, so a sunlit rock face gets three to four times the light of the
    plain around it; a plain clip would wash it to white, the tone curve keeps it bright but coloured.
    """
    sun = sun_dir / np.linalg.norm(sun_dir)
    lambert = np.maximum(hits.normal @ sun, 0.0)
    light = AMBIENT + SUN_GAIN * lambert
    radiance = ALBEDO[hits.kind] * light[..., None]
    rgb = 1.0 - np.exp(-EXPOSURE * radiance)
    return np.round(np.clip(rgb, 0.0, 1.0) * 255).astype(np.uint8)


# ---- PNG ----


def encode_png(image: np.ndarray) -> bytes:
    """An RGB8 PNG of a (height, width, 3) uint8 image (``shared.png``: one IDAT, no row filtering)."""
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] != 3 or image.dtype != np.uint8 or 0 in image.shape:
        raise ValueError(f"encode_png wants a non-empty (height, width, 3) uint8 array, got {image.shape} "
                         f"{image.dtype}")
    height, width = image.shape[:2]
    return png.encode(width, height, image.tobytes(), channels=3)
