"""The in-process loopback mission (``harness.loopback``) that the behaviour suite runs hundreds of times gives the
same report as ``lunarsim run --lockstep`` of the same scenario and seed through real processes and a router: the
suite's figures are the product's, not a model of it."""

from __future__ import annotations

import msgspec
import pytest
from procs import SCENARIOS, free_port, run_cli_mission

from harness.loopback import run_mission
from scenarios.generator import generate
from schemas.scenario import dump_scenario, load_scenario

pytestmark = pytest.mark.e2e
LAUNCHER_ONLY = {"wall_time_s", "map_corridor_mapped", "map_obstacles_found", "map_obstacle_precision"}
"""Fields only the launcher fills: wall time, and the scores of the lander's map file it reads."""


def _compare(tmp_path, scenario_file, max_sim_time: float) -> dict:
    scenario = load_scenario(scenario_file)
    in_process = msgspec.to_builtins(run_mission(scenario, max_sim_time).report())
    processes, _ = run_cli_mission(tmp_path / "run", str(scenario_file), "--lockstep", "--quiet", "--no-record",
                                   "--max-sim-time", str(max_sim_time), "--port", str(free_port()))
    for field in LAUNCHER_ONLY:
        in_process.pop(field)
        processes.pop(field)
    assert in_process == processes
    return in_process


def test_the_shipped_crater_mission_with_its_noise(tmp_path):
    report = _compare(tmp_path, SCENARIOS / "crater_observation.yaml", 300.0)
    assert report["complete"] and report["rovers_total"] == 5


def test_a_generated_mission_with_obstacles_noise_and_a_rover_that_never_hears_the_lander(tmp_path):
    made = next(g for g in map(generate, range(300)) if g.out_of_range and g.classes["density"] != "none"
                and g.classes["noise"] != "none" and len(g.scenario.rovers) <= 8)
    path = tmp_path / "generated.yaml"
    path.write_text(dump_scenario(made.scenario))
    _compare(tmp_path, path, 400.0)


def test_a_team_of_twelve_whose_inputs_the_world_takes_in_key_order(tmp_path):
    """rover/10 sorts before rover/2: the world takes a tick's inputs by key, and moves draw noise in that order.
    Every tick shows it, so the first minute of the mission does, in a quarter of the whole one's time."""
    scenario = load_scenario(SCENARIOS / "crater_and_return.yaml").with_overrides(rovers=12, seed=3)
    path = tmp_path / "twelve.yaml"
    path.write_text(dump_scenario(scenario))
    report = _compare(tmp_path, path, 60.0)
    assert report["rovers_total"] == 12 and report["total_distance_covered_m"] > 12 * 30


def test_a_daisy_chain_with_the_shipped_noise_whose_relays_walk_on_once_released(tmp_path):
    """Goal reports, the lander's answers and the relays' moves chase each other down the chain here."""
    report = _compare(tmp_path, SCENARIOS / "daisy_chain.yaml", 400.0)
    assert report["complete"] and report["rovers_holding_relay_spots"] == 0
