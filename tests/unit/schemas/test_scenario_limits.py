"""Scenario bounds: a value no mission could use is refused at load time, every problem on its own line."""

from __future__ import annotations

import copy
import math
import typing
from pathlib import Path

import msgspec
import pytest
import yaml
from pydantic import BaseModel

from schemas import scenario_limits as limits
from schemas.keyspace import check_world_name
from schemas.params import RoverParams
from schemas.scenario import Scenario, ScenarioError, TerrainSpec, load_rover_params, load_scenario, parse_scenario
from schemas.scenario_types import mirror

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"

BASE = {
    "name": "tiny",
    "seed": 3,
    "lander": {"x": 0.0, "z": 0.0},
    "rovers": [{"x": 5.0, "z": 5.0}],
    "craters": [{"x": 0.0, "z": 60.0, "radius_m": 20.0}],
    "mission": [{"x": 30.0, "z": 10.0}],
}


def _data(**changes) -> dict:
    data = copy.deepcopy(BASE)
    data.update(copy.deepcopy(changes))
    return data


def _error(data: object) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data, "test.yaml")
    return str(info.value)


def _set(data: dict, path: str, value: object) -> dict:
    """``data`` with the value at a dotted path (list indices as numbers) replaced, made on the way if absent."""
    *parents, last = path.split(".")
    node = data
    for key in parents:
        node = node[int(key)] if isinstance(node, list) else node.setdefault(key, {})
    if isinstance(node, list):
        node[int(last)] = value
    else:
        node[last] = value
    return data


# ---- finite numbers ----


def _models(model: type[BaseModel], seen: set[type[BaseModel]]) -> set[type[BaseModel]]:
    if model in seen:
        return seen
    seen.add(model)
    for field in model.model_fields.values():
        stack = [field.annotation]
        while stack:
            t = stack.pop()
            if isinstance(t, type) and issubclass(t, msgspec.Struct):  # validated by its mirror
                t = mirror(t)
            if isinstance(t, type) and issubclass(t, BaseModel):
                _models(t, seen)
            stack.extend(typing.get_args(t))
    return seen


def test_every_model_of_a_scenario_refuses_nan_and_inf():
    models = _models(Scenario, set())
    assert mirror(RoverParams) in models and TerrainSpec in models
    assert [m.__name__ for m in models if m.model_config.get("allow_inf_nan", True)] == []


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize("path", [
    "lander.x", "rovers.0.z", "rovers.0.heading_deg", "craters.0.radius_m", "mission.0.x",
    "rover_params.navigation.speed_mode_one", "rover_params.thermal.sun_c", "rover_params.power.capacity_wh",
    "spawn.start_spawn_x", "formation.spacing_m",
])
def test_a_nan_or_inf_is_refused_naming_its_field(path, value):
    text = _error(_set(_data(), path, value))
    assert f"test.yaml: {path}: Input should be a finite number" in text


def test_nan_inside_tuples_is_refused():
    terrain = {"origin": [-100.0, math.nan], "size_m": [200.0, math.inf]}
    text = _error(_data(terrain=terrain, obstacles={"walls": [{"points": [[0.0, 0.0], [math.nan, 1.0]]}]}))
    for path in ("terrain.origin.1", "terrain.size_m.1", "obstacles.walls.0.points.1.0"):
        assert f"{path}: Input should be a finite number" in text


def test_yaml_nan_in_a_file_names_the_file_and_field(tmp_path):
    path = tmp_path / "nan.yaml"
    path.write_text("lander: {x: .nan, z: 0.0}\n" + yaml.safe_dump({k: v for k, v in _data().items() if k != "lander"}))
    with pytest.raises(ScenarioError, match=r"nan\.yaml: lander\.x: Input should be a finite number"):
        load_scenario(path)


def test_nan_in_a_rover_parameter_file_is_refused(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text("navigation:\n  speed_mode_one: .inf\n")
    with pytest.raises(ScenarioError, match=r"p\.yaml: navigation\.speed_mode_one: Input should be a finite"):
        load_rover_params(path)


# ---- bounds ----


@pytest.mark.parametrize(("path", "value", "fragment"), [
    ("craters.0.radius_m", 200_000.0, "craters.0.radius_m: Input should be less than or equal to 100000"),
    ("craters.0.radius_m", 0.0, "craters.0.radius_m: Input should be greater than 0"),
    ("craters.0.depth_m", 25.0, "craters.0: depth_m (25) must be at most radius_m (20)"),
    ("craters.0.depth_m", -1.0, "craters.0.depth_m: Input should be greater than or equal to 0"),
    ("craters.0.rim_height_m", 21.0, "craters.0: rim_height_m (21) must be at most radius_m (20)"),
    ("seed", -1, "seed: Input should be greater than or equal to 0"),
    ("seed", 2**63, "seed: Input should be less than 9223372036854775808"),
    ("lander.x", 1e300, "lander.x: Input should be less than or equal to 10000000"),
    ("rovers.0.z", -2e7, "rovers.0.z: Input should be greater than or equal to -10000000"),
])
def test_values_out_of_bounds_are_refused(path, value, fragment):
    assert fragment in _error(_set(_data(), path, value))


@pytest.mark.parametrize("seed", [0, 2**63 - 1])
def test_the_extreme_seeds_are_accepted(seed):
    assert parse_scenario(_data(seed=seed)).seed == seed


RATES = ["navigation.publish_frequency", "perception.publish_frequency", "perception.gyroscope_frequency",
         "communication.partners_frequency", "power.publish_frequency"]


@pytest.mark.parametrize("rate", RATES)
def test_sensor_and_publish_rates_are_above_0_and_at_most_100_hz(rate):
    assert parse_scenario(_set(_data(), f"rover_params.{rate}", 100.0))
    assert "less than or equal to 100" in _error(_set(_data(), f"rover_params.{rate}", 100.5))
    assert "greater than 0" in _error(_set(_data(), f"rover_params.{rate}", 0.0))


def test_map_reports_at_most_100_a_second():
    assert "mapping.report_period_s" in _error(_set(_data(), "rover_params.mapping.report_period_s", 0.001))


def test_rover_count_is_1_to_1000():
    many = [{"x": float(i % 40), "z": float(i // 40)} for i in range(limits.MAX_ROVERS)]
    assert len(parse_scenario(_data(rovers=many)).rovers) == limits.MAX_ROVERS
    assert "rovers: List should have at most 1000 items" in _error(_data(rovers=[*many, {"x": 0.0, "z": 0.0}]))
    assert "rovers: List should have at least 1 item" in _error(_data(rovers=[]))
    assert "spawn.rover_count" in _error(_data(spawn={"rover_count": 1001}))
    scenario = parse_scenario(_data())
    with pytest.raises(ScenarioError, match="--rovers must be at most 1000, got 1001"):
        scenario.with_overrides(rovers=1001)
    with pytest.raises(ScenarioError, match="--seed must be at least 0 and below 2\\*\\*63"):
        scenario.with_overrides(seed=-5)


# ---- terrain size and memory ----


def _terrain(**changes) -> dict:
    return {"origin": [-100.0, -100.0], "size_m": [200.0, 200.0], **changes}


def test_terrain_memory_beyond_2_gib_is_refused_with_cells_and_size():
    text = _error(_data(terrain=_terrain(size_m=[10_000.0, 10_000.0], resolution_m=0.05, tile_size_m=1000.0)))
    assert "terrain: a terrain of 10000 m x 10000 m at 0.05 m has 40,000,400,001 cells" in text
    assert "GiB (limit 2.0 GiB)" in text


def test_a_large_tiled_terrain_that_fits_is_accepted():
    """The 50 km² terrain of benchmarks/terrain_memory.py: 2.4 GB as a whole grid, but only its tiles are held."""
    spec = TerrainSpec(origin=(0.0, 0.0), size_m=(7071.0, 7071.0), resolution_m=0.5, max_tiles_in_memory=400)
    nodes, held = limits.terrain_memory(spec.size_m, spec.resolution_m, spec.tile_size_m, spec.max_tiles_in_memory)
    assert nodes == 14143**2 and held < limits.MEMORY_LIMIT_BYTES


@pytest.mark.parametrize(("terrain", "fragment"), [
    (_terrain(size_m=[2e6, 200.0]), "terrain.size_m.0: Input should be less than or equal to 1000000"),
    (_terrain(size_m=[200.0, -1.0]), "terrain.size_m.1: Input should be greater than 0"),
    (_terrain(resolution_m=0.001), "terrain.resolution_m: Input should be greater than or equal to 0.01"),
    (_terrain(resolution_m=200.0), "terrain.resolution_m: Input should be less than or equal to 100"),
])
def test_terrain_bounds(terrain, fragment):
    assert fragment in _error(_data(terrain=terrain))


def test_a_fitted_terrain_too_wide_and_a_traverse_map_too_large_are_refused():
    text = _error(_data(lander={"x": 6e6, "z": 0.0}))
    assert "terrain: none given, and one fitted around" in text and "size_m.0" in text
    text = _error(_set(_data(), "rover_params.mapping.cell_m", 0.001))
    assert "rover_params.mapping.cell_m: the traverse map of the" in text and "cells" in text and "GiB" in text


# ---- names ----


@pytest.mark.parametrize("name", ["../escape", "a/b", "a\\b", "..", ".hidden", "x..y", "", "-x", "a b", "n" * 82])
def test_unsafe_scenario_names_are_refused(name):
    assert "is not a safe name" in _error(_data(name=name))


@pytest.mark.parametrize("name", ["crater_observation", "fig27.v2", "yes", "A-1", "n" * 81])
def test_safe_scenario_names_are_accepted(name):
    assert parse_scenario(_data(name=name)).name == name


@pytest.mark.parametrize("world", ["@w", "a b", "caf\u00e9", "w.1", "w" * 65])
def test_world_names_outside_letters_digits_dash_underscore_are_refused(world):
    with pytest.raises(ValueError, match="invalid world name"):
        check_world_name(world)


# ---- every error listed ----


def test_every_error_is_listed_on_its_own_line_with_its_path():
    data = _data(seed=-1, lander={"x": math.nan, "z": 0.0}, rovers=[{"x": 1.0, "zz": 2.0}],
                 rover_params={"perception": {"gyroscope_frequency": 500.0}})
    lines = _error(data).splitlines()
    assert lines[0] == "test.yaml: 4 problems:"
    assert sorted(line.strip().split(":")[0] for line in lines[1:]) == [
        "lander.x", "rover_params.perception.gyroscope_frequency", "rovers.0.zz", "seed"]
    assert "(did you mean 'z'?)" in lines[1]  # unknown fields first; the 'z' it explains is not listed again
    assert "more)" not in "\n".join(lines)


def test_every_cross_field_problem_is_listed():
    data = _data(terrain=_terrain(size_m=[50.0, 50.0]), rovers=[{"x": 70.0, "z": 0.0}, {"x": 0.0, "z": 90.0}],
                 mission=[{"x": 30.0, "z": 10.0}, {"x": 99.0, "z": 99.0, "kind": "crater"}])
    lines = _error(data).splitlines()
    assert lines[0] == "test.yaml: 6 problems:"
    for what in ("mission.1: crater goal", "lander (0.0, 0.0) lies outside", "rovers.0 (70.0, 0.0) lies outside",
                 "rovers.1 (0.0, 90.0) lies outside", "mission.1 (99.0, 99.0) lies outside",
                 "mission.0 (30.0, 10.0) lies outside"):
        assert any(line.strip().startswith(what) for line in lines[1:]), what


# ---- files ----


@pytest.mark.parametrize(("content", "fragment"), [
    (b"\xff\xfename: x\n", "cannot read scenario: not UTF-8 text (byte 0xff at offset 0)"),
    (b"name: [x\n", "cannot read scenario: not valid YAML at line 2"),
    (b"", "the scenario file is empty"),
    (b"# only a comment\n", "the scenario file is empty"),
    (b"- a\n- b\n", "expected a mapping at the top level, got list"),
    (b"just text\n", "expected a mapping at the top level, got str"),
    (b"name: x\nseed: 2024-13-45\n", "a YAML value cannot be read: month must be in 1..12"),
])
def test_unreadable_files_get_one_line_naming_the_file(tmp_path, content, fragment):
    path = tmp_path / "test.yaml"
    path.write_bytes(content)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    text = str(info.value)
    assert text.startswith(f"{path}: ") and fragment in text


def test_a_directory_or_a_missing_file_is_named(tmp_path):
    with pytest.raises(ScenarioError) as info:
        load_scenario(tmp_path)
    assert str(info.value) == f"{tmp_path}: cannot read scenario: Is a directory"
    with pytest.raises(ScenarioError, match=r"nope\.yaml: cannot read scenario: No such file"):
        load_scenario(tmp_path / "nope.yaml")


@pytest.mark.parametrize("path", sorted(SCENARIOS.glob("*.yaml")), ids=lambda p: p.name)
def test_shipped_scenarios_stay_within_the_bounds(path):
    scenario = load_scenario(path)
    spec = scenario.terrain_spec()
    _, held = limits.terrain_memory(spec.size_m, spec.resolution_m, spec.tile_size_m, spec.max_tiles_in_memory)
    assert held < limits.MEMORY_LIMIT_BYTES / 10


# ---- list lengths ----


@pytest.mark.parametrize(("path", "bound"), [
    ("craters", limits.MAX_CRATERS), ("mission", limits.MAX_GOALS), ("obstacles.rocks", limits.MAX_ROCKS),
    ("obstacles.walls", limits.MAX_WALLS), ("obstacles.rock_fields", limits.MAX_ROCK_FIELDS),
    ("obstacles.walls.0.points", limits.MAX_WALL_POINTS),
])
def test_every_list_is_bounded_and_refused_before_its_items_are_checked(path, bound):
    """One item too many is one line naming the list, not a line for each of its (here all bad) items."""
    items = [{"x": "?"}] * (bound + 1)
    data = _data(obstacles={"walls": [{"points": items}]}) if ".0." in path else _set(_data(), path, items)
    lines = _error(data).splitlines()
    assert lines == [f"test.yaml: {path}: List should have at most {bound} items after validation, not {bound + 1}"]


def test_rocks_listed_and_scattered_are_bounded_together():
    fields = [{"x": 9.0, "z": 9.0, "radius_m": 5.0, "count": limits.MAX_ROCKS // 2}] * 2
    assert len(parse_scenario(_data(obstacles={"rock_fields": fields})).obstacles.rock_fields) == 2
    text = _error(_data(obstacles={"rock_fields": fields, "rocks": [{"x": 9.0, "z": 9.0, "radius_m": 1.0}]}))
    assert text == "test.yaml: obstacles: 100,001 rocks in all (listed, and every rock field's count): at most 100,000"


# ---- a behaviour's form ----


@pytest.mark.parametrize("spec", ["default", "my-plugin.v2", "my_rovers.slow:Slow", "antigravity:Foo"])
def test_a_behaviour_of_a_usable_form_is_accepted(spec):
    assert parse_scenario(_data(behaviour=spec)).behaviour == spec


@pytest.mark.parametrize("spec", ["", "two words", "a:b:c", "pkg.:Class", "pkg:1Class", "../x:Y", "x" * 300])
def test_a_behaviour_of_no_usable_form_is_refused(spec):
    assert "is not a behaviour: give a name (default, straight, an installed plugin) or 'package.module:Class'" in \
        _error(_data(behaviour=spec))
