"""Every benchmark runs end to end in its quick mode and prints its figures, so none rots between the runs that
measure. Each script runs as a reader runs it (``python benchmarks/NAME.py --quick``), in a process of its own;
the test checks that it exits 0, that each figure line is there in its format, and that its ``--json`` file holds
the figures. How fast anything was is for the benchmarks to print, never for a test to judge."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from procs import REPO, free_port
from test_web_browser import CHROMIUM

pytestmark = pytest.mark.bench_smoke

BENCHMARKS = REPO / "benchmarks"
SUPPORT = {"behaviour_tables", "control_loop_world", "host", "latency_summary", "lockstep_speed_report", "proc_meter",
           "quick", "scale_args", "scale_cluster", "scale_hosts", "scale_observe", "scale_report", "scale_witness",
           "tick_costs",
           "zenoh_floor", "ros2_sdk_meter"}
"""Modules the benchmarks import or start, not benchmarks themselves."""
MS = r"\d+\.\d{3}"


@dataclass(frozen=True)
class Smoke:
    """A benchmark's quick run: extra arguments (``{port}``: a free loopback port; ``{flight_env}``: the flight
    environment the flight wheel's tests build, which the benchmark would otherwise build the same way), the figure
    lines it must print (regular expressions, each matching a whole line of its output) and what its ``--json``
    file must hold."""

    args: tuple[str, ...] = ()
    lines: tuple[str, ...] = ()
    json_check: Callable[[object], bool] = field(default=lambda doc: bool(doc))
    timeout_s: float = 600.0


SMOKES: dict[str, Smoke] = {
    "behaviour_suite": Smoke(lines=(
        r"\[2/2\] seed \d+ \w+ team=\w+ start=\w+ noise=\w+: \d+/\d+ reached, \d+ collisions, \d+ stuck, \d+ s "
        r"simulated( \(cap\))?, [\d.]+ s wall",
        r"all\s+2\s+\d+\s+\d+\.\d%\s+\d+\.\d%\s+\d+\.\d\d\s+\d+\s+\S+\s+\d+\.\d\s+\d+\.\d.*\d+/2\s*",
        r"failure taxonomy \(\d+ rovers did not reach their final goal\):",
        r"2 missions in \d+ s of wall \(2 jobs\); one mission took [\d.]+ s on average \(max [\d.]+ s\); 0 failed "
        r"with an error"),
        json_check=lambda doc: len(doc["missions"]) == 2 and "overall" in doc["aggregate"]),
    "chaos": Smoke(lines=(
        r"router killed and restarted on its port, 0\.5 s down \(mission: \d+/1 reached, (NOT )?complete\)",
        r"\s+1\s+\d+\.\d\d\s+\d+\.\d\d",
        r"\s+5%\s+\d+/1\s+\d+\s+\d+\.\d\s+\d+\.\d",
        r"recorder SIGKILLed after 2 s: 'lunarsim recover' kept \d+ of the \d+ samples recorded until the kill "
        r"\(\d+\.\d%\); last recovered sample -?[\d.]+ s before the kill"),
        json_check=lambda doc: {"reconnect", "loss", "recovery"} <= doc.keys()),
    "control_loop_latency": Smoke(lines=(
        rf"over Zenoh \(world -> router -> rover -> router -> world\)\s+50(\s+{MS}){{5}}",
        rf"bare Zenoh floor \(ping -> router -> echo -> router -> pong\)\s+50(\s+{MS}){{5}}",
        rf"agent only, in process \(decode \+ decide \+ encode\)\s+50(\s+{MS}){{5}}",
        rf"Target p50 < 1 ms: {MS} ms  (PASS|FAIL)",
        r"Target p50 within 1\.2x the floor: \d+\.\d\dx  (PASS|FAIL)",
        r"Target p99 within 1\.2x the floor: \d+\.\d\dx  (PASS|FAIL)"),
        json_check=lambda doc: {"p50", "p99"} == doc["ratio_to_floor"].keys() and doc["floor"]["loops"] == 50),
    "env_steps": Smoke(lines=(
        r"\s+5 rovers \| idle\s+[\d,]+ \| random\s+[\d,]+ \| agent\s+[\d,]+ \| 1 workers: idle\s+[\d,]+, agent "
        r"episodes\s+[\d,]+ agent-steps/s \| sim s per wall s: agent policy [\d.]+, plain run [\d.]+ \([\d.]+x\)",),
        json_check=lambda doc: "5" in doc["results"]),
    "flight_rover": Smoke(args=("--port", "{port}", "--venv", "{flight_env}"), lines=(
        r"bare Zenoh client\s+\d+\.\d\d\s+\d+\.\d\s+\d+\.\d",
        r"rover agent \(flight\)\s+\d+\.\d\d\s+\d+\.\d\s+\d+\.\d",
        r"rover agent over the bare client: \+-?\d+\.\d MiB resident, x\d+\.\d\d start-up"),
        json_check=lambda doc: doc["runs"] == 1 and doc["rover_agent"]["rss_mib"] > 0),
    "flood": Smoke(args=("--port", "{port}"), lines=(
        r"flood_puts_per_s\s+\d+",
        r"clock_pace_during_flood\s+\d+\.\d{3}",
        r"world_rss_peak_growth_mib\s+-?\d+\.\d{3}",
        r"other_rovers_reply_p99_ms\s+(\d+\.\d{3}|nan)",
        r"reached\s+\d+/3"),
        json_check=lambda doc: doc["flood_puts_per_s"] > 0),
    "lockstep_speed": Smoke(lines=(
        r"in process \(harness\.loopback\.run_mission_agents\): median \d+\.\d x real time \(runs: [\d.]+\); "
        r"target 60 x: (PASS|FAIL)",
        r"lunarsim run --lockstep, whole command \(a process per rover\): median \d+\.\d x real time \(runs: [\d.]+\); "
        r"target 25 x: (PASS|FAIL)",
        r"lunarsim run phases \(median s from the command's start\): .*clock started \d+\.\d\d.*, command over "
        r"\d+\.\d\d",
        rf"the world's ticks through processes \(median ms a tick\): mission {MS}, stepping {MS}, publishing {MS}, "
        rf"waiting for acks {MS} \(\d+% of ticks wait\), taking answers {MS}",
        rf"\s+world: perception rays\s+{MS} ms a tick\s+\d+\.\d%",
        rf"an agent's handling of one perception \(in process, mean of \d+\): {MS} ms until its answer is out: .*; "
        rf"then the traverse map {MS} ms"),
        json_check=lambda doc: len(doc["in_process"]) == len(doc["command"]) == 1 and doc["parts"][0]["ticks"] > 0),
    "recorder_throughput": Smoke(args=("--port", "{port}"), lines=(
        r"10 rovers, 3 s simulated in [\d.]+ s \(real-time factor [\d.]+\): \d+ messages/s, [\d.]+ MB/s",
        r"perception\s+\d+\s+\d+",
        r"recorder drops: \d+; missing: \d+.*",
        r"router \+ recorder CPU: [\d.]+ s \(\d+% of one core\); peak RSS of the larger: [\d.]+ MB; file [\d.]+ MB"),
        json_check=lambda doc: doc["published"]["perception"] > 0),
    "report_scenarios": Smoke(lines=(
        r"\[4/4\] \w+ x5 seed 1: \d/5 reached, \d+ stuck, \d+ collisions \(\d+ s\)",
        r"maze_crater_return\s+5\s+\d+\.\d%\s+\d+\s+\d+\s+\d/1\s+\d+\.\d\s+\d+\.\d-\d+\.\d\s*",
        r"all\s+\d+\.\d%\s+\d+\s+\d+\s+\d/4\s+\d+\.\d\s+\d+\.\d-\d+\.\d\s*",
        r"\d+ rovers short of their final goal:",  # cut at 30 s, some are
        r"  \w+ x5 seed 1 rover \d+ \(\w+\): \d+\.\d m off its goal, its estimate (\d+\.\d m|-) off the truth, "
        r"1 sigma (\d+\.\d m|-), NEES (\d+\.\d|-)",
        r"4 missions in \d+ s"),
        json_check=lambda doc: len(doc["missions"]) == 4 and all("short" in row for row in doc["missions"])),
    "scale": Smoke(lines=(
        r"realtime\s+3\s+3\s+\d\.\d{3}\s.*",
        r"realtime\s+10\s+2\s+\d\.\d{3}\s.*",
        r"lockstep\s+5\s+5\s+\d+\.\d{3}\s.*",
        r"highest shared-process rover count holding real time: (\d+|none measured)",
        r"target: 5-rover lockstep at least 20 x real time: [\d.]+ x  (PASS|FAIL)"),
        json_check=lambda doc: len(doc["rows"]) == 5),
    "scenario_load": Smoke(lines=(
        rf"1,000,000 rovers \(24\.0 MB\): {MS} s \([\d.]+ s with Python's start\), peak \d+ MB: .*cannot read "
        r"scenario: .*",
        r"a FIFO \(0\.0 MB\): .*not a regular file.*",
        r"target \(24 MB refused in < 2 s, < 200 MB\): met; every hostile file refused"),
        json_check=lambda doc: "aliases 10 deep" in doc),
    "suite_cpu": Smoke(lines=(
        r"pytest -q -p no:cacheprovider -n 0 tests/unit/schemas/test_keyspace\.py: \d+ passed in [\d.]+s \(exit 0\)",
        r"wall \d+\.\d s on \d+ cores; the process tree used \d+\.\d CPU s, the poll saw \d+\.\d; the machine was "
        r"idle \d+% of its \d+\.\d CPU s",
        r"pytest\s+\d+\.\d\s+\d+\.\d%\s+1\s*"),
        json_check=lambda doc: doc["exit"] == 0 and "pytest" in doc["by_kind"]),
    "terrain_memory": Smoke(lines=(
        r"tiles    loaded max \d+ \(\d+ MiB\), at end \d+; generated \d+ \(in \d+ rounds, ~\d+ ms each\), evicted "
        r"[1-9]\d*",
        rf"round    total\s+mean {MS} ms  p50 {MS}  p99 {MS}  max {MS}",
        r"memory   peak RSS \d+ MiB \(baseline after imports \d+ MiB\), tracemalloc peak not traced",
        r"target   peak RSS under 2048 MiB: PASS"),
        json_check=lambda doc: doc["run"]["rounds"] == 30),
    "viewer_fps": Smoke(args=("--chromium", CHROMIUM), lines=(
        r"scale    1:    0 rovers:\s+\d+\.\d frames/s at \d\.\d{3} resolution,\s+\d+\.\d states/s reached the page "
        r"\(viewport 640x360, states published at 20 Hz\)",
        r"scale    1:   10 rovers:\s+\d+\.\d frames/s at .*"),
        json_check=lambda doc: [r["rovers"] for r in doc["results"]] == [0, 10]),
    "wake_cost": Smoke(args=("--port", "{port}"), lines=(
        r"\d+ of 600 samples received; CPU per sample, medians of 1 round\(s\) of 200, the same span with nothing "
        r"sent taken off:",
        *(rf"  {n} a wake, {2 * n} ms apart: subscriber -?\d+ us, router -?\d+ us a sample" for n in (1, 2, 4))),
        json_check=lambda doc: set(doc["us_per_sample"]) == {"1", "2", "4"} and doc["sent"] == 600),
    "web_upload": Smoke(lines=(
        r"idle\s+\{\"n\": 50, \"p50_ms\": [\d.]+, \"p95_ms\": [\d.]+, \"max_ms\": [\d.]+\}",
        r"yaml file\s+\{\"request_mib\": [\d.]+, \"status\": 200, .*\"info_during\": \{\"n\": \d+, .*",
        r"page json\s+\{\"request_mib\": [\d.]+, \"status\": 200, .*"),
        json_check=lambda doc: doc["yaml file"]["status"] == doc["page json"]["status"] == 200),
    "ros2_bridge": Smoke(lines=(
        r"5 rovers, real time, [\d.]+ s: world published \d+ scan\+imu samples, the ROS 2 subscriber got \d+, "
        r"lost \d+.*",
        r"ROS 2 via the bridge \(SDK\)(\s+[\d.]+){4}",
        r"the bridge adds -?[\d.]+ ms at p99 to the SDK subscriber's trip, .*",
        r"20 rovers, real time: the bridge used [\d.]+% of one core over [\d.]+ s .*"),
        json_check=lambda doc: "five_rovers" in doc),
    "world_scale": Smoke(lines=(
        r"\s+10\s+\d+\.\d{4}\s+\d+\.\d\d\s+\d+\s+\d+\.\d",
        r"\s+100\s+\d+\.\d{4}\s+\d+\.\d\d\s+\d+\s+\d+\.\d"),
        json_check=lambda doc: [r["rovers"] for r in doc["rows"]] == [10, 100]),
}


def run_quick(name: str, smoke: Smoke, folder: Path, request: pytest.FixtureRequest) -> tuple[str, Path]:
    """The benchmark's quick run; its output (stdout and stderr) and its JSON file."""
    figures = folder / f"{name}.json"
    args = [a.replace("{port}", str(free_port())) for a in smoke.args]
    args = [str(request.getfixturevalue("flight_env")) if a == "{flight_env}" else a for a in args]
    proc = subprocess.run([sys.executable, str(BENCHMARKS / f"{name}.py"), "--quick", "--json", str(figures), *args],
                          cwd=REPO, capture_output=True, text=True, timeout=smoke.timeout_s)
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"{name} --quick exited {proc.returncode}:\n{output[-4000:]}"
    return output, figures


def test_every_benchmark_has_a_quick_run_here():
    scripts = {path.stem for path in BENCHMARKS.glob("*.py")}
    assert scripts - SUPPORT == SMOKES.keys(), "a benchmark without a smoke run here, or a smoke run of nothing"


@pytest.mark.parametrize("name", sorted(SMOKES))
def test_the_quick_run_prints_its_figures(name, tmp_path, request):
    if name == "viewer_fps" and not Path(CHROMIUM).is_file():
        pytest.skip("Debian's chromium is not installed (apt-get install -y chromium; .ci/run does it)")
    smoke = SMOKES[name]
    output, figures = run_quick(name, smoke, tmp_path, request)
    lines = [line.rstrip() for line in output.splitlines()]
    missing = [p for p in smoke.lines if not any(re.fullmatch(p, line) for line in lines)]
    assert not missing, f"{name} --quick printed no line like {missing}:\n{output[-4000:]}"
    assert smoke.json_check(json.loads(figures.read_text())), f"{name}: unexpected --json {figures.read_text()[:2000]}"
    if name == "scale":  # a saved run prints again
        again = subprocess.run([sys.executable, str(BENCHMARKS / "scale_report.py"), str(figures)], cwd=REPO,
                               capture_output=True, text=True, timeout=60)
        assert again.returncode == 0 and "target: 5-rover lockstep at least 20 x real time" in again.stdout, again
    if name == "behaviour_suite":
        again = subprocess.run([sys.executable, str(BENCHMARKS / "behaviour_suite.py"), "--table", str(figures)],
                               cwd=REPO, capture_output=True, text=True, timeout=60)
        assert again.returncode == 0 and re.search(r"^all\s+2\s", again.stdout, re.M), again


def test_the_scale_benchmark_runs_its_shared_series_on_two_hosts(tmp_path):
    """``--two-hosts``: the rovers on a network namespace of their own behind a second router; the namespaces are
    gone afterwards."""
    if os.geteuid() != 0 or shutil.which("ip") is None:
        pytest.skip("network namespaces need root and iproute2 (.ci/run runs as root)")
    figures = tmp_path / "scale.json"
    proc = subprocess.run([sys.executable, str(BENCHMARKS / "scale.py"), "--quick", "--two-hosts", "--skip-lockstep",
                           "--counts", "2", "--shared-counts", "4", "--per-process", "2", "--json", str(figures)],
                          cwd=REPO, capture_output=True, text=True, timeout=600)
    output = proc.stdout + proc.stderr
    assert proc.returncode == 0, output[-4000:]
    assert "routing: two hosts" in output
    doc = json.loads(figures.read_text())
    assert [(r["rovers"], r["hosts"], r["processes"]) for r in doc["rows"]] == [(2, 2, 2), (4, 2, 2)], doc["rows"]
    assert all(r["cpu_cores"]["router"] > 0 for r in doc["rows"])  # both routers' CPU counted
    namespaces = subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
    assert doc["hosts"]["hub"] not in namespaces and doc["hosts"]["fleet"] not in namespaces

