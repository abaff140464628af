"""Pure world functions with known geometry: rays, scans, navigation, terrain pitch, radio graph, the World."""

from __future__ import annotations

import math

import msgpack
import numpy as np
import pytest
from test_camera import decode_png

from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.frames import wrap_deg
from schemas.params import BehaviourParams, NavigationParams
from schemas.scenario import Crater, TerrainSpec, parse_scenario
from world_service import geometry as geo
from world_service.actuation import navigation as nav
from world_service.radio.graph import build_graph
from world_service.scene import FEW_PAIRS, KIND_CODE, CircleGrid, Scene, circle_pairs
from world_service.sensors import perception
from world_service.sensors.perception import Perceiver
from world_service.sim import World
from world_service.terrain.heightmap import Heightmap

INF = np.inf

# ---- geometry ----


def test_direction_follows_the_heading_convention():
    dx, dz = geo.direction(np.array([0.0, 90.0, 180.0, 270.0]))
    assert np.allclose(dx, [0, 1, 0, -1]) and np.allclose(dz, [1, 0, -1, 0])


def ray_circles(ox, oz, dx, dz, cx, cz, r) -> np.ndarray:
    """Distance along unit rays to where each enters each circle (every ray against every circle)."""
    ox, oz, dx, dz = (np.asarray(a, float)[..., None] for a in (ox, oz, dx, dz))
    return geo.ray_circle(ox, oz, dx, dz, cx, cz, r)


def test_ray_circles_known_distances():
    # two rays from the origin, +z and +x, against a circle ahead and one to the right
    t = ray_circles([0.0, 0.0], [0.0, 0.0], [0.0, 1.0], [1.0, 0.0], [0.0, 5.0], [5.0, 0.0], [1.0, 2.0])
    assert t.shape == (2, 2)
    assert np.allclose(t, [[4.0, INF], [INF, 3.0]])


@pytest.mark.parametrize(("cx", "cz", "r", "expected"), [
    (0.0, 5.0, 1.0, 4.0),  # straight ahead
    (3.0, 4.0, 1.0, INF),  # off the ray by 3 with radius 1: miss ...
    (1.0, 5.0, 1.0, 5.0),  # ... tangent: grazes at its nearest point
    (0.0, -5.0, 1.0, INF),  # behind
    (0.0, 0.5, 1.0, INF),  # the ray starts inside
    (0.6, 4.0, 1.0, 4.0 - 0.8),  # chord: enters at z = 4 - sqrt(1 - 0.36)
])
def test_ray_circles_cases(cx, cz, r, expected):
    t = ray_circles(0.0, 0.0, 0.0, 1.0, [cx], [cz], [r])
    assert t.shape == (1,)
    assert np.allclose(t, [expected])


def test_ray_circles_from_an_offset_origin_along_a_diagonal():
    d = math.sqrt(0.5)
    t = ray_circles(10.0, 10.0, d, d, [13.0], [14.0], [1.0])
    # the centre is (3, 4) from the origin: 7 / sqrt2 along the (1, 1) / sqrt2 ray and 1 / sqrt2 beside it
    along = 7.0 / math.sqrt(2)
    assert np.allclose(t, [along - math.sqrt(1.0 - 0.5)])


@pytest.mark.parametrize(("seg", "expected"), [
    ((-1.0, 3.0, 1.0, 3.0), 3.0),  # across the ray
    ((0.0, 3.0, 2.0, 3.0), 3.0),  # the ray meets an end point
    ((2.0, 3.0, 4.0, 3.0), INF),  # beside the ray
    ((-1.0, -3.0, 1.0, -3.0), INF),  # behind
    ((0.0, 1.0, 0.0, 5.0), INF),  # parallel, along the ray itself
    ((-2.0, 2.0, 2.0, 6.0), 4.0),  # diagonal, crosses at (0, 4)
])
def test_ray_segments_cases(seg, expected):
    ax, az, bx, bz = seg
    t = geo.ray_segments(0.0, 0.0, 0.0, 1.0, [ax], [az], [bx], [bz])
    assert np.allclose(t, [expected])


def test_ray_segments_broadcast_shape():
    t = geo.ray_segments([0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, -1.0], [1.0, 0.0, 0.0],
                         [-1.0, 2.0], [3.0, -1.0], [1.0, 2.0], [3.0, 1.0])
    assert t.shape == (3, 2)
    assert np.allclose(t, [[3.0, INF], [INF, 2.0], [INF, INF]])


def test_point_segment_distance():
    d = geo.point_segment_distance([0.0, 2.0, -4.0, 0.0], [1.0, 1.0, 0.0, 0.0], [-1.0, 3.0], [0.0, 4.0],
                                   [1.0, 3.0], [0.0, 4.0])
    assert d.shape == (4, 2)
    expected = [
        [1.0, math.hypot(3, 3)],  # above the middle of the first; to the (degenerate) point (3, 4)
        [math.hypot(1, 1), math.hypot(1, 3)],  # beyond the end (1, 0)
        [3.0, math.hypot(7, 4)],  # beyond the start (-1, 0)
        [0.0, 5.0],  # on the segment
    ]
    assert np.allclose(d, expected)


def test_segment_segment_distance():
    d = geo.segment_segment_distance(0.0, 0.0, 0.0, 10.0, np.array([-1.0, 2.0, 3.0]), np.array([5.0, 0.0, 12.0]),
                                     np.array([1.0, 2.0, 4.0]), np.array([5.0, 10.0, 14.0]))
    assert np.allclose(d, [0.0, 2.0, math.hypot(3, 2)])


@pytest.mark.parametrize("points, circles", [(3, 5), (1, 20), (40, 200)])
def test_circle_pairs_are_every_circle_in_reach_with_or_without_a_grid(points, circles):
    """Few pairs are tested all at once, many through a grid (the last case is above ``FEW_PAIRS``): the same
    pairs either way, for static circles (rocks) and moving ones (rovers)."""
    rng = np.random.default_rng(points)
    cx, cz, cr = rng.uniform(-10, 10, circles), rng.uniform(-10, 10, circles), rng.uniform(0.1, 2.0, circles)
    px, pz = rng.uniform(-10, 10, points), rng.uniform(-10, 10, points)
    expected = {(i, j) for i in range(points) for j in range(circles)
                if math.hypot(cx[j] - px[i], cz[j] - pz[i]) <= 6.0 + cr[j]}
    for found in (circle_pairs(px, pz, cx, cz, cr, 6.0, 8.0), CircleGrid(cx, cz, cr, 8.0).pairs(px, pz, 6.0)):
        assert set(zip(*(a.tolist() for a in found), strict=True)) == expected
    assert expected, "some circles are in reach"
    assert (points * circles > FEW_PAIRS) == (points == 40)


def test_the_grid_finds_a_wide_circle_whose_centre_is_beyond_the_cells_in_reach():
    """Reach 6 from x = 9.9 looks in cells -1 to 1 of 10 m (x < 20), but a 5 m rock centred at 20.5 reaches to 15.5."""
    cx, cz, cr = np.concatenate([[20.5], np.full(5000, 500.0)]), np.zeros(5001), np.ones(5001)
    cr[0] = 5.0
    point, circle = CircleGrid(cx, cz, cr, 10.0).pairs(np.array([9.9]), np.array([0.0]), 6.0)
    assert circle.tolist() == [0] and point.tolist() == [0]


def test_wall_edges_of_one_piece_is_a_rectangle_around_it():
    e = geo.wall_edges([(0.0, 0.0), (10.0, 0.0)], thickness=2.0)
    assert e.shape == (4, 4)
    corners = {(round(x, 9), round(z, 9)) for x, z in e[:, :2]} | {(round(x, 9), round(z, 9)) for x, z in e[:, 2:]}
    assert corners == {(-1.0, 1.0), (11.0, 1.0), (11.0, -1.0), (-1.0, -1.0)}
    # each edge ends where the next starts: a closed outline
    assert np.allclose(e[:, 2:], np.roll(e[:, :2], -1, axis=0))


def test_wall_edges_of_a_polyline_skips_repeated_points():
    e = geo.wall_edges([(0.0, 0.0), (0.0, 5.0), (0.0, 5.0), (5.0, 5.0)], thickness=1.0)
    assert e.shape == (8, 4)
    assert geo.wall_edges([(1.0, 1.0), (1.0, 1.0)], 1.0).shape == (0, 4)
    # a vertical piece 1 m thick: its long sides are at x = +-0.5
    xs = sorted({round(v, 9) for v in e[:4, [0, 2]].ravel()})
    assert xs == [-0.5, 0.5]


# ---- scene: perception ----


def _scenario(rovers=((0.0, 0.0, 0.0),), rocks=(), craters=(), walls=(), **params):
    rover_params = {"perception": {"perception_granularity": 71}}  # rays every 3 deg, one straight ahead
    for section, values in params.items():
        rover_params.setdefault(section, {}).update(values)
    return parse_scenario({
        "name": "unit",
        "lander": {"x": -200.0, "z": -200.0},
        "rovers": [{"x": x, "z": z, "heading_deg": h} for x, z, h in rovers],
        "craters": [{"x": x, "z": z, "radius_m": r} for x, z, r in craters],
        "obstacles": {"rocks": [{"x": x, "z": z, "radius_m": r} for x, z, r in rocks],
                      "walls": [{"points": list(w), "thickness_m": 1.0} for w in walls]},
        "mission": [{"x": 0.0, "z": 300.0}],
        "rover_params": rover_params,
    })


def _scan(scenario, index=0):
    xs = np.array([r.x for r in scenario.rovers])
    zs = np.array([r.z for r in scenario.rovers])
    hs = np.array([r.heading_deg for r in scenario.rovers])
    terrain = Heightmap.from_scenario(scenario, np.random.default_rng(0))
    perceiver = Perceiver(Scene.from_scenario(scenario), terrain, scenario.rover_params)
    scan = perceiver.scan(xs, zs, hs, np.array([index]))[0]
    return list(zip(scan.angles_deg.tolist(), scan.distances_m.tolist(), [m.HIT_KINDS[k] for k in scan.kinds],
                    strict=True))


def test_scan_of_empty_ground_sees_nothing():
    assert _scan(_scenario()) == []


def test_rock_straight_ahead_is_seen_at_angle_zero_at_its_surface():
    hits = _scan(_scenario(rocks=[(0.0, 5.0, 0.5)]))
    angle, dist, kind = min(hits, key=lambda h: abs(h[0]))
    assert angle == pytest.approx(0.0, abs=1e-9)
    assert dist == pytest.approx(4.5)
    assert kind == "obstacle"
    assert {h[2] for h in hits} == {"obstacle"}
    assert [a for a, _, _ in hits] == pytest.approx([-3.0, 0.0, 3.0])  # only the rays that meet the rock
    assert min(d for _, d, _ in hits) == pytest.approx(4.5)


@pytest.mark.parametrize(("heading", "rock", "angle"), [
    (90.0, (5.0, 0.0), 0.0),  # facing +x, rock on +x: ahead
    (0.0, (5.0, 0.0), 90.0),  # facing +z, rock on +x: to the right, positive
    (0.0, (-5.0, 0.0), -90.0),  # to the left, negative
    (180.0, (0.0, -5.0), 0.0),
])
def test_scan_angles_are_relative_to_the_heading(heading, rock, angle):
    hits = _scan(_scenario(rovers=[(0.0, 0.0, heading)], rocks=[(*rock, 0.5)]))
    nearest = min(hits, key=lambda h: h[1])
    assert nearest[0] == pytest.approx(angle, abs=1e-9)
    assert nearest[1] == pytest.approx(4.5)


def test_scan_stops_at_the_perception_radius_and_field_of_view():
    assert _scan(_scenario(rocks=[(0.0, 11.0, 0.5)])) == []  # surface at 10.5 m, radius 10
    assert _scan(_scenario(rocks=[(0.0, -5.0, 0.5)])) == []  # behind, outside 210 deg
    assert _scan(_scenario(rocks=[(0.0, 10.4, 0.5)]))[0][1] == pytest.approx(9.9)


def test_rover_ahead_is_seen_and_one_behind_a_rock_is_hidden():
    open_ground = _scan(_scenario(rovers=[(0.0, 0.0, 0.0), (0.0, 8.0, 180.0)]))
    assert {h[2] for h in open_ground} == {"rover"}
    assert min(open_ground, key=lambda h: abs(h[0]))[1] == pytest.approx(7.5)
    hidden = _scan(_scenario(rovers=[(0.0, 0.0, 0.0), (0.0, 8.0, 180.0)], rocks=[(0.0, 5.0, 1.0)]))
    assert hidden and "rover" not in {h[2] for h in hidden}
    assert min(d for _, d, _ in hidden) == pytest.approx(4.0)


def test_wall_ahead_is_seen_as_obstacle_at_its_face():
    hits = _scan(_scenario(walls=[[(-3.0, 6.0), (3.0, 6.0)]]))  # 1 m thick: near face at z = 5.5
    ahead = min(hits, key=lambda h: abs(h[0]))
    assert ahead[2] == "obstacle"
    assert ahead[0] == pytest.approx(0.0, abs=1e-9) and ahead[1] == pytest.approx(5.5)


def test_crater_terrain_is_seen_where_the_ray_enters_the_outer_rim():
    # crater centre 20 m ahead, radius 10, rim width 0.3: outer circle of radius 13 entered at 7 m
    hits = _scan(_scenario(craters=[(0.0, 20.0, 10.0)]))
    assert {h[2] for h in hits} == {"crater_terrain"}
    ahead = min(hits, key=lambda h: abs(h[0]))
    assert ahead[0] == pytest.approx(0.0, abs=1e-9) and ahead[1] == pytest.approx(7.0)


@pytest.mark.parametrize(("rover_z", "distance"), [
    (7.3, 6.8),  # centre just inside the outer circle (12.7 m from the crater centre), nearer than the rim entry
    (9.5, 9.0),  # well inside: crater terrain is walkable ground, not a screen
])
def test_crater_terrain_does_not_hide_a_rover(rover_z, distance):
    hits = _scan(_scenario(rovers=[(0.0, 0.0, 0.0), (0.0, rover_z, 0.0)], craters=[(0.0, 20.0, 10.0)]))
    ahead = min(hits, key=lambda h: abs(h[0]))
    assert ahead[2] == "rover"
    assert ahead[1] == pytest.approx(distance)
    assert "crater_terrain" in {h[2] for h in hits}  # rays beside the rover still see the rim


def test_a_rock_and_a_rover_met_at_the_same_distance_are_seen_as_the_rock():
    radius = BehaviourParams().rover_radius
    hits = _scan(_scenario(rovers=[(0.0, 0.0, 0.0), (0.0, 8.0, 0.0)], rocks=[(0.0, 8.0, radius)]))
    assert {h[2] for h in hits} == {"obstacle"}


def test_rovers_scanned_together_see_what_each_sees_alone(monkeypatch):
    scenario = _scenario(rovers=[(0.0, 0.0, 0.0), (3.0, 4.0, 90.0), (-2.0, 6.0, 200.0), (30.0, 0.0, 0.0)],
                         rocks=[(1.0, 5.0, 0.6), (-4.0, 3.0, 1.0), (5.0, 6.0, 0.8)], craters=[(0.0, 22.0, 10.0)],
                         walls=[[(-6.0, -2.0), (-6.0, 9.0)]])
    xs, zs, hs = (np.array([getattr(r, a) for r in scenario.rovers]) for a in ("x", "z", "heading_deg"))
    terrain = Heightmap.from_scenario(scenario, np.random.default_rng(0))
    perceiver = Perceiver(Scene.from_scenario(scenario), terrain, scenario.rover_params)
    together = perceiver.scan(xs, zs, hs, np.arange(4))
    for i, scan in enumerate(together):
        alone = perceiver.scan(xs, zs, hs, np.array([i]))[0]
        for field in ("angles_deg", "distances_m", "kinds"):
            assert np.array_equal(getattr(scan, field), getattr(alone, field))
    assert {k for s in together[:3] for k in s.kinds} >= {KIND_CODE[k] for k in ("rover", "obstacle")}
    assert KIND_CODE["crater_terrain"] in together[0].kinds
    monkeypatch.setattr(perception, "FEW_PAIRS", 0)  # the rocks through their grid, as in a wide rock field
    for scan, gridded in zip(together, perceiver.scan(xs, zs, hs, np.arange(4)), strict=True):
        for field in ("angles_deg", "distances_m", "kinds"):
            assert np.array_equal(getattr(scan, field), getattr(gridded, field))


# ---- navigation kinematics ----

NAV = NavigationParams()


def _run(body, dt=0.05, limit=2000):
    for _ in range(limit):
        ended = nav.step(body, dt, NAV)
        if ended:
            return ended
    raise AssertionError("the action never ended")


@pytest.mark.parametrize(("start", "goal_world", "bearing"), [
    ((0.0, 0.0, 0.0), (3.0, 4.0), math.degrees(math.atan2(3, 4))),
    ((10.0, -5.0, 90.0), (14.0, -8.0), math.degrees(math.atan2(4, -3))),  # +z of the rover is world +x
    ((1.0, 1.0, 200.0), (1.0 - 4.0 * math.sin(math.radians(20)) - 3.0 * math.cos(math.radians(20)),
                         1.0 - 4.0 * math.cos(math.radians(20)) + 3.0 * math.sin(math.radians(20))), None),
])
def test_move_relative_ends_exactly_on_the_goal_facing_along_the_move(start, goal_world, bearing):
    body = nav.RoverBody(1, *start)
    body.start_move(3.0, 4.0)
    assert body.busy and body.remaining() == pytest.approx(5.0)
    ended = _run(body)
    assert (ended.action, ended.outcome, ended.start) == ("move", "completed", start)
    assert (body.x, body.z) == pytest.approx(goal_world, abs=1e-12)
    expected = start[2] + math.degrees(math.atan2(3, 4)) if bearing is None else bearing
    assert wrap_deg(body.heading - expected) == pytest.approx(0.0, abs=1e-6)
    assert body.distance_covered == pytest.approx(5.0)
    assert not body.busy and body.velocity == 0.0 and body.remaining() == 0.0


@pytest.mark.parametrize("degrees", [-90.0, 90.0, 30.0, -400.0])
def test_rotate_changes_the_heading_by_its_angle(degrees):
    body = nav.RoverBody(1, 2.0, 3.0, 30.0)
    body.start_rotate(degrees)
    assert body.remaining() == abs(degrees)
    ended = _run(body)
    assert (ended.action, ended.outcome) == ("rotate", "completed")
    assert wrap_deg(body.heading - (30.0 + degrees)) == pytest.approx(0.0, abs=1e-6)
    assert (body.x, body.z) == (2.0, 3.0) and body.distance_covered == 0.0


def test_rotate_speed_is_in_place_rotation_speed():
    body = nav.RoverBody(1, 0.0, 0.0, 0.0)
    body.start_rotate(-90.0)
    nav.step(body, 0.1, NAV)
    assert body.heading == pytest.approx(360.0 - math.degrees(2.0) * 0.1)


def test_cancel_mid_move_decelerates_and_reports_where_it_stopped():
    body = nav.RoverBody(1, 5.0, 5.0, 90.0)
    body.start_move(0.0, 10.0)  # straight ahead: along world +x
    for _ in range(10):  # 0.5 s: at full speed 3.5 m/s after 0.175 s
        assert nav.step(body, 0.05, NAV) is None
    assert body.velocity == pytest.approx(3.5)
    travelled = body.x - 5.0
    assert 0.0 < travelled < 10.0
    body.cancel()
    ended = _run(body)
    assert (ended.action, ended.outcome) == ("move", "cancelled")
    # braking at 20 m/s^2 in 0.05 s ticks from 3.5 m/s: 2.5, 1.5, 0.5 m/s -> 0.225 m further
    assert body.x - 5.0 == pytest.approx(travelled + 0.225)
    assert body.z == pytest.approx(5.0) and body.velocity == 0.0 and not body.busy
    x, z, angle = body.relative_to_start(ended.start)
    assert x == pytest.approx(0.0, abs=1e-9)
    assert z == pytest.approx(travelled + 0.225)
    assert angle == pytest.approx(0.0)


def test_cancel_while_turning_towards_the_goal_ends_at_once_with_the_angle_turned():
    body = nav.RoverBody(1, 0.0, 0.0, 0.0)
    body.start_move(5.0, 0.0)  # 90 deg to the right: turns at 120 deg/s first
    nav.step(body, 0.1, NAV)
    body.cancel()
    ended = nav.step(body, 0.1, NAV)
    assert ended.outcome == "cancelled"
    assert body.relative_to_start(ended.start) == pytest.approx((0.0, 0.0, 12.0))


def test_speed_level_limits_the_speed():
    body = nav.RoverBody(1, 0.0, 0.0, 0.0, speed_level=1)
    body.start_move(0.0, 10.0)
    for _ in range(20):
        nav.step(body, 0.05, NAV)
    assert body.velocity == pytest.approx(1.5)


# ---- terrain ----


@pytest.fixture(scope="module")
def crater_terrain():
    crater = Crater(x=0.0, z=0.0, radius_m=20.0)  # depth 4, rim height 0.8, rim down to the plain at 26 m
    spec = TerrainSpec(origin=(-60.0, -60.0), size_m=(120.0, 120.0), resolution_m=0.5)
    return Heightmap.build(spec, [crater], np.random.default_rng(0))


def test_terrain_heights(crater_terrain):
    assert crater_terrain.height(0.0, 0.0) == pytest.approx(0.8 - 4.0)
    assert crater_terrain.height(0.0, -20.0) == pytest.approx(0.8)
    assert crater_terrain.height(-50.0, 50.0) == 0.0


def test_pitch_facing_the_centre_from_outside_the_crest_is_positive(crater_terrain):
    pitch = float(crater_terrain.pitch_deg(0.0, -23.0, 0.0))  # on the outer rim slope, facing +z (the centre)
    # rim 0.4 (1 + cos(pi u)), u = (r - 20) / 6: slope 0.4 pi / 6 at u = 0.5, about 11.8 deg
    assert pitch == pytest.approx(math.degrees(math.atan(0.4 * math.pi / 6)), abs=0.5)
    assert float(crater_terrain.pitch_deg(0.0, -23.0, 180.0)) == pytest.approx(-pitch)


def test_pitch_just_inside_the_crest_is_negative(crater_terrain):
    pitch = float(crater_terrain.pitch_deg(0.0, -19.0, 0.0))
    # bowl 0.8 - 4 (1 - r^2 / 400): slope 8 r / 400 = 0.38 at r = 19, downhill towards the centre
    assert pitch < 0
    assert pitch == pytest.approx(-math.degrees(math.atan(0.38)), abs=0.5)


def test_pitch_on_flat_ground_and_across_the_slope_is_zero(crater_terrain):
    assert np.allclose(crater_terrain.pitch_deg([-50.0, 45.0], [50.0, 0.0], [0.0, 90.0]), 0.0)
    assert float(crater_terrain.pitch_deg(0.0, -23.0, 90.0)) == pytest.approx(0.0, abs=1e-9)


def test_rough_terrain_is_seeded():
    spec = TerrainSpec(origin=(0.0, 0.0), size_m=(50.0, 50.0), roughness_m=0.5)
    a = Heightmap.build(spec, [], np.random.default_rng(4))
    b = Heightmap.build(spec, [], np.random.default_rng(4))
    c = Heightmap.build(spec, [], np.random.default_rng(5))
    assert np.array_equal(a.heights, b.heights)
    assert not np.array_equal(a.heights, c.heights)
    assert np.abs(a.heights).max() <= 0.5 + 1e-9 and np.abs(a.heights).max() > 0


# ---- radio graph ----


@pytest.fixture
def chain():
    # lander at the origin, r1 8 m away, r2 8 m further (16 m from the lander), r3 far off
    ids = np.array([0, 1, 2, 3])
    return build_graph(ids, np.array([0.0, 8.0, 16.0, 100.0]), np.array([0.0, 0.0, 0.0, 100.0]),
                       comm_range=10.0, lander_range=10.0)


def test_radio_partners(chain):
    assert chain.partners(0) == [1]
    assert chain.partners(1) == [0, 2]
    assert chain.partners(2) == [1]
    assert chain.partners(3) == []
    assert chain.partners(99) == []


def test_radio_connected_is_transitive(chain):
    assert chain.connected(0, 2) and chain.connected(2, 0) and chain.connected(1, 2)
    assert not chain.connected(0, 3) and not chain.connected(3, 1)
    assert chain.connected(3, 3)
    assert not chain.connected(0, 99)


def test_radio_links(chain):
    assert chain.links() == [(0, 1), (1, 2)]


def test_lander_range_is_its_own():
    ids = np.array([0, 1, 2])
    g = build_graph(ids, np.array([0.0, 50.0, 65.0]), np.array([0.0, 0.0, 0.0]), comm_range=10.0, lander_range=60.0)
    assert g.partners(0) == [1]  # 65 m is beyond the lander's 60 m
    assert g.partners(2) == []  # r1-r2 are 15 m apart: beyond the rovers' 10 m
    assert g.links() == [(0, 1)]
    assert not g.connected(0, 2)


def _dense_pairs(x, z, comm_range, lander_range):
    """Every distance at once: how the graph was built before the grid search, kept as the reference."""
    reach = np.full((len(x), len(x)), comm_range)
    reach[0, :] = reach[:, 0] = lander_range
    return np.nonzero(np.triu(np.hypot(x[:, None] - x[None, :], z[:, None] - z[None, :]) <= reach, 1))


@pytest.mark.parametrize("n, comm_range, lander_range", [(1001, 10.0, 1000.0), (400, 10.0, 60.0),
                                                          (300, 0.0, 50.0), (300, 7.5, 0.0), (500, 200.0, 30.0)])
def test_grid_search_finds_the_same_pairs_in_the_same_order_as_every_distance(n, comm_range, lander_range):
    """A formation of rovers (some on each other's 10 m exactly, some on top of one another) and a sight that
    blocks every third pair it is asked about: the graph and the pairs sight is asked about are the dense ones."""
    rng = np.random.default_rng(n)
    x = np.round(rng.normal(0.0, 40.0, n), 1)
    z = np.round(rng.normal(0.0, 40.0, n), 1)
    x[1:6], z[1:6] = [0.0, 10.0, 20.0, 20.0, 20.0], [0.0, 0.0, 0.0, 0.0, 7.5]
    asked = []

    def sight(i, j):
        asked.append((i.copy(), j.copy()))
        return (i + j) % 3 != 0

    graph = build_graph(np.arange(n), x, z, comm_range, lander_range, sight)
    i, j = _dense_pairs(x, z, comm_range, lander_range)
    assert len(asked) == 1 and len(i) > 0
    assert np.array_equal(asked[0][0], i) and np.array_equal(asked[0][1], j)
    seen = (i + j) % 3 != 0
    expected = np.zeros((n, n), bool)
    expected[i[seen], j[seen]] = expected[j[seen], i[seen]] = True
    assert np.array_equal(graph.adjacency, expected)


# ---- the World ----

KEYS = ks.Keyspace("unit")


def _send(world, rid, message):
    topic = next(t for t, model in m.TOPIC_MODELS.items() if model is type(message))
    return world.receive(KEYS.rover(rid, topic), codec.encode(message))


def _only_rejection(out, rid=1):
    assert len(out) == 1
    key, message = out[0]
    assert key == KEYS.rover(rid, ks.ACTION_REJECTED)
    assert isinstance(message, m.ActionRejected)
    return message


def _step_until_idle(world, rid=1, limit=400):
    out = []
    for _ in range(limit):
        out += world.step()
        if not world.actuator.bodies[rid].busy:
            return out
    raise AssertionError("the rover never became idle")


def test_move_accepted_answers_a_running_status_and_completes():
    world = World(_scenario(), KEYS)
    out = _send(world, 1, m.MoveAction(x=0.0, z=5.0))
    assert out == [(KEYS.rover(1, ks.NAVIGATION_STATUS),
                    m.NavigationStatus(stamp=0.0, action="move", remaining=5.0, outcome="running"))]
    out = _step_until_idle(world)
    statuses = [msg for key, msg in out if key == KEYS.rover(1, ks.NAVIGATION_STATUS)]
    assert statuses[-1].outcome == "completed" and statuses[-1].remaining == 0.0
    assert all(s.outcome == "running" for s in statuses[:-1])
    assert (world.actuator.bodies[1].x, world.actuator.bodies[1].z) == pytest.approx((0.0, 5.0))
    assert not any(key == KEYS.rover(1, ks.CANCEL_RESULT) for key, _ in out)


@pytest.mark.parametrize(("x", "z"), [(0.0, -5.0), (-2.0, -5.0), (3.0, -8.0)])
def test_move_out_of_view_is_rejected(x, z):
    world = World(_scenario(), KEYS)
    rejection = _only_rejection(_send(world, 1, m.MoveAction(x=x, z=z)))
    assert (rejection.action, rejection.reason) == ("move", "out_of_view")
    assert not world.actuator.bodies[1].busy


def test_move_beyond_range_is_rejected_with_tolerance():
    world = World(_scenario(), KEYS)
    rejection = _only_rejection(_send(world, 1, m.MoveAction(x=0.0, z=11.5)))  # limit 10 x 1.1
    assert (rejection.action, rejection.reason) == ("move", "out_of_range")
    out = _send(world, 1, m.MoveAction(x=0.0, z=10.9))
    assert out[0][1] == m.NavigationStatus(stamp=0.0, action="move", remaining=10.9)


def test_move_through_a_rock_is_blocked():
    world = World(_scenario(rocks=[(0.0, 5.0, 0.5)]), KEYS)
    rejection = _only_rejection(_send(world, 1, m.MoveAction(x=0.0, z=8.0)))
    assert (rejection.action, rejection.reason) == ("move", "blocked")
    assert not world.actuator.bodies[1].busy
    # beside the rock, the centre line is clear (strict_line_of_sight is off by default)
    assert _send(world, 1, m.MoveAction(x=1.0, z=8.0))[0][0] == KEYS.rover(1, ks.NAVIGATION_STATUS)


def test_strict_line_of_sight_blocks_a_body_wide_pass():
    world = World(_scenario(rocks=[(0.8, 2.0, 0.5)], navigation={"strict_line_of_sight": True}), KEYS)
    rejection = _only_rejection(_send(world, 1, m.MoveAction(x=0.0, z=4.0)))
    assert rejection.reason == "blocked"


def test_move_into_another_rover_is_blocked():
    world = World(_scenario(rovers=[(0.0, 0.0, 0.0), (0.0, 5.0, 0.0)]), KEYS)
    assert _only_rejection(_send(world, 1, m.MoveAction(x=0.0, z=8.0))).reason == "blocked"


def test_second_action_while_busy_is_rejected():
    world = World(_scenario(), KEYS)
    _send(world, 1, m.MoveAction(x=0.0, z=5.0))
    world.step()
    rejection = _only_rejection(_send(world, 1, m.MoveAction(x=0.0, z=3.0)))
    assert (rejection.action, rejection.reason) == ("move", "action_in_progress")
    world.step()  # a rover gets at most one refusal a tick
    rejection = _only_rejection(_send(world, 1, m.RotateAction(degrees=10.0)))
    assert (rejection.action, rejection.reason) == ("rotate", "action_in_progress")


def test_cancel_with_nothing_running_is_rejected():
    world = World(_scenario(), KEYS)
    rejection = _only_rejection(_send(world, 1, m.CancelAction()))
    assert (rejection.action, rejection.reason) == ("cancel", "no_action")


def _navigation_ends(out) -> tuple[list, list]:
    """Rover 1's navigation statuses and cancel results among a world's outputs."""
    return ([msg for key, msg in out if key == KEYS.rover(1, ks.NAVIGATION_STATUS)],
            [msg for key, msg in out if key == KEYS.rover(1, ks.CANCEL_RESULT)])


def test_cancel_of_a_move_answers_a_cancel_result():
    world = World(_scenario(), KEYS)
    _send(world, 1, m.MoveAction(x=0.0, z=8.0))
    for _ in range(5):
        world.step()
    assert _send(world, 1, m.CancelAction()) == []
    statuses, results = _navigation_ends(_step_until_idle(world))
    assert statuses[-1].outcome == "cancelled"
    assert len(results) == 1 and results[0].reason == "cancelled"
    assert results[0].z == pytest.approx(world.actuator.bodies[1].z) and 0 < results[0].z < 8.0
    assert results[0].x == pytest.approx(0.0, abs=1e-9) and results[0].angle_deg == pytest.approx(0.0)


def test_unknown_rover_and_garbage_are_counted_and_answered_with_nothing():
    world = World(_scenario(), KEYS)
    unknown = KEYS.rover(7, ks.MOVE_ACTION)
    assert world.receive(unknown, codec.encode(m.MoveAction(x=0.0, z=1.0))) == []
    assert world.rejected.by_topic[ks.MOVE_ACTION] == 1  # counted by topic: forged ids must not grow the table
    garbage = KEYS.rover(1, ks.MOVE_ACTION)
    assert world.receive(garbage, b"\xc1not msgpack") == [] and world.rejected.by_topic[ks.MOVE_ACTION] == 2
    assert world.receive(garbage, codec.encode(m.RotateAction(degrees=1.0))) == []
    assert world.rejected.by_topic[ks.MOVE_ACTION] == 3
    not_an_input = KEYS.rover(1, ks.PERCEPTION)
    assert world.receive(not_an_input, codec.encode(m.Perception(stamp=0, angles_deg=[], distances_m=[],
                                                                 kinds=[]))) == []
    assert world.receive("lunar/other/rover/1/move_action", codec.encode(m.MoveAction(x=0.0, z=1.0))) == []
    assert world.receive(KEYS.lander(ks.COMM_OUT), b"") == []
    assert world.rejected.total == 6
    assert world.report().rejected_messages == 6
    assert not world.actuator.bodies[1].busy


def test_only_the_lander_may_use_the_mission_channels():
    world = World(_scenario(rovers=[(0.0, 0.0, 0.0), (3.0, 0.0, 0.0)]), KEYS)
    direction = m.MissionDirection(goal_index=0, goals_total=1, kind="waypoint", bearing_deg=0.0, distance_m=5.0)
    forged = m.OutboundComm(targets=[2], payload=codec.encode(direction), channel="mission_direction")
    assert _send(world, 1, forged) == []
    assert world.rejected.total == 1
    out = world.receive(KEYS.lander(ks.COMM_OUT), codec.encode(forged))
    assert out == [(KEYS.rover(2, ks.MISSION_DIRECTION), direction)]


def test_rover_radio_reaches_a_neighbour_as_comm_in():
    world = World(_scenario(rovers=[(0.0, 0.0, 0.0), (3.0, 0.0, 0.0)]), KEYS)
    out = _send(world, 1, m.OutboundComm(targets=[2, 0], payload=b"hi"))
    assert out == [(KEYS.rover(2, ks.COMM_IN), m.InboundComm(sender=1, payload=b"hi")),
                   (KEYS.lander(ks.COMM_IN), m.InboundComm(sender=1, payload=b"hi"))]


def test_driving_into_a_rock_is_a_collision():
    # the centre line passes 0.8 m beside the rock centre (radius 0.5): accepted without strict line of sight,
    # but the rover's 0.5 m body meets the rock on the way
    world = World(_scenario(rocks=[(0.8, 2.0, 0.5)]), KEYS)
    accepted = _send(world, 1, m.MoveAction(x=0.0, z=4.0))
    assert accepted[0][1].outcome == "running"
    statuses, results = _navigation_ends(_step_until_idle(world))
    assert statuses[-1].outcome == "collided" and statuses[-1].remaining == 0.0
    assert len(results) == 1 and results[0].reason == "collided"
    assert world.actuator.obstacle_collisions == 1 and world.actuator.rover_collisions == 0
    body = world.actuator.bodies[1]
    assert math.hypot(body.x - 0.8, body.z - 2.0) >= 1.0  # left where it was before touching
    assert results[0].z == pytest.approx(body.z) and results[0].x == pytest.approx(0.0, abs=1e-9)
    assert 0.0 < body.z < 2.0
    world.observed_state()  # statistics follow the published state
    assert world.report().obstacle_collisions == 1


def test_a_move_that_touches_a_rock_on_its_last_step_ends_collided_with_a_cancel_result():
    """The step that completes a move may be the one that touches: the move is then already over when the
    collision is found, and its end still needs the CancelResult that tells the agent where the rover stopped."""
    world = World(_scenario(rocks=[(0.0, 4.99, 0.5)]), KEYS)  # the body touches it only at the move's end
    assert _send(world, 1, m.MoveAction(x=0.0, z=4.0))[0][1].outcome == "running"
    statuses, results = _navigation_ends(_step_until_idle(world))
    assert statuses[-1].outcome == "collided"
    assert len(results) == 1 and results[0].reason == "collided"
    assert results[0].z == pytest.approx(world.actuator.bodies[1].z) and 3.5 < results[0].z < 4.0


def test_driving_into_a_rover_is_a_rover_collision():
    world = World(_scenario(rovers=[(0.0, 0.0, 0.0), (0.8, 2.0, 0.0)]), KEYS)
    assert _send(world, 1, m.MoveAction(x=0.0, z=4.0))[0][1].outcome == "running"
    out = _step_until_idle(world)
    assert [msg.reason for key, msg in out if key == KEYS.rover(1, ks.CANCEL_RESULT)] == ["collided"]
    assert world.actuator.rover_collisions == 1 and world.actuator.obstacle_collisions == 0


def test_sensors_are_published_at_their_rates():
    world = World(_scenario(), KEYS)
    keys = [key for _ in range(20) for key, _ in world.step()]  # one second at 20 Hz
    assert world.clock.sim_time == pytest.approx(1.0)
    assert keys.count(KEYS.rover(1, ks.PERCEPTION)) == 5
    assert keys.count(KEYS.rover(1, ks.GYROSCOPE)) == 20
    assert keys.count(KEYS.rover(1, ks.COMM_PARTNERS)) == 1
    assert keys.count(KEYS.clock) == 20
    assert keys.count(KEYS.stats) == 1


@pytest.mark.parametrize("degrees", [math.nan, math.inf])
def test_non_finite_rotate_does_not_keep_the_rover_busy(degrees):
    world = World(_scenario(), KEYS)
    key = KEYS.rover(1, ks.ROTATE_ACTION)
    assert world.receive(key, msgpack.packb([codec.SCHEMA_VERSION, {"degrees": degrees}])) == []
    assert world.rejected.by_topic[ks.ROTATE_ACTION] == 1
    with pytest.raises(ValueError):
        codec.checked(m.RotateAction(degrees=degrees))
    for _ in range(200):
        world.step()
    assert not world.actuator.bodies[1].busy


def test_a_wall_between_two_rovers_cuts_their_radio_link():
    world = World(_scenario(rovers=[(0.0, 0.0, 0.0), (6.0, 0.0, 0.0)], walls=[[(3.0, -5.0), (3.0, 5.0)]]), KEYS)
    assert 2 not in world.radio.graph.partners(1)


def test_photo_action_renders_what_the_rover_sees():
    world = World(_scenario(rocks=[(0.0, 6.0, 1.0)]), KEYS)
    assert world.receive(KEYS.rover(1, ks.PHOTO_ACTION), codec.encode(m.PhotoAction(label="rim"))) == []
    job = world.shutter.jobs.pop()
    assert (job.rover_id, job.label, job.stamp) == (1, "rim", 0.0)
    image = decode_png(world.render(job).png)
    params = world.scenario.rover_params.camera
    assert image.shape == (params.height, params.width, 3)
    world.shutter.scene = Scene.from_scenario(_scenario())  # the same view without the rock
    empty = decode_png(world.render(job).png)
    assert np.abs(image.astype(int) - empty.astype(int)).sum() > 0


def test_the_slope_bound_is_never_below_the_real_slope():
    spec = TerrainSpec(origin=(-60.0, -60.0), size_m=(120.0, 120.0), resolution_m=0.5, roughness_m=0.8)
    craters = [Crater(x=0.0, z=0.0, radius_m=20.0), Crater(x=25.0, z=10.0, radius_m=8.0, depth_m=4.0)]
    terrain = Heightmap.build(spec, craters, np.random.default_rng(5))
    gx, gz = np.meshgrid(np.linspace(-59, 59, 300), np.linspace(-59, 59, 300))
    slope_deg = np.degrees(np.arctan(np.hypot(*terrain.gradient(gx, gz))))  # whatever the heading
    assert slope_deg.max() <= terrain.max_slope_bound_deg() + 1e-6


def test_ground_rising_too_steeply_is_perceived_as_terrain():
    scenario = parse_scenario({
        "name": "steep", "lander": {"x": 40.0, "z": 40.0},
        "rovers": [{"x": 0.0, "z": 0.0, "heading_deg": 0.0}],
        "craters": [{"x": 0.0, "z": 0.0, "radius_m": 20.0, "depth_m": 12.0}],
        "mission": [{"x": 0.0, "z": 0.0, "kind": "crater"}],
    })
    hits = _scan(scenario)
    ahead = [(d, k) for a, d, k in hits if abs(a) < 3]
    # the bowl wall (2 depth r / R^2 per metre) passes tan(25 deg) near r = 7.8 m
    assert ahead and ahead[0][1] == "terrain" and 6.5 <= ahead[0][0] <= 9.0


def _gyroscopes(world: World) -> list[m.Gyroscope]:
    return [codec.decode(m.Gyroscope, codec.encode(msg)) for _ in range(20) for key, msg in world.step()
            if key == KEYS.rover(1, ks.GYROSCOPE)]


def test_the_gyroscope_carries_a_heading_only_from_a_sun_sensor_and_with_its_noise():
    without = _gyroscopes(World(_scenario(rovers=((0.0, 0.0, 30.0),)), KEYS))
    assert without and all(g.heading_deg is None for g in without)
    exact = _gyroscopes(World(_scenario(rovers=((0.0, 0.0, 30.0),), perception={
        "sun_sensor": True, "sun_sensor_noise_std_deg": 0.0}), KEYS))
    assert [g.heading_deg for g in exact] == [pytest.approx(30.0)] * len(exact)
    noisy = _gyroscopes(World(_scenario(rovers=((0.0, 0.0, 30.0),), perception={
        "sun_sensor": True, "sun_sensor_noise_std_deg": 2.0}), KEYS))
    errors = [wrap_deg(g.heading_deg - 30.0) for g in noisy]
    assert len(set(errors)) == len(errors)  # a fresh draw each reading
    assert 0.5 < float(np.std(errors)) < 4.0 and all(abs(e) < 10.0 for e in errors)
