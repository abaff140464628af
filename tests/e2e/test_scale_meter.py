"""The scale benchmark's process meter: a group's CPU and memory include the processes under it (the world's
camera process), and a helper process that ends between two marks does not break the measurement; the
figures the benchmark derives from what it measured; and the counts its shared series tries."""

from __future__ import annotations

import subprocess
import sys

from procs import REPO

# benchmarks/ is not a package (its scripts import each other by name); last on the path, so that its ros2_bridge.py
# does not hide the ros2_bridge package from the tests that run after this one in the same worker
sys.path.append(str(REPO / "benchmarks"))

from proc_meter import ProcessMeter, with_descendants
from scale_report import highest_holding

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


CHILD = """
import sys, time
def burn(seconds):
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass
burn(0.5)  # before the first mark: not to be counted
print("ready", flush=True)
sys.stdin.readline()
burn(0.5)
"""
PARENT_OF_BUSY = f"""
import subprocess, sys
child = subprocess.Popen([sys.executable, "-c", {CHILD!r}], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
child.stdout.readline()
print(child.pid, flush=True)
child.stdin.write(sys.stdin.readline())
child.stdin.flush()
child.wait()
print("reaped", flush=True)
sys.stdin.readline()
"""


def test_a_child_that_ends_and_is_waited_for_within_its_group_counts_for_what_it_used_between_marks() -> None:
    """The world's camera process renders a lockstep mission's photos and ends with the mission."""
    parent = subprocess.Popen([sys.executable, "-c", PARENT_OF_BUSY], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                              text=True)
    try:
        child = int(parent.stdout.readline())
        meter = ProcessMeter({"world": with_descendants(parent.pid)})
        assert meter.groups["world"] == [parent.pid, child]
        meter.mark()
        parent.stdin.write("go\n")
        parent.stdin.flush()
        assert parent.stdout.readline() == "reaped\n"
        meter.mark()
        used = meter.cpu()["world"] * (meter._marks[1].wall - meter._marks[0].wall)
        assert 0.45 <= used <= 0.75  # its second half second, not the first
    finally:
        parent.kill()
        parent.wait()


def test_a_repeated_measurement_reports_its_median_run_and_every_factor() -> None:
    from scale_report import median_run

    runs = [{"real_time_factor": 18.0, "n": 1}, {"error": "world died"}, {"real_time_factor": 21.0, "n": 3},
            {"real_time_factor": 16.0, "n": 4}]
    row = median_run(runs)
    assert row["n"] == 1 and row["repeats"] == [18.0, None, 21.0, 16.0]  # the middle of three that finished
    assert median_run([{"error": "a"}, {"error": "b"}]) == {"error": "a"}


def test_a_sample_the_world_published_late_is_late_by_its_schedule_though_delivered_at_once() -> None:
    from scale_observe import Reading, schedule_lateness

    start = 1_000_000_000_000
    readings = [Reading(1, "gyroscope", tick * 0.05, start + tick * 50_000_000, start + tick * 50_000_000 + 2_000_000)
                for tick in range(1, 40)]
    late = readings[20]
    readings[20] = late._replace(published_ns=late.published_ns + 60_000_000, received_ns=late.received_ns + 60_000_000)
    readings.append(Reading(1, "navigation_status", 0.5, start + 90_000_000, start + 91_000_000))  # a reply between
    out = schedule_lateness(readings, start, start + 10**10, 0.05, {"gyroscope": 1, "perception": 4})
    assert out["over_one_period"] == 1 and out["slip_ms"]["max_ms"] == 60.0  # ticks: the status is left out
    assert out["arrival_ms"]["max_ms"] == 62.0 and out["slip_ms"]["p50_ms"] == 0.0


def test_a_shared_count_holds_real_time_only_if_its_agents_keep_up() -> None:
    from scale_report import AGENT_LAG_LIMIT_MS, holds

    lag = {"p50_ms": 40.0, "p99_ms": 120.0}
    assert holds({"real_time_factor": 0.998, "agent_lag_ms": lag})
    assert not holds({"real_time_factor": 0.98, "agent_lag_ms": lag})  # the world fell behind
    assert not holds({"real_time_factor": 1.0, "agent_lag_ms": {**lag, "p99_ms": AGENT_LAG_LIMIT_MS + 1}})
    assert not holds({"real_time_factor": 1.0, "error": "the world died"})


def _search(counts: list[int], holding_up_to: int, step_down: bool = True) -> tuple[int | None, list[int]]:
    tried: list[int] = []

    def held(n: int) -> bool:
        tried.append(n)
        return n <= holding_up_to

    return highest_holding(counts, held, step_down), tried


def test_the_shared_series_halves_until_a_count_holds_then_narrows_the_gap() -> None:
    assert _search([1000], 870) == (850, [1000, 500, 750, 900, 800, 850])
    assert _search([1000, 750, 500], 900) == (900, [1000, 750, 900, 950])
    assert _search([1000], 10) == (None, [1000, 500, 250, 125, 62])


def test_without_step_down_only_the_counts_asked_for_are_measured() -> None:
    assert _search([1000], 870, step_down=False) == (None, [1000])
    assert _search([500, 1000], 870, step_down=False) == (500, [1000, 500])
