"""The forward camera (report 10.5): renders of known scenes, and the PNG codec photos are saved with."""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest

from schemas.params import CameraParams
from schemas.scenario import Crater, TerrainSpec, parse_scenario
from shared import png
from world_service.camera import rendering
from world_service.scene import Scene
from world_service.terrain.heightmap import Heightmap

# Small images keep the file fast; 80 x 60 still puts the horizon between rows 29 and 30 and a column at 39/40.
PARAMS = CameraParams(width=80, height=60, max_range_m=150.0)
HORIZON_ROW = PARAMS.height // 2  # first row below the horizon of a level camera on flat ground
MID_COLS = slice(PARAMS.width // 2 - 2, PARAMS.width // 2 + 2)
SPEC = TerrainSpec(origin=(-100.0, -100.0), size_m=(200.0, 200.0), resolution_m=1.0)
NO_ROVERS = np.zeros(0)


def decode_png(data: bytes) -> np.ndarray:
    """Read back an RGB8 PNG that ``rendering.encode_png`` writes; anything else is a ValueError."""
    width, height, channels, pixels = png.decode(data)
    if channels != 3:
        raise ValueError(f"expected an RGB PNG, got {channels} channel(s)")
    return np.frombuffer(pixels, np.uint8).reshape(height, width, 3).copy()


def _flat() -> Heightmap:
    return Heightmap.build(SPEC, [], np.random.default_rng(0))


def _scene(rocks=(), walls=()) -> Scene:
    return Scene.from_scenario(parse_scenario({
        "name": "camera",
        "lander": {"x": -80.0, "z": -80.0},
        "rovers": [{"x": 0.0, "z": 0.0, "heading_deg": 0.0}],
        "obstacles": {"rocks": [{"x": x, "z": z, "radius_m": r} for x, z, r in rocks],
                      "walls": [{"points": list(w), "thickness_m": 0.5} for w in walls]},
        "mission": [{"x": 0.0, "z": 50.0}],
    }))


def _shot(terrain=None, scene=None, rovers=((0.0, 0.0),), x=0.0, z=0.0, heading=0.0, rover_radius=0.5,
          **kwargs) -> np.ndarray:
    """A photo from (x, z) facing ``heading``; by default the camera's own rover is in the rover list."""
    rx = np.array([r[0] for r in rovers], float)
    rz = np.array([r[1] for r in rovers], float)
    terrain = terrain if terrain is not None else _flat()
    scene = scene if scene is not None else _scene()
    return rendering.render(terrain, scene, rx, rz, rover_radius, x, z, heading, PARAMS, **kwargs)


def _warm(pixels: np.ndarray) -> np.ndarray:
    """Red minus blue: zero on the neutral grey regolith, positive on rocks and rovers."""
    return pixels[..., 0].astype(int) - pixels[..., 2].astype(int)


# ---- the picture ----


def test_image_has_the_configured_shape_and_content():
    image = _shot()
    assert image.shape == (PARAMS.height, PARAMS.width, 3)
    assert image.dtype == np.uint8
    assert image.min() != image.max()


def test_ground_below_is_lit_and_the_sky_above_is_black():
    image = _shot().astype(int)
    assert (image[:HORIZON_ROW] == 0).all()  # a level camera on flat ground: sky down to the horizon
    lower = image[HORIZON_ROW:]
    assert lower.mean() > 50
    assert (lower > 0).all()  # every ray below the horizon meets the ground within 150 m here
    assert np.ptp(lower, axis=2).max() == 0  # regolith is neutral grey


def test_a_rock_straight_ahead_shows_and_one_behind_does_not():
    empty = _shot()
    ahead = _shot(scene=_scene(rocks=[(0.0, 8.0, 1.0)]))
    band = (slice(HORIZON_ROW, HORIZON_ROW + 3), MID_COLS)  # just below the horizon, in the middle
    assert (ahead[band] != empty[band]).any(axis=2).all()
    assert (_warm(ahead[band]) > 5).all()  # the rock's warm grey, not the neutral ground
    # a rock 8 m ahead, 1 m radius, spans about +-7 degrees of a 60 degree view: it leaves the sides alone
    assert (ahead[:, :20] == empty[:, :20]).all() and (ahead[:, -20:] == empty[:, -20:]).all()
    behind = _shot(scene=_scene(rocks=[(0.0, -8.0, 1.0)]))
    assert (behind == empty).all()


def test_the_rock_moves_with_the_heading():
    rock = _scene(rocks=[(8.0, 0.0, 1.0)])  # 8 m along +x: straight ahead only when facing 90
    band = (slice(HORIZON_ROW, HORIZON_ROW + 3), MID_COLS)
    sun = rendering.sun_direction(270.0, 20.0)  # behind a camera facing +x, so the rock's face towards it is lit
    assert (_warm(_shot(scene=rock, heading=90.0, sun_dir=sun)[band]) > 5).all()
    assert (_shot(scene=rock, heading=270.0) == _shot(heading=270.0)).all()


def test_another_rover_ahead_shows_gold():
    image = _shot(rovers=[(0.0, 0.0), (0.0, 6.0)])
    pixels = image[HORIZON_ROW - 2:HORIZON_ROW + 2, MID_COLS].astype(int)
    red, green, blue = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    assert (red > 2 * blue).all() and (green > 2 * blue).all() and (red >= green).all()


def test_the_cameras_own_rover_is_left_out():
    # A small body, looking steeply down, would fill the lower image if the camera's own rover were drawn.
    kwargs = {"rover_radius": 0.25, "tilt_deg": 60.0}
    alone = _shot(rovers=[], **kwargs)
    assert (_shot(rovers=[(0.0, 0.0)], **kwargs) == alone).all()
    other = _shot(rovers=[(0.0, 0.0)], x=0.0, z=-0.5, **kwargs)  # 0.5 m behind: now that rover is someone else
    assert (other != _shot(rovers=[], x=0.0, z=-0.5, **kwargs)).any()


def test_a_wall_across_the_view_hides_the_horizon():
    image = _shot(scene=_scene(walls=[[(-30.0, 10.0), (30.0, 10.0)]]))
    # 2 m high, 10 m ahead, camera 0.3 m up: the wall rises ~9.5 degrees above the horizon
    above = image[HORIZON_ROW - 5:HORIZON_ROW, MID_COLS].astype(int)
    assert (above > 0).all()
    assert (above[..., 2] > above[..., 0]).all()  # the walls' cool grey
    assert (image[:5] == 0).all()  # sky above the top of the wall


def test_crater_seen_from_its_rim_shows_the_bowl():
    crater = Crater(x=0.0, z=30.0, radius_m=20.0)  # crest 10 m ahead of the centre's near side, at z = 10
    bowl = Heightmap.build(SPEC, [crater], np.random.default_rng(0))
    sun = rendering.sun_direction(180.0, 15.0)  # low sun behind the camera: the far wall faces it
    inside = _shot(terrain=bowl, z=10.0, sun_dir=sun)
    plain = _shot(z=10.0, sun_dir=sun)
    ground = plain.any(axis=2)
    assert (inside != plain).any(axis=2)[ground].mean() > 0.5
    column = inside[:, PARAMS.width // 2, 0].astype(int)
    flat_grey = int(plain[-1, PARAMS.width // 2, 0])
    lit = column[column > 0]
    assert lit[:5].min() > flat_grey  # the far wall, turned towards the sun
    assert column[-5:].max() < flat_grey  # the near inner slope, turned away from it


def test_sun_direction_is_a_unit_vector_in_heading_convention():
    x, y, z = rendering.sun_direction(90.0, 0.0)
    assert np.allclose((x, y, z), (1.0, 0.0, 0.0))
    assert np.isclose(np.linalg.norm(rendering.DEFAULT_SUN_DIR), 1.0)
    assert 0 < rendering.DEFAULT_SUN_DIR[1] < 0.5  # a low, polar sun


# ---- PNG ----


def test_png_round_trip_is_exact():
    image = np.random.default_rng(1).integers(0, 256, size=(7, 11, 3), dtype=np.uint8)
    data = rendering.encode_png(image)
    assert data.startswith(b"\x89PNG\r\n\x1a\n")
    assert data[12:16] == b"IHDR" and struct.unpack(">II", data[16:24]) == (11, 7)
    decoded = decode_png(data)
    assert decoded.dtype == np.uint8 and decoded.shape == image.shape
    assert (decoded == image).all()


def test_png_of_a_render_round_trips():
    image = _shot(scene=_scene(rocks=[(0.0, 8.0, 1.0)]))
    assert (decode_png(rendering.encode_png(image)) == image).all()


def _corrupt_crc(data: bytes) -> bytes:
    return data[:-5] + bytes([data[-5] ^ 0xFF]) + data[-4:]


def _png_with(header: bytes, rows: bytes) -> bytes:
    def chunk(kind: bytes, body: bytes) -> bytes:
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    return png.SIGNATURE + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


@pytest.mark.parametrize(("make", "message"), [
    (lambda good: b"garbage, not an image", "signature"),
    (lambda good: good[:40], "truncated"),
    (lambda good: _corrupt_crc(good), "CRC"),
    (lambda good: good + b"\x00\x00", "truncated"),
    (lambda good: _png_with(struct.pack(">IIBBBBB", 2, 1, 8, 6, 0, 0, 0), b"\x00" + bytes(8)), "colour type 6"),
    (lambda good: _png_with(struct.pack(">IIBBBBB", 2, 1, 8, 2, 0, 0, 0), b"\x01" + bytes(6)), "filter"),
    (lambda good: _png_with(struct.pack(">IIBBBBB", 2, 2, 8, 2, 0, 0, 0), b"\x00" + bytes(6)), "expected 14"),
])
def test_decode_png_rejects_anything_else(make, message):
    good = rendering.encode_png(np.zeros((2, 2, 3), np.uint8))
    with pytest.raises(ValueError, match=message):
        decode_png(make(good))


def test_encode_png_wants_rgb8():
    with pytest.raises(ValueError, match="uint8"):
        rendering.encode_png(np.zeros((2, 2, 3), float))
    with pytest.raises(ValueError, match="uint8"):
        rendering.encode_png(np.zeros((2, 2), np.uint8))
