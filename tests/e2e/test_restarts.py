"""Processes killed mid-mission and started again as the docs say (``docs/concepts/faults.md``): the world, the lander
and the rover agents. A restart resumes, or the report says what was lost; it never fakes a result.

Each test runs a two-rover crater mission over a real router on loopback; they run with ``pytest -m faults``.
"""

from __future__ import annotations

import logging

import pytest
from procs import wait_for
from test_faults import STALL_S, Mission, Watch, _reached_all, _scenario

from bus import snapshot
from lander_agent import mapping
from lander_agent.resume import FILE_NAME

pytestmark = pytest.mark.faults


def _world_args(mission: Mission, *extra: str) -> list[str]:
    return [str(mission.scenario), "--time-scale", "5", "--exit-when-done", "--report", str(mission.report_file),
            "--max-sim-time", "600", "--state", str(mission.tmp / "state" / "world.state"), *extra]


def _start(mission: Mission, rovers: int) -> None:
    mission.start("world", "world_service", *_world_args(mission))
    mission.start("lander", "lander_agent", str(mission.scenario), "--state", str(mission.tmp / "state" / "lander"),
                  "--map-out", str(mission.tmp / "map"))
    for rid in range(1, rovers + 1):
        mission.start_rover(rid, f"rover{rid}", "--state", str(mission.state_file(rid)))


def _known_cells(traverse: mapping.TraverseMap) -> int:
    return int((traverse.classes() != 0).sum())


def test_a_killed_world_started_again_resumes_its_run_and_reports_it(router, tmp_path):
    mission = Mission(tmp_path, router, _scenario(tmp_path, rovers=2), "world-restart")
    watch = Watch(router, mission.keys)
    try:
        _start(mission, rovers=2)
        wait_for(lambda: watch.under_way(12), 90, "both rovers 12 m out")
        before = watch.state.stamp
        mission.kill("world")
        mission.start("world", "world_service", *_world_args(mission))
        report = mission.finish(240)
        assert "resumed run" in mission.log("world"), mission.log("world")
        assert report["world_resumes"] == 1 and report["rovers_lost"] == 0, report
        assert report["mission_duration_s"] > before
        _reached_all(report, 2)
        assert not (tmp_path / "state" / "world.state").exists()  # the mission is over: nothing to resume
    finally:
        watch.close()
        mission.stop()


def test_a_world_begun_anew_under_running_agents_leaves_them_lost_and_the_report_says_so(router, tmp_path):
    mission = Mission(tmp_path, router, _scenario(tmp_path, rovers=2, stall_after_s=STALL_S), "world-anew")
    watch = Watch(router, mission.keys)
    try:
        _start(mission, rovers=2)
        wait_for(lambda: watch.under_way(12), 90, "both rovers 12 m out")
        mission.kill("world")
        mission.start("world", "world_service", *_world_args(mission, "--fresh"))
        report = mission.finish(240)
        for rid in (1, 2):
            assert "the world began a new run" in mission.log(f"rover{rid}"), mission.log(f"rover{rid}")
        assert report["rovers_lost"] == 2 and report["rovers_reached_final_goal"] == 0, report
        assert report["world_resumes"] == 0 and report["rovers_stuck"] == 2, report
    finally:
        watch.close()
        mission.stop()


def test_a_killed_lander_started_again_keeps_its_map_and_its_plan(router, tmp_path):
    mission = Mission(tmp_path, router, _scenario(tmp_path, rovers=2), "lander-restart")
    watch = Watch(router, mission.keys)
    try:
        _start(mission, rovers=2)
        saved = tmp_path / "state" / "lander" / FILE_NAME

        def saved_cells() -> int:  # how much of the map the lander's state holds (written whole, then renamed)
            state = snapshot.load(saved, logging.getLogger())
            return 0 if state is None else _known_cells(state.map)

        wait_for(lambda: watch.under_way(20) and saved_cells() > 500, 90,
                 "both rovers 20 m out, and the lander's saved map holding what they reported")
        mission.kill("lander")
        before = saved_cells()
        mission.start("lander", "lander_agent", str(mission.scenario), "--state", str(tmp_path / "state" / "lander"),
                      "--map-out", str(tmp_path / "map"))
        report = mission.finish(240)
        assert "lander: resumed its plan and map" in mission.log("lander"), mission.log("lander")
        _reached_all(report, 2)
        assert report["lander_map_lost"] is False, report
        assert before > 500
        wait_for(lambda: int((mapping.load(tmp_path / "map" / mapping.NPZ_FILE)[1] != 0).sum()) > before, 30,
                 "the final map to hold what was mapped before the kill, and more")
    finally:
        watch.close()
        mission.stop()
