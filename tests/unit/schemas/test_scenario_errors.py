"""Error lines: an unknown field gets the field it probably meant, a user's value is repeated cut short, and a
list of many problems is cut short too."""

from __future__ import annotations

import copy

import pytest

from schemas import scenario_limits as limits
from schemas.scenario import ScenarioError, load_rover_params, parse_scenario

BASE = {
    "name": "tiny",
    "lander": {"x": 0.0, "z": 0.0},
    "rovers": [{"x": 5.0, "z": 5.0}],
    "craters": [{"x": 0.0, "z": 60.0, "radius_m": 20.0}],
    "mission": [{"x": 30.0, "z": 10.0}],
}


def _data(**changes) -> dict:
    return {**copy.deepcopy(BASE), **copy.deepcopy(changes)}


def _error(data: object) -> str:
    with pytest.raises(ScenarioError) as info:
        parse_scenario(data, "test.yaml")
    return str(info.value)


# ---- did you mean ----


@pytest.mark.parametrize(("changes", "line"), [
    ({"sed": 4}, "sed: unknown field (did you mean 'seed'?)"),
    ({"craters": [{"x": 0.0, "z": 60.0, "radus_m": 20.0}]}, "craters.0.radus_m: unknown field (did you mean "
                                                            "'radius_m'?)"),
    ({"rover_params": {"navigation": {"slip_sdt": 0.1}}}, "rover_params.navigation.slip_sdt: unknown field (did "
                                                          "you mean 'slip_std'?)"),
    ({"sun": {"latitude_deg": -85.0, "hours_afternoon": 2.0}}, "sun.hours_afternoon: unknown field (did you mean "
                                                               "'hours_after_noon'?)"),
    ({"obstacles": {"rock_fields": [{"x": 0.0, "z": 0.0, "radius_m": 5.0, "count": 1, "max_radius": 1.0}]}},
     "obstacles.rock_fields.0.max_radius: unknown field (did you mean 'max_radius_m'?)"),
    ({"banana": 1}, "banana: unknown field"),
])
def test_every_misspelt_field_gets_the_one_it_probably_meant(changes, line):
    """Any field at its level, not only a required one left missing, is a candidate."""
    assert _error(_data(**changes)) == f"test.yaml: {line}"


def test_a_misspelt_field_of_a_parameter_file_gets_the_one_it_probably_meant(tmp_path):
    path = tmp_path / "params.yaml"
    path.write_text("navigation: {slip_sdt: 0.1}\n")
    with pytest.raises(ScenarioError, match=r"navigation\.slip_sdt: unknown field \(did you mean 'slip_std'\?\)"):
        load_rover_params(path)


# ---- what is repeated ----


def test_a_10_mb_name_is_named_by_its_first_200_characters():
    text = _error(_data(name="x" * 10_000_000))
    assert text.startswith("test.yaml: name: 'xxxx") and "x" * 199 + "..." in text
    assert len(text) < 400


def test_a_10_mb_unknown_field_is_cut_short_with_no_guess():
    text = _error(_data(**{"s" * 10_000_000: 1}))
    assert text == f"test.yaml: {'s' * limits.MAX_ECHO_CHARS}...: unknown field"


def test_a_hundred_thousand_problems_list_fifty_and_count_the_rest():
    lines = _error(_data(obstacles={"rocks": [{"x": "?", "z": 0.0, "radius_m": 1.0}] * 100_000})).splitlines()
    assert lines[0] == "test.yaml: 100,000 problems:" and len(lines) == 52
    assert lines[-1] == "  ... and 99,950 more"
