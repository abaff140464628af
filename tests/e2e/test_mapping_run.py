"""The traverse map across real processes: ``lunarsim run`` (router, world, lander, rover agents, recorder) writes
map.npz and map.png, scores them in report.json, and ``lunarsim report`` scores the recorded map the same."""

from __future__ import annotations

import json

import numpy as np
import pytest
from procs import SCENARIOS, free_port, lunarsim, run_cli_mission

from lander_agent import mapping
from schemas import codec
from schemas import messages as m
from sessions.format import read_samples

pytestmark = pytest.mark.e2e


def test_a_lockstep_run_maps_the_maze_and_the_report_scores_the_map(tmp_path):
    out = tmp_path / "run"
    report, stdout = run_cli_mission(out, str(SCENARIOS / "maze.yaml"), "--lockstep", "--rovers", "2",
                                     "--max-sim-time", "60", "--port", str(free_port()), "--quiet")
    _, classes = mapping.load(out / "map.npz")
    assert (out / "map.png").read_bytes().startswith(b"\x89PNG")
    assert np.count_nonzero(classes == mapping.OBSTACLE) > 50 and np.count_nonzero(classes == mapping.ROVER) == 2
    # Two rovers, one simulated minute, into the maze (in-process the same run measured 0.36 / 0.60 / 0.99):
    # a third of the corridor and over half of its wall and rock cells, with very few obstacles misplaced.
    assert report["map_corridor_mapped"] > 0.25, report
    assert report["map_obstacles_found"] > 0.4 and report["map_obstacle_precision"] > 0.9, report
    assert "traverse map" in stdout

    maps = [codec.decode(m.LanderMap, s.payload) for s in read_samples(out / "session.mcap")
            if s.key == "lunar/default/lander/map"]
    assert len(maps) >= 60 / 5 and np.array_equal(mapping.from_message(maps[-1])[1], classes)
    recomputed = tmp_path / "from_recording.json"
    proc = lunarsim("report", str(out / "session.mcap"), "--json", str(recomputed), "--no-plot")
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert json.loads(recomputed.read_text()) == {**report, "wall_time_s": None}
