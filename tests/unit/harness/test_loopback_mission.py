"""Whole missions in one process, no router: the world, the lander and the rover agents through their pure handlers."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from harness.loopback import run_mission
from schemas.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"
MAX_SIM_TIME = 300.0


@pytest.fixture(scope="module")
def crater_observation():
    return load_scenario(SCENARIOS / "crater_observation.yaml")


@pytest.fixture(scope="module")
def five_rover_run(crater_observation):
    return run_mission(crater_observation, MAX_SIM_TIME)


@pytest.fixture(scope="module")
def ten_rover_run(crater_observation):
    return run_mission(crater_observation.with_overrides(rovers=10), MAX_SIM_TIME)


def test_crater_observation_completes_with_every_rover_on_the_rim(five_rover_run):
    report = five_rover_run.report()
    assert report.complete, report
    assert report.rovers_total == 5
    assert report.rovers_reached_final_goal == 5, report
    assert report.rover_collisions == 0 and report.obstacle_collisions == 0, report
    assert report.rovers_stuck == 0, report
    assert report.rejected_messages == 0, report
    assert 0 < report.mission_duration_s < MAX_SIM_TIME
    assert report.average_path_efficiency > 0.5
    assert all(status.state == "done" for status in five_rover_run.referee.status.values())


def test_same_scenario_gives_identical_runs(crater_observation, five_rover_run):
    again = run_mission(crater_observation, MAX_SIM_TIME)
    assert again.report() == five_rover_run.report()
    assert again.world_state() == five_rover_run.world_state()
    assert again.clock.tick == five_rover_run.clock.tick


def test_ten_rovers_complete_without_collisions(ten_rover_run):
    report = ten_rover_run.report()
    assert report.rovers_total == 10
    assert report.complete, report
    assert report.rover_collisions == 0 and report.obstacle_collisions == 0, report
    assert report.rovers_stuck == 0, report
    assert report.rovers_reached_final_goal >= 8, report


def test_ten_rovers_all_reach_the_rim(ten_rover_run):
    assert ten_rover_run.report().rovers_reached_final_goal == 10


def test_a_team_too_large_for_the_near_side_of_a_small_crater_meets_its_crest_spread_round(crater_observation):
    """Sixteen rovers to a 12 m crater: heading for the crest point nearest where they come from, the later ones
    were held off it behind the first (or slid into the bowl). With stations all round the crest each has its own
    stretch of it."""
    crater = crater_observation.craters[0]
    small = crater_observation.with_overrides(rovers=16).model_copy(
        update={"craters": [crater.model_copy(update={"radius_m": 12.0})]})
    world = run_mission(small, 400.0)
    report = world.report()
    assert report.complete and report.rovers_reached_final_goal == 16, report
    assert report.rover_collisions == 0, report
    off_crest = [abs(math.hypot(r.x - crater.x, r.z - crater.z) - 12.0) for r in world.world_state().rovers]
    assert max(off_crest) < 2.5, off_crest


def test_crater_photos_reach_the_lander_archive(tmp_path):
    import json

    from test_camera import decode_png

    from lander_agent.archive import PhotoArchive

    archive = PhotoArchive(tmp_path)
    world = run_mission(load_scenario(SCENARIOS / "crater_observation.yaml"), 300, archive)
    assert world.report().rovers_reached_final_goal == 5
    index = [json.loads(line) for line in (tmp_path / "index.jsonl").read_text().splitlines()]
    assert len(index) == 5 * 12 == len(archive.received)
    assert {e["rover"] for e in index} == {1, 2, 3, 4, 5}
    first = decode_png((tmp_path / index[0]["file"]).read_bytes())
    assert first.shape == (world.scenario.rover_params.camera.height, world.scenario.rover_params.camera.width, 3)


def test_photos_nobody_keeps_arrive_without_pixels_and_the_mission_is_the_same(tmp_path):
    """Without an archive on disk the photos carry an empty PNG: every one still reaches the lander by its label,
    and the report is the one of the mission whose photos were rendered and archived."""
    from lander_agent.archive import PhotoArchive
    from schemas import messages as m

    def photos_seen(into: list[bytes]):
        return lambda key, message: isinstance(message, m.Photo) and into.append(message.png) and False

    scenario = load_scenario(SCENARIOS / "crater_observation.yaml")
    kept, blank, pngs = PhotoArchive(None), [], []
    plain = run_mission(scenario, 300, kept, drop=photos_seen(blank))
    archived = PhotoArchive(tmp_path)
    rendered = run_mission(scenario, 300, archived, drop=photos_seen(pngs))
    assert len(blank) == len(pngs) == 5 * 12
    assert set(blank) == {b""} and all(png.startswith(b"\x89PNG") for png in pngs)
    assert kept.received == archived.received and len(kept.received) == 5 * 12
    assert plain.report() == rendered.report()
