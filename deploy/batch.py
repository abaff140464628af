"""N seeded runs of a scenario, in parallel, summarised as the report's Table 2 (``lunarsim batch``).

Each run is a whole ``lunarsim run`` (its own router port and world name) with seed BASE + i. Every run's report and
the aggregate go to ``DIR/batch.json``; a run that fails is recorded with the end of its output, and the others go
on. ``deploy.batch_collect`` makes the same batch.json and table from runs made elsewhere, with this module's
folder names, report reading and summary.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from bus import process
from schemas.scenario_limits import SEED_LIMIT

BATCH_FILE = "batch.json"
TABLE_WIDTH = 140
"""Columns of the printed table when the output is not a terminal (a log, CI): wide enough for every figure."""


@dataclass
class Run:
    index: int
    seed: int
    out: Path
    proc: subprocess.Popen | None = None


@dataclass(frozen=True)
class BatchSpec:
    """The options of ``lunarsim batch`` (its ``--help`` says what each does)."""

    scenario: Path
    out: Path
    runs: int = 5
    seed: int = 1
    jobs: int = 1
    lockstep: bool = False
    in_process: bool = False
    rovers: int | None = None
    params: Path | None = None
    max_sim_time: float = 900.0
    time_scale: float = 4.0


MAX_RUNS = 100_000
"""Runs in a batch at most, here or collected from a Kubernetes Job: a table of more says nothing more, and a
hundred million expected runs took collect-batch minutes of listing the missing ones."""


def run_batch(spec: BatchSpec) -> int:
    """Every run, ``spec.jobs`` at a time; batch.json written and Table 2 printed. 1 if no run gave a report."""
    from schemas.scenario import load_rover_params, load_scenario

    if spec.runs < 1 or spec.jobs < 1:
        raise process.UsageError("--runs and --jobs must be at least 1")
    process.check_range("--runs", spec.runs, 1, MAX_RUNS)
    if spec.time_scale <= 0 and not (spec.lockstep or spec.in_process):
        raise process.UsageError(f"--time-scale must be positive without --lockstep, got {spec.time_scale:g}")
    if not 0 <= spec.seed <= SEED_LIMIT - spec.runs:
        raise process.UsageError(f"--seed must be at least 0 and leave every run's seed (BASE + i, {spec.runs} runs) "
                                 f"below 2**63, got {spec.seed}")
    params = load_rover_params(spec.params) if spec.params else None
    scenario = load_scenario(spec.scenario).with_overrides(rovers=spec.rovers, rover_params=params)
    console = table_console()
    if spec.out.exists() and any(spec.out.glob("run-*")):
        raise process.UsageError(f"{spec.out} already holds a batch (run-* folders): choose another --out, so "
                                 "no run overwrites another's report")
    spec.out.mkdir(parents=True, exist_ok=True)
    runs = [Run(i, spec.seed + i, spec.out / run_folder(i + 1, spec.seed + i)) for i in range(spec.runs)]
    mode = ", lockstep in process" if spec.in_process else ", lockstep" if spec.lockstep else ""
    console.print(f"{scenario.name}: {spec.runs} runs, {len(scenario.rovers)} rovers, {spec.jobs} at a time{mode}")
    reports, failed = _run_all(runs, spec, scenario, console)
    summary = summarise(scenario.name, len(scenario.rovers), spec.lockstep or spec.in_process, reports, failed)
    write_summary(spec.out / BATCH_FILE, summary, console)
    console.print(f"written {spec.out / BATCH_FILE}" + (f"; {len(failed)} run(s) failed" if failed else ""))
    return 1 if failed and not reports else 0


def run_folder(run: int, seed: int) -> str:
    """A run's folder, named by run number (Job index + 1) and seed: ``lunarsim batch`` and the Kubernetes Job
    (deploy/k8s/batch/job.yaml) write the same names, so ``lunarsim collect-batch`` reads either."""
    return f"run-{run:03d}-seed{seed}"


def table_console():
    """A console for the table: the terminal's width, or one wide enough for every column in a log (a pod's)."""
    from rich.console import Console

    return Console(width=None if sys.stdout.isatty() else TABLE_WIDTH)


def summarise(scenario: str, rovers: int, lockstep: bool | None, reports: list[dict], failed: list[dict],
              **extra) -> dict:
    """What batch.json holds, whoever ran the runs: one function, so a cluster's batch.json and a machine's have
    the same fields and the same figures for the same reports."""
    reports = sorted(reports, key=lambda r: (r["seed"], r["run"]))
    return {"scenario": scenario, "rovers": rovers, "lockstep": lockstep, "runs": reports, "failed": failed,
            **extra, "aggregate": aggregate(reports)}


def write_summary(path: Path, summary: dict, console) -> None:
    path.write_text(json.dumps(summary, indent=2) + "\n")
    console.print(table_2(summary["scenario"] or path.parent.name, summary["runs"], summary["aggregate"]))


def _run_all(runs: list[Run], spec: BatchSpec, scenario, console) -> tuple[list[dict], list[dict]]:
    reports, failed = [], []
    if spec.in_process:
        from deploy.batch_in_process import run_all

        ended = run_all(runs, scenario, spec.jobs, spec.max_sim_time)
    else:
        ended = _run_all_processes(runs, spec)
    for run, failure in ended:
        report = _collect(run, failure)
        (reports if "error" not in report else failed).append(report)
        done = len(reports) + len(failed)
        console.print(f"[{done}/{len(runs)}] seed {run.seed}: " + (
            f"{report['rovers_reached_final_goal']}/{report['rovers_total']} reached, "
            f"{report['rover_collisions'] + report['obstacle_collisions']} collisions, "
            f"{report['rovers_stuck']} stuck" if "error" not in report else f"failed: {report['error']}"))
    return reports, failed


def _run_all_processes(runs: list[Run], spec: BatchSpec) -> Iterator[tuple[Run, str]]:
    """Each run as it ends, with what its output says if it gave no report: ``spec.jobs`` ``lunarsim run`` at a
    time."""
    waiting, active = list(runs), []
    while waiting or active:
        while waiting and len(active) < spec.jobs:
            run = waiting.pop(0)
            run.proc = _start(run, spec)
            active.append(run)
        time.sleep(0.2)
        for run in [r for r in active if r.proc.poll() is not None]:
            active.remove(run)
            tail = (run.out / "run.log").read_text(errors="replace").strip().splitlines()[-3:]
            yield run, f"exit {run.proc.returncode}: " + " | ".join(tail)


def _start(run: Run, spec: BatchSpec) -> subprocess.Popen:
    command = [sys.executable, "-P", "-m", "deploy.cli", "run", str(spec.scenario), "--seed", str(run.seed),
               "--out", str(run.out), "--port", str(_free_port()), "--world", f"batch{run.index}", "--quiet",
               "--max-sim-time", str(spec.max_sim_time), "--time-scale", str(spec.time_scale)]
    if spec.lockstep:
        command.append("--lockstep")
    if spec.rovers:
        command += ["--rovers", str(spec.rovers)]
    if spec.params:
        command += ["--params", str(spec.params)]
    run.out.mkdir(parents=True, exist_ok=True)
    log = open(run.out / "run.log", "wb")  # noqa: SIM115 - handed to the child
    proc = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)
    log.close()
    return proc


def _collect(run: Run, failure: str) -> dict:
    """The run's report as batch.json lists it; ``failure`` says why when it left none (or an unreadable one)."""
    try:
        return read_run(run.out, run.index + 1)
    except (OSError, ValueError):
        return {"run": run.index + 1, "seed": run.seed, "error": failure or "no readable report.json"}


def read_run(folder: Path, run: int) -> dict:
    """A run's report.json as batch.json lists it. Raises OSError when there is none (the run did not finish) and
    ValueError when it is not a mission report (cut short, edited, another program's), so that no half-read report
    reaches the aggregate."""
    import msgspec

    from schemas.truth import MissionReport

    report = json.loads((folder / "report.json").read_text())
    if not isinstance(report, dict):
        raise ValueError(f"a JSON {type(report).__name__}, not a mission report")
    known = {k: v for k, v in report.items() if k in MissionReport.__struct_fields__}
    msgspec.convert(known, MissionReport)  # fields a newer version added are kept, not refused
    return {**report, "run": run, "photos_at_lander": _photos_archived(folder)}


def _photos_archived(out: Path) -> int:
    try:
        return len((out / "lander_archive" / "index.jsonl").read_text().splitlines())
    except OSError:
        return 0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def aggregate(reports: list[dict]) -> dict:
    if not reports:
        return {}
    n = len(reports)
    total = sum(r["rovers_total"] for r in reports)
    reached = sum(r["rovers_reached_final_goal"] for r in reports)

    def mean(field: str) -> float:
        return round(sum(r[field] for r in reports) / n, 4)

    return {
        "runs": n,
        "relative_path_length_m": mean("relative_path_length_m"),
        "average_distance_covered_m": mean("average_distance_covered_m"),
        "average_path_efficiency": mean("average_path_efficiency"),
        "reached_path_efficiency": _reached_efficiency(reports),
        "total_distance_covered_m": mean("total_distance_covered_m"),
        "rovers_reached_final_goal": reached,
        "rovers_total": total,
        "reached_fraction": round(reached / total, 4) if total else 0.0,
        "rover_collisions": sum(r["rover_collisions"] for r in reports),
        "obstacle_collisions": sum(r["obstacle_collisions"] for r in reports),
        "rovers_stuck": sum(r["rovers_stuck"] for r in reports),
        "mission_duration_s": mean("mission_duration_s"),
        "complete_runs": sum(bool(r["complete"]) for r in reports),
        "worst_rover_connected_fraction": min(r["worst_rover_connected_fraction"] for r in reports),
        "max_rovers_in_daisy_chain": max(r["max_rovers_in_daisy_chain"] for r in reports),
        "photos_at_lander": sum(r["photos_at_lander"] for r in reports),
    }


def _reached_efficiency(reports: list[dict]) -> float | None:
    """The mean of the runs' own figures (each already a mean over its rovers that reached); None if none had one."""
    values = [r["reached_path_efficiency"] for r in reports if r.get("reached_path_efficiency") is not None]
    return round(sum(values) / len(values), 4) if values else None


def table_2(name: str, reports: list[dict], agg: dict):
    """The report's Table 2, one row per run and a row over all runs: means of the figures, sums of the counts, the
    lowest connected share and the most relays, each cell saying which."""
    from rich.table import Table

    table = Table(title=f"{name}: {len(reports)} runs", title_justify="left", caption_justify="left",
                  caption="all runs: means of lengths, efficiency and duration; sums of rovers, collisions, stuck "
                          "and photos; the lowest connected share; the most relays")
    for column in ("run", "rel. path m", "avg covered m", "efficiency", "total m", "reached", "collisions",
                   "stuck", "mm:ss", "connected", "relays", "photos"):
        table.add_column(column, justify="right")
    for r in reports:
        table.add_row(str(r["run"]), f"{r['relative_path_length_m']:.2f}", f"{r['average_distance_covered_m']:.2f}",
                      f"{r['average_path_efficiency']:.3f}", f"{r['total_distance_covered_m']:.1f}",
                      f"{r['rovers_reached_final_goal']}/{r['rovers_total']}",
                      str(r["rover_collisions"] + r["obstacle_collisions"]), str(r["rovers_stuck"]),
                      _mmss(r["mission_duration_s"]), *_radio(r))
    if agg:
        table.add_row("all runs", f"{agg['relative_path_length_m']:.2f}", f"{agg['average_distance_covered_m']:.2f}",
                      f"{agg['average_path_efficiency']:.3f}", f"{agg['total_distance_covered_m']:.1f}",
                      f"{agg['rovers_reached_final_goal']}/{agg['rovers_total']} ({agg['reached_fraction']:.0%})",
                      str(agg["rover_collisions"] + agg["obstacle_collisions"]), str(agg["rovers_stuck"]),
                      _mmss(agg["mission_duration_s"]), f"min {agg['worst_rover_connected_fraction']:.2f}",
                      f"max {agg['max_rovers_in_daisy_chain']}", str(agg["photos_at_lander"]), style="bold")
    return table


def _radio(r: dict) -> tuple[str, str, str]:
    return (f"{r['worst_rover_connected_fraction']:.2f}", str(r["max_rovers_in_daisy_chain"]),
            str(r["photos_at_lander"]))


def _mmss(seconds: float) -> str:
    return f"{int(seconds // 60)}:{int(seconds % 60):02d}"
