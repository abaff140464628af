"""Tiled heightmap terrain: seamless lazy tiles, LRU and chunk activation, gradients, mesh import, GLB export."""

from __future__ import annotations

import io
import math
import time

import numpy as np
import pytest
import trimesh

from schemas.scenario import Crater, TerrainSpec
from world_service.terrain import heightmap as terrain_module
from world_service.terrain.export import export_glb
from world_service.terrain.heightmap import Heightmap
from world_service.terrain.landforms import crater_profile
from world_service.terrain.mesh import MeshSurface, load_vertices_faces

CRATERS = [Crater(x=30.0, z=40.0, radius_m=20.0), Crater(x=70.0, z=64.0, radius_m=10.0, rim_width=0.5)]
SMALL = TerrainSpec(origin=(0.0, 0.0), size_m=(130.0, 110.0), resolution_m=0.5, roughness_m=0.4)


def slope_deg(terrain: Heightmap, x, z) -> np.ndarray:
    """Steepest slope angle at the points, whatever the heading (what ``max_slope_deg`` is judged on)."""
    gx, gz = terrain.gradient(x, z)
    return np.degrees(np.arctan(np.hypot(gx, gz)))


def fit_spec(path, resolution_m: float = 1.0, **fields: object) -> TerrainSpec:
    """A TerrainSpec covering the mesh's ground footprint (a whole number of cells, so every node is on it)."""
    vertices, _ = load_vertices_faces(path)
    lo, hi = vertices[:, [0, 2]].min(axis=0), vertices[:, [0, 2]].max(axis=0)
    cells = np.maximum(np.floor((hi - lo) / resolution_m + 1e-9), 1)
    return TerrainSpec(origin=(float(lo[0]), float(lo[1])), size_m=tuple(float(c * resolution_m) for c in cells),
                       resolution_m=resolution_m, mesh=str(path), **fields)


def _build(spec: TerrainSpec, craters=CRATERS, seed: int = 3, **update) -> Heightmap:
    return Heightmap.build(spec.model_copy(update=update), craters, np.random.default_rng(seed))


class UntiledReference:
    """The generator before tiling (one float64 grid, np.gradient, edge-clamped bilinear), kept as the oracle."""

    def __init__(self, spec: TerrainSpec, craters: list[Crater], rng: np.random.Generator) -> None:
        nx = int(np.ceil(spec.size_m[0] / spec.resolution_m)) + 1
        nz = int(np.ceil(spec.size_m[1] / spec.resolution_m)) + 1
        gx, gz = np.meshgrid(spec.origin[0] + np.arange(nx) * spec.resolution_m,
                             spec.origin[1] + np.arange(nz) * spec.resolution_m)
        heights = np.zeros((nz, nx))
        if spec.roughness_m > 0:
            for _ in range(6):
                wavelength, angle = rng.uniform(20.0, 120.0), rng.uniform(0, 2 * np.pi)
                phase = rng.uniform(0, 2 * np.pi)
                wave = np.sin(2 * np.pi / wavelength * (gx * np.cos(angle) + gz * np.sin(angle)) + phase)
                heights += wave * (spec.roughness_m / 6)
        for crater in craters:
            r = np.hypot(gx - crater.x, gz - crater.z) / crater.radius_m
            near = r < 1.0 + crater.rim_width
            heights[near] += crater_profile(r[near], crater)
        self.spec, self.heights = spec, heights
        self.slope_z, self.slope_x = np.gradient(heights, spec.resolution_m)

    def sample(self, grid: np.ndarray, x, z) -> np.ndarray:
        res = self.spec.resolution_m
        fx = np.clip((np.asarray(x, float) - self.spec.origin[0]) / res, 0, grid.shape[1] - 1.000001)
        fz = np.clip((np.asarray(z, float) - self.spec.origin[1]) / res, 0, grid.shape[0] - 1.000001)
        ix, iz = fx.astype(int), fz.astype(int)
        tx, tz = fx - ix, fz - iz
        top = grid[iz, ix] * (1 - tx) + grid[iz, ix + 1] * tx
        bottom = grid[iz + 1, ix] * (1 - tx) + grid[iz + 1, ix + 1] * tx
        return top * (1 - tz) + bottom * tz

    def pitch_deg(self, x, z, heading_deg) -> np.ndarray:
        h = np.radians(heading_deg)
        along = self.sample(self.slope_x, x, z) * np.sin(h) + self.sample(self.slope_z, x, z) * np.cos(h)
        return np.degrees(np.arctan(along))


def _points(n: int = 20_000, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.uniform(-5.0, 140.0, n), rng.uniform(-5.0, 120.0, n)


# ---- tiles ----


def test_tiles_join_seamlessly_and_match_an_untiled_build():
    whole, tiled = _build(SMALL, tile_size_m=500.0), _build(SMALL, tile_size_m=16.0)
    assert (whole.tiles_x, whole.tiles_z) == (1, 1) and (tiled.tiles_x, tiled.tiles_z) == (9, 7)
    edges = 16.0 * np.arange(1, 9)
    z = np.linspace(0.0, 110.0, 37)
    for eps in (1e-4, 0.1, 0.25):
        left, right = tiled.height(edges[:, None] - eps, z[None, :]), tiled.height(edges[:, None] + eps, z[None, :])
        assert np.allclose(left, whole.height(edges[:, None] - eps, z[None, :]), atol=1e-4)
        assert np.allclose(right, whole.height(edges[:, None] + eps, z[None, :]), atol=1e-4)
    gap = tiled.height(edges[:, None] + 1e-6, z[None, :]) - tiled.height(edges[:, None] - 1e-6, z[None, :])
    assert np.abs(gap).max() < 1e-4  # continuous across every x edge
    x, zz = _points()
    assert np.allclose(tiled.height(x, zz), whole.height(x, zz), atol=1e-4)
    for a, b in zip(tiled.gradient(x, zz), whole.gradient(x, zz), strict=True):
        assert np.allclose(a, b, atol=1e-4)  # the halo makes edge gradients central differences too
    assert np.array_equal(tiled.heights, whole.heights) and np.array_equal(tiled.slope_z, whole.slope_z)


@pytest.mark.parametrize("centre", [(65.0, 55.0), (3.0, 108.0), (-20.0, 130.0)])  # inside, a corner, outside
def test_a_block_around_a_point_samples_the_tiles_heights_within_its_reach(centre):
    """The camera marches in such a block (compiled): it must read exactly what the tiles give, to the bit."""
    tiled = _build(SMALL, tile_size_m=16.0)
    grid = tiled.grid_around(*centre, 30.0)
    assert grid.heights.shape[0] < tiled.nz and grid.ceiling == tiled.max_height_bound()
    rng = np.random.default_rng(5)
    angle, r = rng.uniform(0, 2 * np.pi, 20_000), 30.0 * np.sqrt(rng.uniform(0, 1, 20_000))
    x, z = centre[0] + r * np.sin(angle), centre[1] + r * np.cos(angle)
    assert np.array_equal(grid.height(x, z), tiled.height(x, z))
    assert grid.height(*centre) == tiled.height(*centre)  # a scalar in, a scalar out


def test_the_compiled_march_finds_the_ground_where_its_steps_cross_it():
    flat = _build(TerrainSpec(origin=(0.0, 0.0), size_m=(100.0, 100.0), resolution_m=1.0), craters=[])
    grid = flat.grid_around(50.0, 50.0, 40.0)
    down = np.array([[0.0, -math.sin(a), math.cos(a)] for a in np.radians([90.0, 30.0, 5.0, 0.0, -10.0])])
    t = grid.march(np.array([50.0, 1.0, 50.0]), down, 40.0, 0.2, 0.2, 0.03)
    expected = 1.0 / np.sin(np.radians([90.0, 30.0, 5.0]))  # flat ground: a linear crossing is exact
    assert np.allclose(t[:3], expected) and np.isinf(t[3:]).all()  # level and rising rays never meet it


def test_the_compiled_surface_is_the_march_with_numpy_central_difference_normals_to_the_bit():
    """The camera shades what ``surface`` returns: the march's distances, and normals as NumPy computes them."""
    tiled = _build(SMALL, tile_size_m=16.0)
    grid = tiled.grid_around(60.0, 50.0, 40.0)
    origin = np.array([60.0, float(tiled.height(60.0, 50.0)) + 0.3, 50.0])
    rng = np.random.default_rng(3)
    dirs = rng.normal(size=(4000, 3)) * [1.0, 0.2, 1.0]
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    t, normal = grid.surface(origin, dirs, 40.0, 0.2, 0.2, 0.03, 0.25)
    assert np.array_equal(t, grid.march(origin, dirs, 40.0, 0.2, 0.2, 0.03))
    hit = np.isfinite(t)
    assert 0 < hit.sum() < len(t) and not normal[~hit].any()
    points = origin + t[hit, None] * dirs[hit]
    px, pz, e = points[:, 0], points[:, 2], 0.25
    slope_x = (grid.height(px + e, pz) - grid.height(px - e, pz)) / (2 * e)
    slope_z = (grid.height(px, pz + e) - grid.height(px, pz - e)) / (2 * e)
    n = np.stack([-slope_x, np.ones_like(slope_x), -slope_z], axis=1)
    assert np.array_equal(normal[hit], n / np.linalg.norm(n, axis=1, keepdims=True))


def test_tiled_terrain_is_the_untiled_generator_and_draws_the_same_randoms():
    rng = np.random.default_rng(11)
    ref = UntiledReference(SMALL, CRATERS, np.random.default_rng(11))
    tiled = Heightmap.build(SMALL.model_copy(update={"tile_size_m": 20.0}), CRATERS, rng)
    x, z = _points()
    heading = np.random.default_rng(1).uniform(0, 360, x.size)
    assert np.allclose(tiled.height(x, z), ref.sample(ref.heights, x, z), atol=1e-4)
    assert np.allclose(tiled.pitch_deg(x, z, heading), ref.pitch_deg(x, z, heading), atol=1e-3)
    assert rng.uniform() == np.random.default_rng(11).uniform(size=19)[-1]  # 18 draws, as before: the world's rng


def test_crater_profile_and_pitch_signs_on_a_tiled_crater():
    crater = Crater(x=0.0, z=0.0, radius_m=20.0)  # depth 4, rim 0.8; the centre sits on a four-tile corner
    terrain = Heightmap.build(TerrainSpec(origin=(-60.0, -60.0), size_m=(120.0, 120.0), resolution_m=0.5,
                                          tile_size_m=30.0), [crater], np.random.default_rng(0))
    assert terrain.height(0.0, 0.0) == pytest.approx(0.8 - 4.0)
    assert terrain.height(0.0, -20.0) == pytest.approx(0.8)
    assert terrain.height(-50.0, 50.0) == 0.0
    for angle in np.radians([0.0, 37.0, 90.0, 200.0, 300.0]):
        toward = math.degrees(math.atan2(-math.sin(angle), -math.cos(angle)))  # heading from the rim to the centre
        outside = float(terrain.pitch_deg(23.0 * math.sin(angle), 23.0 * math.cos(angle), toward))
        inside = float(terrain.pitch_deg(19.0 * math.sin(angle), 19.0 * math.cos(angle), toward))
        assert outside == pytest.approx(math.degrees(math.atan(0.4 * math.pi / 6)), abs=0.5)
        assert inside == pytest.approx(-math.degrees(math.atan(0.38)), abs=0.5)
    assert float(slope_deg(terrain, 0.0, -23.0)) == pytest.approx(math.degrees(math.atan(0.4 * math.pi / 6)), abs=0.5)


def test_sampling_keeps_the_shape_and_a_scalar_stays_a_scalar():
    terrain = _build(SMALL, tile_size_m=16.0)
    assert np.ndim(terrain.height(3.0, 4.0)) == 0 and isinstance(float(terrain.pitch_deg(3.0, 4.0, 90.0)), float)
    grid = terrain.height(np.linspace(0, 120, 7)[None, :], np.linspace(0, 100, 5)[:, None])
    assert grid.shape == (5, 7)
    assert terrain.pitch_deg([1.0, 50.0], [2.0, 60.0], 45.0).shape == (2,)
    edge = terrain.height([-100.0, 1000.0], [-100.0, 1000.0])  # clamped to the corners
    assert edge == pytest.approx([terrain.height(0.0, 0.0), terrain.height(130.0, 110.0)])


def test_a_few_points_sample_in_python_to_the_bit_of_the_batched_path(monkeypatch):
    """Lockstep missions must not change with the number of rovers a tick samples: same bits, same tile order."""
    few, batched = _build(SMALL, tile_size_m=16.0, max_tiles_in_memory=5), _build(SMALL, tile_size_m=16.0,
                                                                                   max_tiles_in_memory=5)
    rng = np.random.default_rng(4)
    for n in [1, 2, 5, terrain_module.FEW_POINTS]:
        for _ in range(40):
            x, z = rng.uniform(-10.0, 145.0, n), rng.uniform(-10.0, 125.0, n)  # some clamped at the edges
            heading = rng.uniform(0.0, 360.0, n)
            ours = few.pitch_deg(x, z, heading), few.height(x, z)
            with monkeypatch.context() as patch:
                patch.setattr(terrain_module, "FEW_POINTS", 0)
                theirs = batched.pitch_deg(x, z, heading), batched.height(x, z)
            assert all(np.array_equal(a, b) for a, b in zip(ours, theirs, strict=True))
            assert few.loaded_tiles == batched.loaded_tiles
    assert few.tiles_evicted == batched.tiles_evicted > 0


def test_lru_evicts_beyond_the_cap():
    terrain = _build(SMALL, tile_size_m=16.0, max_tiles_in_memory=4)
    assert terrain.loaded_tiles == []  # nothing generated until sampled
    centres = [(8.0 + 16.0 * i, 8.0) for i in range(6)]
    for x, z in centres:
        terrain.height(x, z)
    assert terrain.loaded_tiles == [(0, 2), (0, 3), (0, 4), (0, 5)]
    assert terrain.tiles_evicted == 2 and terrain.tiles_generated == 6
    terrain.height(*centres[2])  # touching a tile makes it the most recent
    terrain.height(8.0, 40.0)
    assert terrain.loaded_tiles == [(0, 4), (0, 5), (0, 2), (2, 0)]
    terrain.height(*np.array(centres).T)  # one batch over six tiles still answers every point
    assert len(terrain.loaded_tiles) == 4


def test_keep_near_loads_what_is_near_and_drops_what_is_far():
    terrain = _build(SMALL, tile_size_m=16.0, max_tiles_in_memory=20)
    near = terrain.keep_near(np.array([[8.0, 8.0]]), 5.0)
    assert near == {(0, 0)} and terrain.loaded_tiles == [(0, 0)]
    near = terrain.keep_near(np.array([[32.0, 32.0], [120.0, 100.0]]), 1.0)  # a tile corner, a far rover
    assert near == {(1, 1), (1, 2), (2, 1), (2, 2), (6, 7)} and set(terrain.loaded_tiles) == near
    generated = terrain.tiles_generated
    terrain.height(33.0, 33.0)
    assert terrain.tiles_generated == generated  # sampling where the rovers are needs no new tile


def test_keep_near_beyond_the_cap_keeps_the_nearest():
    terrain = _build(SMALL, tile_size_m=16.0, max_tiles_in_memory=3)
    near = terrain.keep_near(np.array([[40.0, 40.0]]), 30.0)
    assert len(near) > 3 and len(terrain.loaded_tiles) == 3
    assert (2, 2) in terrain.loaded_tiles  # the tile the rover stands on


def test_fifty_square_kilometres_construct_lazily():
    spec = TerrainSpec(origin=(0.0, 0.0), size_m=(7071.0, 7071.0), resolution_m=0.5, roughness_m=0.3)
    centres = np.random.default_rng(2).uniform(0, 7071, (200, 2))
    craters = [Crater(x=float(x), z=float(z), radius_m=50.0) for x, z in centres]
    start = time.perf_counter()
    terrain = Heightmap.build(spec, craters, np.random.default_rng(0))
    assert time.perf_counter() - start < 0.5
    assert terrain.loaded_tiles == [] and terrain.tiles_x == terrain.tiles_z == 28
    assert terrain.full_grid_bytes() > 2e9  # what an untiled float32 grid would hold
    terrain.height([10.0, 12.0, 3000.0, 7000.0], [10.0, 15.0, 5000.0, 7071.0])
    assert len(terrain.loaded_tiles) == 3 and terrain.tile_bytes < 12e6
    with pytest.raises(MemoryError):
        _ = terrain.heights


# ---- gradients and mesh import ----


def _plane_mesh(angle_deg: float, size: float = 100.0) -> trimesh.Trimesh:
    """A plane rising along +z at ``angle_deg``, two triangles over [0, size]²."""
    rise = size * math.tan(math.radians(angle_deg))
    vertices = np.array([[0.0, 0.0, 0.0], [size, 0.0, 0.0], [0.0, rise, size], [size, rise, size]])
    return trimesh.Trimesh(vertices, [[0, 2, 1], [1, 2, 3]], process=False)


@pytest.mark.parametrize("angle", [5.0, 17.0, 30.0])
def test_gradient_and_slope_on_an_imported_tilted_plane(tmp_path, angle):
    path = tmp_path / "plane.stl"
    _plane_mesh(angle).export(path)
    terrain = Heightmap.build(fit_spec(path, resolution_m=0.5, tile_size_m=32.0), [], np.random.default_rng(0))
    x, z = _points(2000, seed=4)
    x, z = np.clip(x, 0, 100), np.clip(z, 0, 100)
    gx, gz = terrain.gradient(x, z)
    assert np.allclose(gx, 0.0, atol=1e-5) and np.allclose(gz, math.tan(math.radians(angle)), rtol=1e-5)
    assert np.allclose(slope_deg(terrain, x, z), angle, atol=1e-3)
    assert np.allclose(terrain.pitch_deg(x, z, 0.0), angle, atol=1e-3)  # facing uphill (+z)
    assert np.allclose(terrain.pitch_deg(x, z, 90.0), 0.0, atol=1e-3)  # across the slope
    assert np.allclose(terrain.height(x, z), z * math.tan(math.radians(angle)), atol=1e-4)


def _pyramid(half: float = 20.0, peak: float = 6.0) -> trimesh.Trimesh:
    """Square pyramid centred on (0, 0): height peak * (1 - max(|x|, |z|) / half)."""
    corners = [[-half, 0.0, -half], [half, 0.0, -half], [half, 0.0, half], [-half, 0.0, half]]
    vertices = np.array([*corners, [0.0, peak, 0.0]])
    return trimesh.Trimesh(vertices, [[0, 4, 1], [1, 4, 2], [2, 4, 3], [3, 4, 0]], process=False)


@pytest.mark.parametrize("suffix", ["obj", "stl", "ply", "glb"])
def test_mesh_formats_import_to_the_mesh_heights(tmp_path, suffix):
    path = tmp_path / f"pyramid.{suffix}"
    _pyramid().export(path)
    spec = TerrainSpec(origin=(-30.0, -30.0), size_m=(80.0, 80.0), resolution_m=0.25, tile_size_m=8.0,
                       mesh=str(path), mesh_scale=(2.0, 0.5, 2.0), mesh_offset=(10.0, 1.0, 5.0))
    terrain = Heightmap.build(spec, [], np.random.default_rng(0))  # a pyramid 80 m wide, 3 m high, on y = 1
    x, z = np.random.default_rng(5).uniform(-30.0, 50.0, (2, 5000))
    expected = 1.0 + 3.0 * np.clip(1 - np.maximum(np.abs(x - 10.0), np.abs(z - 5.0)) / 40.0, 0.0, None)
    interior = np.maximum(np.abs(x - 10.0), np.abs(z - 5.0)) < 39.0
    # bilinear between nodes on the ridge lines is not exactly the pyramid, so allow a quarter-cell of slope
    assert np.allclose(terrain.height(x[interior], z[interior]), expected[interior], atol=3.0 / 40.0 * 0.25)
    nodes = np.arange(-30.0, 50.0, 0.25)
    on_nodes = terrain.height(nodes[None, :], nodes[:, None])
    truth = 1.0 + 3.0 * np.clip(1 - np.maximum(np.abs(nodes[None, :] - 10.0), np.abs(nodes[:, None] - 5.0)) / 40.0,
                                0.0, None)
    assert np.allclose(on_nodes, truth, atol=1e-5)  # exact on grid nodes; off the mesh: its lowest height


def test_mesh_takes_the_highest_surface_and_resolves_relative_to_base_dir(tmp_path):
    low = trimesh.creation.box(extents=(20.0, 1.0, 20.0))  # top face at y = 0.5
    high = trimesh.Trimesh([[-5, 3, -5], [5, 3, -5], [5, 3, 5], [-5, 3, 5]], [[0, 2, 1], [0, 3, 2]])
    trimesh.util.concatenate([low, high]).export(tmp_path / "stack.ply")
    spec = TerrainSpec(origin=(-10.0, -10.0), size_m=(20.0, 20.0), resolution_m=0.5, mesh="stack.ply")
    terrain = Heightmap.build(spec, [], np.random.default_rng(0), base_dir=tmp_path)
    assert terrain.height([0.0, 4.9, -8.0], [0.0, -4.9, 8.0]) == pytest.approx([3.0, 3.0, 0.5])


def test_mesh_surface_bins_and_batches_agree_with_one_pass():
    rng = np.random.default_rng(8)
    grid = np.stack(np.meshgrid(np.linspace(0, 50, 26), np.linspace(0, 50, 26)), -1).reshape(-1, 2)
    vertices = np.column_stack([grid[:, 0], rng.uniform(0, 2, len(grid)), grid[:, 1]])
    a = (np.arange(25)[:, None] * 26 + np.arange(25)[None, :]).ravel()
    faces = np.concatenate([np.column_stack([a, a + 26, a + 1]), np.column_stack([a + 1, a + 26, a + 27])])
    coarse, fine = MeshSurface(vertices, faces, bin_size_m=1000.0), MeshSurface(vertices, faces, bin_size_m=3.0)
    block = coarse.block(0.0, 0.0, 0.5, 101, 101)
    assert np.array_equal(block, fine.block(0.0, 0.0, 0.5, 101, 101))
    assert np.allclose(block[::4, ::4], vertices[:, 1].reshape(26, 26))  # vertices land on nodes


# ---- export ----


def test_export_glb_round_trips_to_the_terrain_heights(tmp_path):
    terrain = _build(SMALL, tile_size_m=16.0)
    path = tmp_path / "terrain.glb"
    written = export_glb(terrain, path, step=3)
    assert terrain.loaded_tiles == []  # exporting leaves the rovers' tiles alone
    loaded = trimesh.load(path, force="mesh")
    v = np.asarray(loaded.vertices)
    assert len(v) == len(written.vertices) == 88 * 75
    assert np.allclose(v[:, 1], terrain.height(v[:, 0], v[:, 2]), atol=1e-4)
    assert v[:, 0].min() == 0.0 and v[:, 0].max() == 130.0 and v[:, 2].max() == 110.0  # edges kept
    assert (np.asarray(loaded.face_normals)[:, 1] > 0).all()  # faces up, y up


def test_export_glb_bounds_loaded_and_automatic_step():
    terrain = _build(SMALL, tile_size_m=16.0)
    terrain.keep_near(np.array([[20.0, 20.0]]), 1.0)
    buf = io.BytesIO()
    mesh = export_glb(terrain, buf, bounds="loaded")
    v = np.asarray(mesh.vertices)
    assert (v[:, 0].min(), v[:, 2].min(), v[:, 0].max(), v[:, 2].max()) == (16.0, 16.0, 32.0, 32.0)
    assert len(v) == 33 * 33 and buf.getvalue()[:4] == b"glTF"
    small = export_glb(terrain, io.BytesIO(), bounds=(0.0, 0.0, 130.0, 110.0), max_vertices=1000)
    assert len(small.vertices) <= 1000 * 1.2
