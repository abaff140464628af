"""``lunarsim batch --in-process``: the reports and Table 2 of ``lunarsim batch --lockstep`` for the same seeds, as
real commands, and a worker that dies fails its run, not the batch."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from procs import REPO, two_rover_scenario

SEED = 21
RUNS = 2
MAX_SIM_TIME = "90"
TIMEOUT_S = 300

DIES = '''
import os, signal
from rover_agent.behaviour import DefaultBehaviour

class Dies(DefaultBehaviour):
    def decide(self, view):
        os.kill(os.getpid(), signal.SIGKILL)  # as the kernel's OOM killer would end the worker
'''


def _batch(scenario: Path, out: Path, *extra: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "deploy.cli", "batch", str(scenario), "--runs", str(RUNS), "--seed",
                           str(SEED), "--max-sim-time", MAX_SIM_TIME, "--out", str(out), *extra], cwd=REPO,
                          capture_output=True, text=True, timeout=TIMEOUT_S, env=env)


def _rows(stdout: str) -> list[str]:
    """Table 2's rows of figures (run 1, 2, ..., all runs)."""
    return [line for line in stdout.splitlines() if re.match(r"^│\s+(\d+|all runs) │", line)]


@pytest.mark.e2e
def test_an_in_process_batch_gives_the_reports_and_table_of_a_lockstep_batch(tmp_path):
    scenario = two_rover_scenario(tmp_path)
    fast = _batch(scenario, tmp_path / "in_process", "--in-process", "--jobs", "2")
    slow = _batch(scenario, tmp_path / "processes", "--lockstep", "--jobs", "2")
    assert fast.returncode == 0 and slow.returncode == 0, fast.stdout + fast.stderr + slow.stdout + slow.stderr
    assert "lockstep in process" in fast.stdout
    ours, theirs = (json.loads((tmp_path / name / "batch.json").read_text()) for name in ("in_process", "processes"))
    assert [{k: v for k, v in run.items() if k != "wall_time_s"} for run in ours["runs"]] == \
           [{k: v for k, v in run.items() if k != "wall_time_s"} for run in theirs["runs"]]
    assert ours["aggregate"] == theirs["aggregate"] and ours["lockstep"] is True
    assert ours["aggregate"]["runs"] == RUNS and ours["aggregate"]["photos_at_lander"] > 0
    assert ours["runs"][0]["map_corridor_mapped"] is not None  # the lander's map scored, as lunarsim run scores it
    assert _rows(fast.stdout) == _rows(slow.stdout) and len(_rows(fast.stdout)) == RUNS + 1


@pytest.mark.e2e
def test_a_run_that_kills_its_worker_fails_alone_and_the_batch_ends(tmp_path):
    (tmp_path / "dies.py").write_text(DIES)
    scenario = two_rover_scenario(tmp_path)
    scenario.write_text(scenario.read_text() + "behaviour: dies:Dies\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(tmp_path), os.environ.get("PYTHONPATH")]))}
    done = _batch(scenario, tmp_path / "out", "--in-process", "--jobs", "1", env=env)
    assert done.returncode == 1 and "Traceback" not in done.stdout + done.stderr, done.stdout + done.stderr
    summary = json.loads((tmp_path / "out" / "batch.json").read_text())
    assert [f["seed"] for f in summary["failed"]] == [SEED, SEED + 1]  # a new pool for the second run
    assert all("BrokenProcessPool" in f["error"] for f in summary["failed"]), summary["failed"]
    assert f"{RUNS} run(s) failed" in done.stdout
