"""Many rover agents in one process (``lunarsim rover --ids``): the world sees them exactly as it sees
separate processes, so a lockstep run gives the same report either way."""

from __future__ import annotations

import json

import pytest
import yaml
from procs import SCENARIOS, module, stop, wait_for

from rover_agent.identity import MAX_AGENTS_PER_PROCESS, parse_ids


@pytest.mark.parametrize(("text", "ids"), [("1-3", [1, 2, 3]), ("4", [4]), ("1,3,7-9", [1, 3, 7, 8, 9]),
                                           (" 2 , 5-6", [2, 5, 6])])
def test_parse_ids_reads_ids_and_ranges(text, ids):
    assert parse_ids(text) == ids


@pytest.mark.parametrize(("text", "problem"), [("0-3", "from 1"), ("5-2", "low <= high"), ("a-b", "not an id"),
                                               ("1-3,2", "twice"), ("", "not an id"),
                                               (f"1-{MAX_AGENTS_PER_PROCESS + 1}", "from 1 to 1000"),
                                               ("1-99999999999999", "from 1 to 1000"), ("1001", "from 1 to 1000")])
def test_parse_ids_names_what_is_wrong(text, problem):
    with pytest.raises(ValueError, match=problem):
        parse_ids(text)


def _lockstep_report(tmp_path, name: str, router: str, rover_args: list[list[str]]) -> dict:
    data = yaml.safe_load((SCENARIOS / "crater_observation.yaml").read_text())
    data["rovers"] = data["rovers"][:3]
    scenario = tmp_path / "three.yaml"
    scenario.write_text(yaml.safe_dump(data))
    report = tmp_path / f"{name}.json"
    common = ["--world", name, "--connect", router]
    world = module("world_service", str(scenario), *common, "--lockstep", "--max-sim-time", "25",
                   "--exit-when-done", "--report", str(report))
    lander = module("lander_agent", str(scenario), *common)
    rovers = [module("rover_agent", *args, "--params", str(scenario), *common) for args in rover_args]
    try:
        wait_for(lambda: world.poll() is not None, 180, f"the {name} run to finish")
        assert world.returncode == 0, world.stdout.read()
    finally:
        stop(world, lander, *rovers)
    return json.loads(report.read_text())


@pytest.mark.e2e
def test_agents_sharing_a_process_run_the_mission_exactly_as_separate_processes(router, tmp_path):
    apart = _lockstep_report(tmp_path, "apart", router, [["--id", "1"], ["--id", "2"], ["--id", "3"]])
    shared = _lockstep_report(tmp_path, "shared", router, [["--ids", "1-3"]])
    assert apart["total_distance_covered_m"] > 10  # they really drove
    for report in (apart, shared):
        report.pop("wall_time_s")
    assert shared == apart
