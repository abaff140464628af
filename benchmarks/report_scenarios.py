"""The report's four scenarios with their shipped noise, 5 and 20 rovers, 10 seeds each: reach, collisions, stuck,
and the missions' simulated durations (median and range); then each rover that fell short, with how far off its
estimate was against what the rover said of it.

The report's editor profiles (appendix C.3, figures 27-30: crater_observation, crater_and_return, maze,
maze_crater_return) are what the behaviour was built on; this measures it there as the issue's targets ask
(at least 98 % reach, no collisions, no stuck rover), with 20-rover teams respawned in the report's formation
(``--rovers``). Each mission runs in lockstep in one process (``harness.loopback.run_mission``, which gives the
report of ``lunarsim run --lockstep``: tests/e2e/test_loopback_equals_processes.py), capped in simulated time as the
behaviour suite caps its missions.

    python benchmarks/report_scenarios.py [--seeds 1-10] [--teams 5 20] [--jobs 2] [--json FILE]
    python benchmarks/report_scenarios.py --quick    # one seed of 5 rovers, cut at 30 simulated seconds
"""

from __future__ import annotations

import argparse
import json
import logging
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import host
import quick
from behaviour_suite import estimate_error, estimate_nees, estimate_std, parse_seeds, sim_cap

from harness.loopback import run_mission_agents
from schemas.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
REPORT_SCENARIOS = ("crater_observation", "crater_and_return", "maze", "maze_crater_return")
QUICK = {"seeds": range(1, 2), "teams": [5], "sim_cap": 30.0}


def run_one(name: str, rovers: int, seed: int, cap_s: float | None = None) -> dict:
    logging.disable(logging.WARNING)
    scenario = load_scenario(SCENARIOS / f"{name}.yaml").with_overrides(seed=seed, rovers=rovers)
    started = time.perf_counter()
    world, agents = run_mission_agents(scenario, sim_cap(scenario, cap_s))
    report = world.report()
    state = world.referee.stats.last
    reached = set(world.referee.stats.reached(state))
    short = [{"id": r.id, "state": r.state, "goal_error_m": r.distance_to_goal_m,
              "estimate_error_m": estimate_error(agents[r.id], scenario, r.x, r.z),
              "estimate_std_m": estimate_std(agents[r.id]),
              "estimate_nees": estimate_nees(agents[r.id], scenario, r.x, r.z)}
             for r in state.rovers if r.id not in reached]
    return {"scenario": name, "rovers": rovers, "seed": seed, "wall_s": round(time.perf_counter() - started, 2),
            "reached": report.rovers_reached_final_goal, "relays": report.rovers_holding_relay_spots,
            "collisions": report.rover_collisions + report.obstacle_collisions, "stuck": report.rovers_stuck,
            "complete": report.complete, "duration_s": report.mission_duration_s, "short": short}


def table(rows: list[dict]) -> None:
    print(f"{'scenario':<20} {'rovers':>6} {'reach':>8} {'collisions':>10} {'stuck':>6} {'complete':>9} "
          f"{'median s':>9} {'range s':>13}")
    groups = sorted({(r["scenario"], r["rovers"]) for r in rows}, key=lambda g: (REPORT_SCENARIOS.index(g[0]), g[1]))
    for name, rovers in groups:
        some = [r for r in rows if (r["scenario"], r["rovers"]) == (name, rovers)]
        _line(name, str(rovers), some)
    _line("all", "", rows)
    shortfalls(rows)


def shortfalls(rows: list[dict]) -> None:
    """The rovers that did not reach, one a line: how far off their goal, and how far off their own estimate was
    against what it said of itself (its 1-sigma error, and the truth's NEES in its covariance: above 9.21 one time
    in 100 for an honest estimate). Runs saved before the figure have none."""
    short = [(row, r) for row in rows for r in row.get("short", [])]
    if not short:
        return
    print(f"{len(short)} rovers short of their final goal:")
    for row, r in short:
        print(f"  {row['scenario']} x{row['rovers']} seed {row['seed']} rover {r['id']} ({r['state']}): "
              f"{_fmt(r['goal_error_m'], ' m')} off its goal, its estimate {_fmt(r['estimate_error_m'], ' m')} off "
              f"the truth, 1 sigma {_fmt(r['estimate_std_m'], ' m')}, NEES {_fmt(r['estimate_nees'])}")


def _fmt(value: float | None, unit: str = "") -> str:
    return "-" if value is None else f"{value:.1f}{unit}"


def _line(name: str, rovers: str, rows: list[dict]) -> None:
    total = sum(r["rovers"] for r in rows)
    reached = sum(r["reached"] for r in rows)
    durations = [r["duration_s"] for r in rows]
    spread = f"{min(durations):.1f}-{max(durations):.1f}"
    print(f"{name:<20} {rovers:>6} {reached / total:>8.1%} {sum(r['collisions'] for r in rows):>10} "
          f"{sum(r['stuck'] for r in rows):>6} {sum(r['complete'] for r in rows):>5}/{len(rows):<3} "
          f"{statistics.median(durations):>9.1f} {spread:>13}", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=parse_seeds, default=range(1, 11), metavar="A-B")
    parser.add_argument("--teams", type=int, nargs="+", default=[5, 20], help="rovers in a mission")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--json", type=Path, metavar="FILE")
    parser.add_argument("--table", type=Path, metavar="FILE", help="print the table of a --json FILE, run nothing")
    parser.add_argument("--sim-cap", type=float, metavar="S", help="stop every mission after S simulated seconds "
                        "(default: from its longest ideal path)")
    args = quick.parse_args(parser, QUICK)
    if args.sim_cap is not None and args.sim_cap <= 0:
        parser.error("--sim-cap must be more than 0")
    if args.table:
        table(json.loads(args.table.read_text())["missions"])
        return
    about = {"host": host.describe(), "code": host.code_version()}
    print(host.line(about["host"]), f"| commit {about['code']['commit']}", flush=True)
    jobs = [(name, rovers, seed, args.sim_cap) for rovers in args.teams for name in REPORT_SCENARIOS
            for seed in args.seeds]
    started = time.perf_counter()
    rows = []
    with ProcessPoolExecutor(args.jobs) as pool:
        for row in pool.map(run_one, *zip(*jobs, strict=True)):
            rows.append(row)
            print(f"[{len(rows)}/{len(jobs)}] {row['scenario']} x{row['rovers']} seed {row['seed']}: "
                  f"{row['reached']}/{row['rovers']} reached, {row['stuck']} stuck, {row['collisions']} collisions "
                  f"({row['wall_s']:.0f} s)", flush=True)
    table(rows)
    print(f"{len(rows)} missions in {time.perf_counter() - started:.0f} s")
    if args.json:
        args.json.write_text(json.dumps({**about, "missions": rows}, indent=2))


if __name__ == "__main__":
    main()
