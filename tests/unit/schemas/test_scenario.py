"""Scenario files, overrides, YAML dumps, rover parameter files and the report's editor profiles."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import pytest
import trimesh
import yaml

from scenarios.profiles import load_profile, profile_to_scenario, scenario_to_profile
from schemas.params import RoverParams, SpawnParams
from schemas.scenario import (
    Scenario,
    ScenarioError,
    dump_scenario,
    load_rover_params,
    load_scenario,
    parse_scenario,
)

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"
SCENARIO_FILES = sorted(SCENARIOS.glob("*.yaml"))
PROFILES = Path(__file__).resolve().parents[2] / "data" / "profiles"
"""The report's editor profiles (appendix C.3, figures 27-30), kept as test data."""

BASE = {
    "name": "tiny",
    "seed": 3,
    "lander": {"x": 0.0, "z": 0.0},
    "rovers": [{"x": 5.0, "z": 5.0, "heading_deg": 90.0}, {"x": -5.0, "z": 5.0}],
    "craters": [{"x": 0.0, "z": 60.0, "radius_m": 20.0}],
    "mission": [{"x": 30.0, "z": 10.0}, {"x": 2.0, "z": 58.0, "kind": "crater"}],
}


def _data(**changes) -> dict:
    data = copy.deepcopy(BASE)
    data.update(copy.deepcopy(changes))
    return data


def _error(data) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data, "test.yaml")
    return str(info.value)


# ---- scenario files ----


def test_there_are_scenario_files():
    assert {p.stem for p in SCENARIO_FILES} >= {"crater_observation", "crater_and_return", "maze",
                                                 "maze_crater_return"}


@pytest.mark.parametrize("path", SCENARIO_FILES, ids=lambda p: p.name)
def test_every_scenario_file_loads(path):
    scenario = load_scenario(path)
    assert isinstance(scenario, Scenario)
    assert scenario.name == path.stem
    assert scenario.rovers and scenario.mission
    for goal in scenario.mission:
        if goal.kind == "crater":
            assert scenario.crater_of(goal) is not None


@pytest.mark.parametrize("path", SCENARIO_FILES, ids=lambda p: p.name)
def test_scenario_file_dump_then_parse_is_equal(path):
    scenario = load_scenario(path)
    assert parse_scenario(yaml.safe_load(dump_scenario(scenario))) == scenario


def test_small_scenario_parses_with_defaults():
    s = parse_scenario(_data())
    assert s.rovers[1].heading_deg == 180.0
    assert s.lander.radius_m == 1.5
    assert s.rover_params == RoverParams()
    assert s.obstacles.rocks == [] and s.obstacles.walls == []
    assert s.craters[0].depth == pytest.approx(4.0) and s.craters[0].rim_height == pytest.approx(0.8)
    assert s.craters[0].outer_radius == pytest.approx(26.0)
    assert s.crater_of(s.mission[1]) == s.craters[0]
    assert [g.kind for g in s.mission] == ["waypoint", "crater"]


# ---- errors name the field ----


def test_typo_in_a_rover_field_names_its_path():
    text = _error(_data(rovers=[{"x": 1.0, "z": 1.0, "headng_deg": 90.0}]))
    assert text.startswith("test.yaml: ")
    assert "rovers.0.headng_deg" in text
    assert "\n" not in text


def test_typo_in_a_crater_field_names_the_misspelt_key():
    text = _error(_data(craters=[{"x": 0.0, "z": 60.0, "radius_mm": 20.0}]))
    assert "craters.0.radius_mm" in text
    assert "radius_m'" in text  # the field it probably meant
    assert "\n" not in text


@pytest.mark.parametrize(("changes", "fragment"), [
    ({"obstacles": {"rocks": [{"x": 1.0, "z": 1.0, "radius_m": -1.0}]}}, "obstacles.rocks.0.radius_m"),
    ({"rover_params": {"perception": {"perception_radius": "far"}}}, "rover_params.perception.perception_radius"),
    ({"rover_params": {"behaviour": {"rover_radious": 1.0}}}, "rover_params.behaviour.rover_radious"),
    ({"rovers": []}, "rovers"),
    ({"mission": []}, "mission"),
    ({"obstacles": {"walls": [{"points": [[0.0, 0.0]]}]}}, "obstacles.walls.0.points"),
    ({"terrain": {"origin": [0.0, 0.0], "size_m": [0.0, 10.0]}}, "terrain"),
    ({"spawn": {"spawn_spacing_x": 0}}, "spawn.spawn_spacing_x"),
])
def test_invalid_values_name_their_path(changes, fragment):
    assert fragment in _error(_data(**changes))


def test_crater_goal_outside_every_crater_is_rejected():
    text = _error(_data(mission=[{"x": 0.0, "z": 90.0, "kind": "crater"}]))
    assert "mission.0" in text and "lies in no crater" in text


def test_crater_goal_on_the_crest_is_accepted_and_outside_the_crest_rejected():
    assert parse_scenario(_data(mission=[{"x": 0.0, "z": 80.0, "kind": "crater"}]))
    assert "lies in no crater" in _error(_data(mission=[{"x": 0.0, "z": 80.5, "kind": "crater"}]))


def test_things_outside_a_declared_terrain_are_rejected():
    terrain = {"origin": [-50.0, -50.0], "size_m": [100.0, 200.0]}
    assert parse_scenario(_data(terrain=terrain)).terrain.contains(5.0, 5.0)
    text = _error(_data(terrain=terrain, rovers=[{"x": 60.0, "z": 0.0}]))
    assert "rovers.0 (60.0, 0.0) lies outside the terrain" in text


@pytest.mark.parametrize("data", [None, [1, 2], "name: x", 3])
def test_top_level_must_be_a_mapping(data):
    assert "expected a mapping at the top level" in _error(data)


def test_invalid_yaml_reports_the_line(tmp_path):
    path = tmp_path / "broken.yaml"
    path.write_text("name: broken\nseed: 1\nrovers:\n  - x: 1\n   z: 2\n")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    text = str(info.value)
    assert str(path) in text and "not valid YAML" in text
    assert "line 5" in text


def test_scenario_error_names_the_file(tmp_path):
    path = tmp_path / "typo.yaml"
    data = _data(rovers=[{"x": 1.0, "z": 1.0, "headng_deg": 90.0}])
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ScenarioError, match=r"typo\.yaml: rovers\.0\.headng_deg: "):
        load_scenario(path)


def test_missing_scenario_file(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read scenario"):
        load_scenario(tmp_path / "nope.yaml")


# ---- overrides ----


def test_seed_override_keeps_everything_else():
    s = parse_scenario(_data())
    t = s.with_overrides(seed=99)
    assert t.seed == 99 and s.seed == 3
    assert t.model_copy(update={"seed": 3}) == s
    assert s.with_overrides() == s


def test_rovers_override_gives_the_table_3_formation_for_five():
    s = load_scenario(SCENARIOS / "crater_observation.yaml").with_overrides(seed=8, rovers=5)
    assert s.seed == 8
    assert [(r.x, r.z) for r in s.rovers] == [(-510, 100), (-500, 100), (-490, 100), (-510, 90), (-500, 90)]
    assert all(r.heading_deg == 180.0 for r in s.rovers)


@pytest.mark.parametrize("count", [1, 2, 3, 4, 7, 10, 16, 17])
def test_rovers_override_gives_n_rovers_in_rows_of_ceil_sqrt_n(count):
    s = parse_scenario(_data()).with_overrides(rovers=count)
    assert len(s.rovers) == count
    per_row = math.ceil(math.sqrt(count))
    for i, r in enumerate(s.rovers):
        assert r.x == pytest.approx(-510.0 + 10.0 * (i % per_row))
        assert r.z == pytest.approx(100.0 - 10.0 * (i // per_row))
    assert len({(r.x, r.z) for r in s.rovers}) == count
    assert s.craters == parse_scenario(_data()).craters and s.mission == parse_scenario(_data()).mission


def test_rovers_override_uses_the_scenarios_spawn_parameters():
    spawn = {"start_spawn_x": 0.0, "start_spawn_z": 0.0, "spawn_spacing_x": 4.0, "spawn_spacing_z": 6.0,
             "spawn_group_orientation": 0.0, "spawn_individual_orientation": 45.0}
    s = parse_scenario(_data(spawn=spawn)).with_overrides(rovers=4)
    positions = [c for r in s.rovers for c in (r.x, r.z)]
    # rows run along +z (orientation 0), the second row lies to the group's right (+x)
    assert positions == pytest.approx([0.0, 0.0, 0.0, 4.0, 6.0, 0.0, 6.0, 4.0])
    assert {r.heading_deg for r in s.rovers} == {45.0}


@pytest.mark.parametrize("count", [0, -3])
def test_rovers_override_must_be_positive(count):
    with pytest.raises(ScenarioError, match="--rovers must be at least 1"):
        parse_scenario(_data()).with_overrides(rovers=count)


def test_rovers_override_outside_the_terrain_is_a_scenario_error():
    s = parse_scenario(_data(terrain={"origin": [-50.0, -50.0], "size_m": [100.0, 200.0]}))
    with pytest.raises(ScenarioError, match="outside the terrain"):
        s.with_overrides(rovers=3)


# ---- dump ----


def test_dump_then_parse_is_equal_for_a_scenario_using_every_section():
    data = _data(
        terrain={"origin": [-100.0, -100.0], "size_m": [200.0, 250.0], "resolution_m": 0.5, "roughness_m": 0.3},
        lander={"x": 0.0, "z": 0.0, "radius_m": 2.0},
        craters=[{"x": 0.0, "z": 60.0, "radius_m": 20.0, "depth_m": 3.0, "rim_height_m": 1.0, "rim_width": 0.5}],
        obstacles={"rocks": [{"x": 10.0, "z": 10.0, "radius_m": 0.75}],
                   "walls": [{"points": [[0.0, 20.0], [10.0, 25.0], [20.0, 20.0]], "thickness_m": 1.0}]},
        rover_params={"navigation": {"strict_line_of_sight": True}, "perception": {"perception_radius": 12.5},
                      "behaviour": {"rover_radius": 0.4}},
        spawn={"rover_count": 4, "start_spawn_x": 1.0},
        behaviour="default",
    )
    s = parse_scenario(data)
    text = dump_scenario(s)
    assert text.startswith("name: tiny\nseed: 3\n")
    assert parse_scenario(yaml.safe_load(text)) == s


def test_dump_leaves_out_defaults():
    text = dump_scenario(parse_scenario(_data()))
    assert "rover_params" not in text and "obstacles" not in text and "depth_m" not in text
    assert yaml.safe_load(text)["rovers"][1] == {"x": -5.0, "z": 5.0}


def test_dump_quotes_names_that_yaml_would_misread():
    s = parse_scenario(_data(name="yes"))
    assert parse_scenario(yaml.safe_load(dump_scenario(s))).name == "yes"


# ---- rover parameter files ----


def test_load_rover_params_from_a_scenario_file(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(_data(rover_params={"perception": {"perception_radius": 15.0}})))
    params = load_rover_params(path)
    assert params.perception.perception_radius == 15.0
    assert params.navigation == RoverParams().navigation


def test_load_rover_params_from_a_scenario_file_without_params(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(_data()))
    assert load_rover_params(path) == RoverParams()


@pytest.mark.parametrize("path", SCENARIO_FILES, ids=lambda p: p.name)
def test_load_rover_params_from_the_shipped_scenarios(path):
    assert load_rover_params(path) == load_scenario(path).rover_params


def test_load_rover_params_from_a_bare_params_file(tmp_path):
    path = tmp_path / "p.yaml"
    path.write_text("behaviour:\n  rover_radius: 0.7\nnavigation:\n  strict_line_of_sight: true\n")
    params = load_rover_params(path)
    assert params.behaviour.rover_radius == 0.7
    assert params.navigation.strict_line_of_sight is True
    assert params.perception == RoverParams().perception


def test_load_rover_params_empty_file_and_none_give_defaults(tmp_path):
    path = tmp_path / "empty.yaml"
    path.write_text("")
    assert load_rover_params(path) == RoverParams()
    assert load_rover_params(None) == RoverParams()


def test_load_rover_params_missing_file(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read rover parameters"):
        load_rover_params(tmp_path / "missing.yaml")


def test_load_rover_params_invalid_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("behaviour:\n  rover_radius: -1\n")
    with pytest.raises(ScenarioError, match=r"bad\.yaml: behaviour\.rover_radius"):
        load_rover_params(bad)
    broken = tmp_path / "broken.yaml"
    broken.write_text("behaviour: [1\n")
    with pytest.raises(ScenarioError, match="cannot read rover parameters"):
        load_rover_params(broken)


# ---- profiles (appendix C.3) ----

EXPECTED_PROFILES = {
    "fig27_crater_observation": ("crater_observation", ["crater"]),
    "fig28_crater_and_return": ("crater_and_return", ["crater", "waypoint"]),
    "fig29_maze": ("maze", ["waypoint"]),
    "fig30_maze_crater_return": ("maze_crater_return", ["waypoint", "crater", "waypoint"]),
}


def _profile(stem: str) -> Path:
    return PROFILES / f"{stem}.json"


@pytest.mark.parametrize("stem", sorted(EXPECTED_PROFILES))
def test_load_profile_counts_and_headings(stem):
    s = load_profile(_profile(stem))
    _, kinds = EXPECTED_PROFILES[stem]
    assert s.name == stem
    assert len(s.rovers) == 5
    assert len(s.craters) == 1
    assert [g.kind for g in s.mission] == kinds
    assert sum(g.kind == "crater" for g in s.mission) == kinds.count("crater")
    for r in s.rovers:
        assert r.heading_deg == pytest.approx(180.0, abs=0.5)
    assert s.obstacles.rocks == [] and s.terrain is None


def test_every_profile_file_is_covered():
    _profile("fig27_crater_observation")
    assert {p.stem for p in PROFILES.glob("*.json")} == set(EXPECTED_PROFILES)


@pytest.mark.parametrize("stem", sorted(EXPECTED_PROFILES))
def test_shipped_scenario_keeps_the_profiles_layout(stem):
    profile = load_profile(_profile(stem))
    scenario = load_scenario(SCENARIOS / f"{EXPECTED_PROFILES[stem][0]}.yaml")
    assert (scenario.lander.x, scenario.lander.z) == (profile.lander.x, profile.lander.z)
    assert scenario.rovers == profile.rovers
    assert scenario.craters == profile.craters
    assert scenario.mission == profile.mission


def test_load_profile_name_override():
    assert load_profile(_profile("fig27_crater_observation"), name="mine").name == "mine"


def _assert_same_layout(a: Scenario, b: Scenario):
    assert (a.lander.x, a.lander.z) == (b.lander.x, b.lander.z)
    assert [(r.x, r.z) for r in a.rovers] == [(r.x, r.z) for r in b.rovers]
    for ra, rb in zip(a.rovers, b.rovers, strict=True):
        assert math.isclose(((ra.heading_deg - rb.heading_deg + 180) % 360) - 180, 0.0, abs_tol=1e-3)
    assert [(c.x, c.z, c.radius_m) for c in a.craters] == [(c.x, c.z, c.radius_m) for c in b.craters]
    assert [(g.x, g.z, g.kind) for g in a.mission] == [(g.x, g.z, g.kind) for g in b.mission]


@pytest.mark.parametrize("path", SCENARIO_FILES, ids=lambda p: p.name)
def test_scenario_to_profile_and_back(path):
    s = load_scenario(path)
    back = profile_to_scenario(json.loads(json.dumps(scenario_to_profile(s))), s.name, seed=s.seed)
    _assert_same_layout(s, back)
    assert back.name == s.name and back.seed == s.seed


@pytest.mark.parametrize("heading", [0.0, 45.0, 90.0, 179.5, 180.0, 270.0, 315.25, -90.0])
def test_profile_round_trip_of_headings(heading):
    s = parse_scenario(_data(rovers=[{"x": 1.5, "z": -2.25, "heading_deg": heading}]))
    back = profile_to_scenario(scenario_to_profile(s), "h")
    _assert_same_layout(s, back)
    assert 0.0 <= back.rovers[0].heading_deg < 360.0


@pytest.mark.parametrize("stem", sorted(EXPECTED_PROFILES))
def test_profile_file_round_trip(stem):
    s = load_profile(_profile(stem))
    _assert_same_layout(s, profile_to_scenario(scenario_to_profile(s), stem))


def test_profile_errors(tmp_path):
    with pytest.raises(ScenarioError, match="cannot read profile"):
        load_profile(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text('{\n  "landerDataObject": {\n  oops\n}')
    with pytest.raises(ScenarioError, match="not valid JSON at line 3"):
        load_profile(bad)
    bad.write_text("[1, 2]")
    with pytest.raises(ScenarioError, match="a profile is a JSON object"):
        load_profile(bad)
    bad.write_text(json.dumps({"landerDataObject": {"position": {"x": 0, "z": 0}}}))
    with pytest.raises(ScenarioError, match="missing 'roverDataObjects'"):
        load_profile(bad)
    bad.write_text(json.dumps({"landerDataObject": {"rotation": {}}, "roverDataObjects": []}))
    with pytest.raises(ScenarioError, match="landerDataObject: missing or malformed position"):
        load_profile(bad)


def _editor_profile() -> dict:
    return scenario_to_profile(parse_scenario(_data()))


@pytest.mark.parametrize("mutation", ["crater_radius", "goal_index", "null_rovers"])
def test_malformed_profile_values_are_scenario_errors(mutation):
    profile = _editor_profile()
    if mutation == "crater_radius":
        profile["craterDataObjects"][0]["radius"] = "big"
    elif mutation == "goal_index":
        profile["missionDataObjects"][0]["index"] = "first"
    else:
        profile["roverDataObjects"] = None
    with pytest.raises(ScenarioError):
        profile_to_scenario(profile, "broken")


def test_spawn_params_formation_default_is_table_3():
    assert SpawnParams().formation(2) == [(-510.0, 100.0, 180.0), (-500.0, 100.0, 180.0)]


def test_a_relative_mesh_path_is_resolved_against_the_scenario_file(tmp_path):
    folder = tmp_path / "site"
    folder.mkdir()
    data = yaml.safe_load((SCENARIOS / "crater_observation.yaml").read_text())
    data["terrain"] = {"origin": [-700, -131], "size_m": [270, 291], "mesh": "ground.glb"}
    (folder / "s.yaml").write_text(yaml.safe_dump(data))
    trimesh.creation.box(extents=(1.0, 1.0, 1.0)).export(folder / "ground.glb")
    scenario = load_scenario(folder / "s.yaml")
    assert scenario.terrain.mesh == str((folder / "ground.glb").resolve())
