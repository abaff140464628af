"""End to end: ``lunarsim run scenarios/polar_night_edge.yaml --lockstep`` over a real router with real
processes, once with the default behaviour and once with ``sun_ignoring``: the first rover charges in sunlight
and crosses the crater's shadow, the second runs empty in it and freezes there."""

from __future__ import annotations

import pytest
import yaml
from procs import SCENARIOS, free_port, run_cli_mission

pytestmark = pytest.mark.e2e


def _run(tmp_path, name: str, behaviour: str) -> dict:
    data = yaml.safe_load((SCENARIOS / "polar_night_edge.yaml").read_text())
    data["behaviour"] = behaviour
    scenario = tmp_path / f"{name}.yaml"
    scenario.write_text(yaml.safe_dump(data))
    report, _ = run_cli_mission(tmp_path / name, str(scenario), "--lockstep", "--max-sim-time", "70",
                                "--port", str(free_port()), "--quiet", "--no-record", timeout=180)
    return report


def test_a_rover_that_ignores_sunlight_runs_out_of_power_and_the_default_one_does_not(tmp_path):
    default = _run(tmp_path, "default", "default")
    blind = _run(tmp_path, "blind", "sun_ignoring")
    assert default["rovers_reached_final_goal"] == 1 and default["complete"] is True, default
    assert default["power_shutdowns"] == 0 and default["cold_shutdowns"] == 0
    assert blind["rovers_reached_final_goal"] == 0 and blind["complete"] is False, blind
    assert blind["power_shutdowns"] == 1 and blind["cold_shutdowns"] == 1
    assert blind["total_distance_covered_m"] < 0.7 * default["total_distance_covered_m"]  # stopped in the shadow
    for report in (default, blind):
        assert report["energy_used_wh"] > 0
    assert 0 < default["power_budget_efficiency"] <= 1
    assert blind["power_budget_efficiency"] == 0.0, "a rover that died in the shadow bought the mission nothing"
