"""The scale benchmark's process meter: a group's CPU and memory include the processes under it (the world's
camera process), and a helper process that ends between two marks does not break the measurement."""

from __future__ import annotations

import subprocess
import sys

from procs import REPO

sys.path.insert(0, str(REPO / "benchmarks"))  # benchmarks/ is not a package: its scripts import each other so

from scale_observe import ProcessMeter, with_descendants

PARENT = ("import subprocess, sys, time; child = subprocess.Popen([sys.executable, '-c', 'import time; "
          "time.sleep(60)']); print(child.pid, flush=True); time.sleep(60)")


def test_a_group_counts_the_processes_under_it() -> None:
    parent = subprocess.Popen([sys.executable, "-c", PARENT], stdout=subprocess.PIPE, text=True)
    try:
        child = int(parent.stdout.readline())
        assert with_descendants(parent.pid) == [parent.pid, child]
    finally:
        parent.kill()
        parent.wait()


def test_a_process_that_ends_between_marks_counts_for_nothing() -> None:
    short = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    long = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        meter = ProcessMeter({"world": [long.pid, short.pid]})
        meter.mark()
        short.kill()
        short.wait()
        meter.mark()
        assert meter.cpu()["world"] >= 0.0
        memory = meter.memory()["world"]
        assert memory["rss_mib"] > 0.0 and memory["pss_mib"] > 0.0
    finally:
        long.kill()
        long.wait()


def test_a_repeated_measurement_reports_its_median_run_and_every_factor() -> None:
    from scale import median_run

    runs = [{"real_time_factor": 18.0, "n": 1}, {"error": "world died"}, {"real_time_factor": 21.0, "n": 3},
            {"real_time_factor": 16.0, "n": 4}]
    row = median_run(runs)
    assert row["n"] == 1 and row["repeats"] == [18.0, None, 21.0, 16.0]  # the middle of three that finished
    assert median_run([{"error": "a"}, {"error": "b"}]) == {"error": "a"}
