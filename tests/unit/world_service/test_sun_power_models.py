"""Sunlight, shadows, batteries and temperatures: the pure models against closed forms, and the
world with and without a sun."""

from __future__ import annotations

import math

import msgspec
import numpy as np
import pytest
from procs import SCENARIOS

from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.keyspace import Keyspace
from schemas.params import PowerParams, ThermalParams
from schemas.scenario import Obstacles, Rock, ScenarioError, SunSpec, TerrainSpec, Wall, load_scenario, parse_scenario
from world_service.power import battery, shadows
from world_service.power.shadows import Occluders, ShadowCache, lit
from world_service.power.sun import SYNODIC_DAY_S, Sun, SunPosition, from_site
from world_service.power.thermal import Thermal, relax
from world_service.scene import CircleGrid, Scene
from world_service.sim import World
from world_service.terrain.heightmap import Heightmap

FLAT = TerrainSpec(origin=(-100.0, -100.0), size_m=(200.0, 200.0), resolution_m=1.0)


def _flat() -> Heightmap:
    return Heightmap(FLAT)


def no_occluders() -> Occluders:
    """Nothing on the ground to cast a shadow: only the terrain does."""
    empty = np.zeros(0)
    return Occluders(empty, empty, empty, empty, CircleGrid(empty, empty, empty, 10.0), np.zeros((0, 4)), empty)


def _scene(**obstacles) -> Scene:
    data = {"name": "s", "lander": {"x": 90.0, "z": 90.0}, "rovers": [{"x": 0.0, "z": 0.0}],
            "mission": [{"x": 10.0, "z": 0.0}], "obstacles": Obstacles(**obstacles).model_dump()}
    return Scene.from_scenario(parse_scenario(data))


def _shadow_end(terrain, occ, sun, xs, zs) -> float:
    """Distance along the points to the last one in shadow."""
    shaded = ~lit(terrain, occ, sun, xs, zs, panel_height_m=0.0, max_shadow_m=200.0)
    return float(np.hypot(xs, zs)[shaded].max())


# ---- sun ----


def test_a_fixed_sun_stays_where_the_scenario_puts_it():
    sun = Sun(SunSpec(azimuth_deg=450.0, elevation_deg=10.0))
    assert sun.at(0.0) == sun.at(1e6) == SunPosition(90.0, 10.0)
    assert np.allclose(sun.at(0.0).vector, [math.cos(math.radians(10)), math.sin(math.radians(10)), 0.0])


def test_the_sun_at_a_polar_site_stands_low_and_circles_with_the_lunar_day():
    noon = from_site(-87.5, 0.0, 0.0)
    assert noon.elevation_deg == pytest.approx(2.5) and noon.azimuth_deg == pytest.approx(0.0)  # north
    north = from_site(40.0, 0.0, 0.0)
    assert north.elevation_deg == pytest.approx(50.0) and north.azimuth_deg == pytest.approx(180.0)
    sun = Sun(SunSpec(latitude_deg=-87.5, step_deg=0.01))
    quarter = sun.at(SYNODIC_DAY_S / 4)  # six hours of a 24-hour clock later: hour angle 90, on the horizon, west
    assert quarter.elevation_deg == pytest.approx(0.0, abs=0.01) and quarter.azimuth_deg == pytest.approx(270.0,
                                                                                                          abs=0.1)
    afternoon = sun.at(3600.0).azimuth_deg  # from the pole the sun moves west: 0.51 degrees an hour
    assert afternoon == pytest.approx(360.0 - 360.0 / 29.530589 / 24, abs=0.01)


def test_sun_spec_wants_one_way_of_placing_the_sun():
    with pytest.raises(ValueError, match="either azimuth_deg and elevation_deg"):
        SunSpec()
    with pytest.raises(ValueError, match="needs both"):
        SunSpec(azimuth_deg=10.0)
    data = {"name": "s", "lander": {"x": 0, "z": 0}, "rovers": [{"x": 1, "z": 1}], "mission": [{"x": 5, "z": 5}],
            "sun": {"latitude_deg": -120}}
    with pytest.raises(ScenarioError, match=r"sun\.latitude_deg"):
        parse_scenario(data)


# ---- shadows on known geometry ----


@pytest.mark.parametrize("elevation", [5.0, 15.0, 30.0])
def test_a_wall_casts_a_shadow_of_its_height_over_tan_elevation(elevation):
    terrain = _flat()
    wall = Wall(points=[(-20.0, 0.0), (20.0, 0.0)], thickness_m=0.2, height_m=2.0)
    occ = Occluders.from_scene(_scene(walls=[wall]), terrain)
    sun = SunPosition(0.0, elevation)  # from +z: the shadow falls towards -z
    zs = -np.arange(0.2, 60.0, 0.05)
    expected = 2.0 / math.tan(math.radians(elevation))
    assert _shadow_end(terrain, occ, sun, np.zeros_like(zs), zs) == pytest.approx(expected + 0.1, abs=0.06)
    assert lit(terrain, occ, sun, [0.0], [5.0], 0.0, 200.0)[0]  # the sunny side
    assert lit(terrain, occ, sun, [25.0], [-3.0], 0.0, 200.0)[0]  # beyond the wall's end


def test_a_rock_casts_a_shadow_of_its_radius_over_sin_elevation():
    terrain = _flat()
    occ = Occluders.from_scene(_scene(rocks=[Rock(x=0.0, z=0.0, radius_m=1.5)]), terrain)
    sun = SunPosition(90.0, 10.0)  # from +x: the shadow falls towards -x
    xs = -np.arange(1.6, 40.0, 0.05)
    assert _shadow_end(terrain, occ, sun, xs, np.zeros_like(xs)) == pytest.approx(1.5 / math.sin(math.radians(10)),
                                                                                  abs=0.06)
    assert lit(terrain, occ, sun, [-5.0], [2.0], 0.0, 200.0)[0]  # beside the shadow


class Ridge:
    """A height source: a ridge 4 m high and 2 m wide along x at z = 0."""

    def block(self, x0, z0, resolution, nx, nz):
        zs = z0 + np.arange(nz) * resolution
        return np.repeat(np.where(np.abs(zs) <= 1.0, 4.0, 0.0)[:, None], nx, axis=1)


def test_terrain_shadows_are_ray_marched_over_the_heightmap():
    terrain = Heightmap(FLAT, base=Ridge())
    sun = SunPosition(0.0, 8.0)
    zs = -np.arange(2.5, 60.0, 0.25)
    expected = 1.0 + 4.0 / math.tan(math.radians(8.0))  # from the ridge's south foot
    assert _shadow_end(terrain, no_occluders(), sun, np.zeros_like(zs), zs) == pytest.approx(expected, abs=1.0)
    assert not lit(terrain, no_occluders(), SunPosition(0.0, -1.0), [0.0], [10.0], 0.2, 200.0)[0]  # night
    assert lit(terrain, no_occluders(), SunPosition(0.0, 80.0), [0.0], [-3.0], 0.2, 200.0)[0]  # high sun


def test_rays_stop_once_above_any_ground_without_changing_the_answer():
    world = World(load_scenario(SCENARIOS / "polar_night_edge.yaml"), Keyspace("t"))
    terrain, sun = world.terrain, SunPosition(0.0, 2.5)
    xs, zs = (g.ravel() for g in np.meshgrid(np.arange(-10.0, 60.0, 1.5), np.arange(-15.0, 15.0, 1.5)))
    py = terrain.height(xs, zs) + 0.2
    top = shadows.height_bound(terrain, xs, zs, 200.0)
    assert top == pytest.approx(1.2)  # the one crater's rim: 0.04 x 30 m
    bounded = shadows._terrain_shadow(terrain, sun, xs, py, zs, 200.0, top)
    assert np.array_equal(bounded, shadows._terrain_shadow(terrain, sun, xs, py, zs, 200.0))
    assert 0 < bounded.sum() < bounded.size


def test_the_shadow_cache_answers_as_a_fresh_trace_of_the_cell_centre():
    terrain = Heightmap(FLAT, base=Ridge())
    cache = ShadowCache(terrain, no_occluders(), 0.2, 200.0)
    sun = SunPosition(0.0, 8.0)
    xs, zs = np.linspace(-5, 5, 41), np.linspace(-40, -1, 41)
    first = cache.lit(sun, xs, zs)
    traced = cache.traced
    assert np.array_equal(cache.lit(sun, xs, zs), first) and cache.traced == traced  # all from the cache
    centres = np.floor(xs / 0.25 + 0.5) * 0.25, np.floor(zs / 0.25 + 0.5) * 0.25
    assert np.array_equal(first, lit(terrain, no_occluders(), sun, *centres, 0.2, 200.0))
    cache.lit(SunPosition(0.0, 9.0), xs, zs)
    assert cache.traced > traced  # a new sun step traces again


# ---- battery ----


def test_draw_follows_the_action_and_the_speed_level():
    p = PowerParams()
    activity = np.array([battery.IDLE, battery.MOVING, battery.MOVING, battery.TURNING])
    draw = battery.draw_w(p, activity, np.array([3, 1, 3, 2]))
    base = p.idle_w + p.perception_w
    assert draw.tolist() == pytest.approx([base, base + p.move_w[0], base + p.move_w[2], base + p.rotate_w])


def test_solar_input_follows_the_incidence_and_only_in_light():
    p = PowerParams(panel_area_m2=0.1, panel_efficiency=0.3)
    sun = SunPosition(45.0, 30.0)
    flat = battery.incidence_cos(p, sun, np.zeros(1), np.zeros(1))
    assert flat[0] == pytest.approx(math.sin(math.radians(30)))
    tilted = battery.incidence_cos(PowerParams(panel_tilt_deg=60.0), sun, np.zeros(1), np.zeros(1))
    assert tilted[0] == pytest.approx(1.0)  # the panel's normal points at the sun
    facing = battery.incidence_cos(p, sun, np.array([-0.5 * math.sin(math.radians(45))]),
                                 np.array([-0.5 * math.cos(math.radians(45))]))  # ground falling away from the sun
    assert facing[0] > flat[0]
    out = battery.solar_w(p, np.array([True, False]), np.array([0.5, 0.5]))
    assert out.tolist() == pytest.approx([1361.0 * 0.1 * 0.3 * 0.5, 0.0])


def test_battery_charge_is_linear_in_time_until_empty_then_resumes_above_its_threshold():
    p = PowerParams(capacity_wh=1.0, initial_charge_fraction=0.5, resume_fraction=0.2)
    bank = battery.Batteries(p, 1)
    dt, draw = 0.05, np.array([9.0])
    for _ in range(200):  # 10 s at 9 W in shadow
        bank.step(draw, np.zeros(1), np.ones(1, bool), dt)
    assert bank.charge_wh[0] == pytest.approx(0.5 - 9.0 * 10.0 / 3600.0)
    steps_to_empty = math.ceil(0.5 * 3600.0 / 9.0 / dt)  # 200 s
    emptied_at = next(k for k in range(1, 5000) if bank.step(draw, np.zeros(1), np.ones(1, bool), dt)[0][0]) + 200
    assert emptied_at == pytest.approx(steps_to_empty, abs=1)
    assert bank.empty[0] and bank.shutdowns == 1 and bank.used_wh[0] == pytest.approx(0.5)
    solar = np.array([12.0])  # an empty rover draws nothing: only the panel counts
    back_at = next(k for k in range(1, 5000) if bank.step(draw, solar, np.ones(1, bool), dt)[1][0])
    assert back_at == pytest.approx(0.2 * 3600.0 / 12.0 / dt, abs=1)  # 60 s
    assert not bank.empty[0] and bank.used_wh[0] == pytest.approx(0.5)
    bank.spend(0, 36.0)
    assert bank.used_wh[0] == pytest.approx(0.51)


def test_battery_never_exceeds_its_capacity():
    bank = battery.Batteries(PowerParams(capacity_wh=1.0, initial_charge_fraction=0.99), 1)
    for _ in range(100):
        bank.step(np.array([1.0]), np.array([100.0]), np.ones(1, bool), 0.05)
    assert bank.charge_wh[0] == 1.0 and bank.harvested_wh[0] == pytest.approx(100.0 * 5.0 / 3600.0)


# ---- temperature ----


def test_temperature_follows_newtons_law_to_the_closed_form():
    p = ThermalParams(initial_c=20.0, shadow_c=-173.0, cool_time_constant_s=600.0, sun_c=127.0,
                      heat_time_constant_s=300.0)
    t = Thermal(p, 2)
    lit_mask = np.array([False, True])
    for _ in range(2000):  # 100 s at 20 Hz
        t.step(lit_mask, 0.05)
    closed = [-173.0 + 193.0 * math.exp(-100.0 / 600.0), 127.0 + (20.0 - 127.0) * math.exp(-100.0 / 300.0)]
    assert t.celsius.tolist() == pytest.approx(closed)
    assert relax(np.array([20.0]), np.array([False]), p, 100.0)[0] == pytest.approx(closed[0])


def test_a_rover_too_cold_shuts_down_and_starts_again_when_warm():
    p = ThermalParams(initial_c=0.0, min_operating_c=-30.0, resume_c=-20.0, cool_time_constant_s=100.0,
                      heat_time_constant_s=100.0)
    t = Thermal(p, 1)
    froze_at = next(k for k in range(1, 10000) if t.step(np.array([False]), 0.05)[0][0])
    assert froze_at * 0.05 == pytest.approx(100.0 * math.log(173.0 / 143.0), abs=0.05)
    frozen = float(t.celsius[0])
    thawed_at = next(k for k in range(1, 10000) if t.step(np.array([True]), 0.05)[1][0])
    assert thawed_at * 0.05 == pytest.approx(100.0 * math.log((127.0 - frozen) / (127.0 + 20.0)), abs=0.05)
    assert not t.cold[0] and t.shutdowns == 1


# ---- the world ----


def test_without_a_sun_the_world_publishes_no_power_sensors_and_reports_none():
    world = World(load_scenario(SCENARIOS / "crater_observation.yaml"), Keyspace("t"))
    keys = {key for _ in range(40) for key, _ in world.step()}
    assert world.power is None
    assert not any(key.endswith(("/battery", "/temperature", "/sun")) for key in keys)
    state = world.world_state()
    assert state.rovers[0].battery_wh is None and state.counters.power_shutdowns == 0
    assert world.report().power_budget_efficiency is None


def test_with_a_sun_each_rover_gets_its_power_sensors_once_a_second():
    world = World(load_scenario(SCENARIOS / "polar_night_edge.yaml"), Keyspace("t"))
    out = [(key, msg) for _ in range(40) for key, msg in world.step()]
    keys = Keyspace("t")
    for topic, model in ((ks.BATTERY, m.Battery), (ks.TEMPERATURE, m.Temperature), (ks.SUN, m.Sunlight)):
        samples = [msg for key, msg in out if key == keys.rover(1, topic)]
        assert len(samples) == 2 and all(isinstance(s, model) for s in samples)  # ticks 1 and 21 of 40
        assert codec.decode(model, codec.encode(samples[-1])) == samples[-1]
    battery = [msg for key, msg in out if key == keys.rover(1, ks.BATTERY)][-1]
    assert battery.fraction > 0.25 and battery.solar_w > 0  # charging in the sun, standing still
    truth = world.world_state().rovers[0]
    assert truth.sunlit is True and truth.powered is True and truth.battery_wh > battery.charge_wh


def test_an_empty_rover_stops_refuses_actions_and_says_so():
    scenario = load_scenario(SCENARIOS / "polar_night_edge.yaml")
    params = msgspec.structs.replace(scenario.rover_params, power=msgspec.structs.replace(
        scenario.rover_params.power, initial_charge_fraction=0.01))
    scenario = scenario.model_copy(update={"rover_params": params, "sun": SunSpec(azimuth_deg=0.0,
                                                                                   elevation_deg=-5.0)})
    keys = Keyspace("t")
    world = World(scenario, keys)
    world.receive(keys.rover(1, ks.MOVE_ACTION), codec.encode(m.MoveAction(x=0.0, z=8.0)))
    out = [(key, msg) for _ in range(20) for key, msg in world.step()]
    assert world.actuator.bodies[1].distance_covered < 8.0
    ended = [msg for key, msg in out if key == keys.rover(1, ks.NAVIGATION_STATUS) and msg.remaining == 0.0]
    assert ended and ended[-1].outcome == "cancelled"
    assert any(key == keys.rover(1, ks.BATTERY) and msg.empty for key, msg in out)
    refused = world.receive(keys.rover(1, ks.MOVE_ACTION), codec.encode(m.MoveAction(x=0.0, z=2.0)))
    assert refused[0][1].reason == "no_power"
    assert world.world_state().counters.power_shutdowns == 1 and world.world_state().rovers[0].powered is False
