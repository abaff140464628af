"""Behaviour off the tuned cases: generated missions (``scenarios/generator.py``) run in lockstep, results per class.

The shipped scenarios are what the behaviour was tuned on. This runs a fixed range of generated ones and prints,
for every class value the generator labels (family, terrain, rock density, noise, team, start, walls, goals,
return) and for each rover's role (formation, in_crater, out_of_range):
- reach: rovers that reached their final goal (``MissionReport``'s definition: done, at the final goal, and on the
  crest or within the perception radius) over all rovers; and "sent", over the rovers not holding a daisy chain's
  relay spot at the end (at the last goal a daisy chain's relays walk on once released, ``release_relays``; a
  relay still on its spot counts as not reached, as in the report's figure);
- collisions (rover and obstacle, per mission) and stuck rovers (said so, or counted stalled by the world);
- where the distance goes: the metres the rovers that reached walked, by what they walked for (their goal, a
  way by the lander, a search for a fix, a relay spot, the lander's radio), beside their ideal paths;
- relays stranded: rovers still holding a daisy chain's relay spot at the end, a spot nobody needs any more, per
  mission of the daisy family (and how many in the others' missions);
- path efficiency of the rovers that reached: their ideal path (the report's relative path length) over the
  distance they covered (the report's mission figure mixes in rovers that never moved); above 1 where a rover
  skipped a leg: a relay of a chain to a goal before the last is sent on to the next goal, not to that one;
- end-of-mission pose error: from each rover's final true position to its final goal where it is reached (the
  crest for a crater goal, the waypoint otherwise: ``world_service.outcome.statistics.distance_to_goal``), median
  and p90;
- localisation error: from each rover's own estimate of where it stands (``RoverAgent.pose``) to where it truly
  stands at the end, median and p90 over the rovers that walked at least ``behaviour_tables.LOCALISED_AFTER_M``;
- a failure taxonomy: for each rover that did not reach, its classes, role, final state, distance to its final
  goal and whether it ever heard the lander (it holds a goal index only once a mission direction reached it); a
  rover done off its goal is told apart by whether its own estimate allowed for the error
  (``behaviour_tables.UNSURE_SIGMAS``): one that knew it was unsure had nothing left to fix it with, one sure of a
  wrong estimate is the estimator's fault.
``MissionReport`` carries no per-rover figures, so they come from the world's last published state.

Path: ``harness.loopback.run_mission_agents``, the world, lander and rover agents wired in one process through
their pure handlers, every message still through the codec, the world waiting on each tick for exactly the agents
it would wait for in lockstep (``AckPlan``); an agent publishing on a tick nobody waits for is an error there. It
gives the same report.json as ``lunarsim run --lockstep`` but for ``wall_time_s`` and the map scores, which only the
launcher adds (tests/e2e/test_loopback_equals_processes.py: the shipped crater mission, the daisy chain, a generated
one with a rover out of range, a team of twelve). It needs no router, ports or processes: a generated maze took
5.9 s of wall against 21.6 s, crater_observation 1.5 s against 4.9 s.

Each mission stops at a simulated-time cap (``sim_cap``: from the longest rover's ideal path) so a rover that
never finishes cannot hang the suite; the world's watchdog counts a rover stuck after 300 s without progress.
Seed sets are fixed: tune on DEVELOPMENT, then report HELD_OUT, which tuning must not look at (USED_HELD_OUT, the
held-out sets before it, for reference).

    python benchmarks/behaviour_suite.py [--set dev|held-out|used-730000|...] [--seeds A-B] [--kind K]
                                         [--jobs 2] [--json FILE]
    python benchmarks/behaviour_suite.py --quick    # two missions cut at 30 simulated seconds: a smoke check
    python benchmarks/behaviour_suite.py --noise high --sun-sensor   # the high-noise missions, with a sun sensor

``--noise LEVEL`` runs only the set's missions drawn with that noise; ``--sun-sensor`` gives every rover an
absolute heading sensor (``PerceptionParams.sun_sensor``, off in the generated missions as in the report's rover).

With ``--json``, the file holds the missions finished so far while the suite runs (``"partial": true``), so a run
cut short can still be tabled with ``--table``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import logging
import math
import statistics
import sys
import time
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import msgspec

sys.path.insert(0, str(Path(__file__).resolve().parent))
import host
import quick
from behaviour_tables import aggregate, print_failures, print_table

from harness.loopback import run_mission_agents
from rover_agent.agent import RoverAgent
from scenarios.generator import CLASS_VALUES, GeneratedScenario, generate
from schemas.scenario import Scenario
from world_service.outcome import statistics as stats
from world_service.sim import World

DEVELOPMENT = range(0, 200)
HELD_OUT = range(260_000, 260_200)
"""Fixed before any tuning it measures: run it once, at the end of a round of changes, never to tune on."""
USED_HELD_OUT = {"used-470000": range(470_000, 470_200), "used-610000": range(610_000, 610_200),
                 "used-730000": range(730_000, 730_200), "used-900000": range(900_000, 900_200),
                 "used-500000": range(500_000, 500_200)}
"""Earlier held-out sets, each run once (docs/benchmarks.md has their figures): kept to compare with them, no longer
held out."""
SETS = {"dev": DEVELOPMENT, "held-out": HELD_OUT, **USED_HELD_OUT}
BASE_CAP_S, CAP_S_PER_M, MAX_CAP_S = 600.0, 3.0, 1800.0
"""Simulated-time cap: 600 s (twice the watchdog's stall time) plus 3 s a metre of the longest ideal path."""
SHOWN_FAILURES = 25
QUICK = {"seeds": range(6, 8), "sim_cap": 30.0}
"""Two small teams (a crater mission started in the crater, a maze with a rover out of range), cut short."""


def sim_cap(scenario: Scenario, cap_s: float | None = None) -> float:
    """The mission's simulated-time cap: ``cap_s`` when given, else from its longest ideal path."""
    if cap_s is not None:
        return cap_s
    longest = max(stats.relative_path_length(scenario, (r.x, r.z)) for r in scenario.rovers)
    return min(MAX_CAP_S, BASE_CAP_S + CAP_S_PER_M * longest)


def run_one(seed: int, kind: str | None, cap_s: float | None = None, sun_sensor: bool = False) -> dict:
    """One generated mission in lockstep; never raises (an error is a result of its own). ``sun_sensor``: every
    rover carries one (``PerceptionParams.sun_sensor``), the rest of the mission as generated."""
    logging.disable(logging.WARNING)  # the world's per-sample warnings would drown the progress lines
    made = generate(seed, kind)
    if sun_sensor:
        made = with_sun_sensor(made)
    result = {"seed": seed, "name": made.scenario.name, "classes": made.classes, "cap_s": sim_cap(made.scenario, cap_s)}
    started = time.perf_counter()
    try:
        world, agents = run_mission_agents(made.scenario, result["cap_s"])
        report = world.report()
    except Exception as exc:  # a bug in the behaviour or the wiring: record it, go on with the suite
        return {**result, "error": f"{type(exc).__name__}: {exc}", "wall_s": time.perf_counter() - started}
    return {**result, "wall_s": round(time.perf_counter() - started, 3), "report": msgspec.to_builtins(report),
            "rovers": _rovers(world, made, agents)}


def with_sun_sensor(made: GeneratedScenario) -> GeneratedScenario:
    params = made.scenario.rover_params
    perception = msgspec.structs.replace(params.perception, sun_sensor=True)
    scenario = made.scenario.with_overrides(rover_params=msgspec.structs.replace(params, perception=perception))
    return dataclasses.replace(made, scenario=scenario)


def estimate_error(agent: RoverAgent, scenario: Scenario, x: float, z: float) -> float | None:
    """Metres between the rover's estimate (lander frame) and its true position (map frame)."""
    if agent.pose is None:
        return None
    return round(math.hypot(agent.pose.x - (x - scenario.lander.x), agent.pose.z - (z - scenario.lander.z)), 3)


def estimate_nees(agent: RoverAgent, scenario: Scenario, x: float, z: float) -> float | None:
    """The truth's squared Mahalanobis distance from the estimate in the rover's own 2 x 2 position covariance (the
    normalised estimation error squared): about 2 on average, and above 9.21 one time in 100, where the filter's
    stated uncertainty is honest. None for a rover with no uncertainty (no noise, or not yet moved), and for one
    with an action under way, whose estimate is of where the action started (it is updated as the action ends)."""
    loc = agent.estimator.localisation
    if loc is None or agent.actions.in_flight is not None:
        return None
    (a, b), (_, d) = loc.cov[0][:2], loc.cov[1][:2]
    det = a * d - b * b
    if not det > 1e-12:
        return None
    ex, ez = loc.pose.x - (x - scenario.lander.x), loc.pose.z - (z - scenario.lander.z)
    return round((d * ex * ex - 2 * b * ex * ez + a * ez * ez) / det, 3)


def estimate_std(agent: RoverAgent) -> float | None:
    """The rover's own 1-sigma position error, metres: how far off it thinks its estimate may be."""
    loc = agent.estimator.localisation
    return None if loc is None else round(loc.position_std, 3)


def _rovers(world: World, made: GeneratedScenario, agents: dict[int, RoverAgent]) -> list[dict]:
    """Per-rover figures from the world's last published state (the one its report was computed from)."""
    referee = world.referee
    scenario, state, missions = made.scenario, referee.stats.last, referee.missions
    links = referee.stats.links
    reached_ids = set(referee.stats.reached(state))  # the report's own judgement, rover by rover
    out = []
    for r in state.rovers:
        final = missions.final_index(r.id)
        goal = missions.goal(r.id, final)
        spawn = scenario.rovers[r.id - 1]
        reached = r.id in reached_ids
        ideal = stats.relative_path_length(scenario, (spawn.x, spawn.z))
        role = "in_crater" if r.id in made.in_crater else "out_of_range" if r.id in made.out_of_range else "formation"
        disconnected = links.disconnected_by_rover.get(r.id, 0.0)
        out.append({"id": r.id, "role": role, "state": r.state, "stalled": r.stalled, "reached": reached,
                    "goal_index": r.goal_index, "final_goal_index": final, "heard_lander": r.goal_index >= 0,
                    "connected_fraction": round(1 - disconnected / links.elapsed_s, 4) if links.elapsed_s else 1.0,
                    "goal_error_m": round(stats.distance_to_goal(scenario, goal, r.x, r.z), 3),
                    "estimate_error_m": estimate_error(agents[r.id], scenario, r.x, r.z),
                    "estimate_std_m": estimate_std(agents[r.id]),
                    "estimate_nees": estimate_nees(agents[r.id], scenario, r.x, r.z),
                    "distance_covered_m": r.distance_covered_m, "ideal_path_m": round(ideal, 3),
                    "efficiency": round(ideal / r.distance_covered_m, 4) if r.distance_covered_m > 0 else None,
                    "walked_by_cause": {k: round(v, 2) for k, v in sorted(agents[r.id].walked.items())},
                    "detail": referee.status[r.id].detail})
    return out


# ---- output ----


def print_saved(path: Path, shown: int) -> int:
    """Tables of a saved run, aggregated again (so a figure added since is shown for old runs too)."""
    try:
        saved = json.loads(path.read_text())
        results = saved["missions"]
    except (OSError, ValueError, KeyError) as exc:
        raise SystemExit(f"--table: cannot read {path}: {exc}") from None
    cut = " (partial: a run cut short)" if saved.get("partial") else ""
    print(f"{path}: set {saved.get('set')}, seeds {saved.get('seeds')}, {len(results)} missions{cut}")
    agg = aggregate(results)
    print_table(agg)
    print_failures(agg, shown)
    return 0


def parse_seeds(text: str) -> range:
    try:
        first, _, last = text.partition("-")
        seeds = range(int(first), int(last or first) + 1)
    except ValueError:
        raise SystemExit(f"--seeds: expected A-B (inclusive) or N, got {text!r}") from None
    if not seeds or seeds.start < 0:
        raise SystemExit(f"--seeds: expected 0 <= A <= B, got {text!r}")
    return seeds


def describe_seeds(name: str, seeds: range) -> str:
    fixed = SETS[name]
    span = f"seeds {seeds.start}-{seeds.stop - 1}"
    if seeds == fixed:
        return f"set: {name} ({span}, the whole set)"
    if seeds.start >= fixed.start and seeds.stop <= fixed.stop:
        return f"set: {name} ({span}, {len(seeds)} of its {len(fixed)})"
    return f"set: none ({span} lie outside the {name} set {fixed.start}-{fixed.stop - 1})"


def run_all(seeds: Iterable[int], kind: str | None, jobs: int, cap_s: float | None = None,
            keep: Callable[[list[dict]], None] | None = None, sun_sensor: bool = False) -> list[dict]:
    """Every mission's results, in seed order; ``keep`` is handed those so far after each one."""
    results = []
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        futures = [pool.submit(run_one, seed, kind, cap_s, sun_sensor) for seed in seeds]
        for done, future in enumerate(as_completed(futures), 1):
            row = future.result()
            results.append(row)
            print(f"[{done}/{len(futures)}] {_progress(row)}", flush=True)
            if keep is not None:
                keep(sorted(results, key=lambda row: row["seed"]))
    return sorted(results, key=lambda row: row["seed"])


def _progress(row: dict) -> str:
    c = row["classes"]
    what = f"seed {row['seed']} {c['family']} team={c['team']} start={c['start']} noise={c['noise']}"
    if "error" in row:
        return f"{what}: error {row['error']}"
    r = row["report"]
    return (f"{what}: {r['rovers_reached_final_goal']}/{r['rovers_total']} reached, "
            f"{r['rover_collisions'] + r['obstacle_collisions']} collisions, {r['rovers_stuck']} stuck, "
            f"{r['mission_duration_s']:.0f} s simulated{'' if r['complete'] else ' (cap)'}, {row['wall_s']:.1f} s wall")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--set", choices=tuple(SETS), default="dev", help="which fixed seed set (default dev)")
    parser.add_argument("--seeds", type=parse_seeds, metavar="A-B", help="these seeds instead (inclusive)")
    parser.add_argument("--kind", help="only this family (crater, traverse, maze, daisy)")
    parser.add_argument("--jobs", type=int, default=2, help="missions at a time (default 2)")
    parser.add_argument("--json", type=Path, metavar="FILE", help="every mission's results and the aggregates")
    parser.add_argument("--show-failures", type=int, default=SHOWN_FAILURES, metavar="N")
    parser.add_argument("--table", type=Path, metavar="FILE", help="print the tables of a --json FILE, run nothing")
    parser.add_argument("--sim-cap", type=float, metavar="S", help="stop every mission after S simulated seconds "
                        "(default: from its longest ideal path; a mission cut short counts its rovers as they stand)")
    parser.add_argument("--sun-sensor", action="store_true", help="every rover carries a sun sensor, an absolute "
                        "heading sensor (PerceptionParams.sun_sensor; off in the generated missions)")
    parser.add_argument("--noise", choices=CLASS_VALUES["noise"], help="only the seeds drawn with this noise level")
    args = quick.parse_args(parser, QUICK, argv)
    if args.table:
        return print_saved(args.table, args.show_failures)
    if args.jobs < 1 or (args.sim_cap is not None and args.sim_cap <= 0):
        parser.error("--jobs must be at least 1, --sim-cap more than 0")
    try:
        generate(0, args.kind)  # a bad --kind fails here, not in every worker
    except ValueError as exc:
        parser.error(str(exc))
    seeds = args.seeds or SETS[args.set]
    chosen = [s for s in seeds if generate(s, args.kind).classes["noise"] == args.noise] if args.noise else seeds
    machine = host.describe()
    print(host.line(machine))
    print(describe_seeds(args.set, seeds) + (f", kind {args.kind}" if args.kind else "")
          + (f", noise {args.noise} only ({len(chosen)} missions)" if args.noise else "")
          + (", every rover with a sun sensor" if args.sun_sensor else "") + f", {args.jobs} jobs")
    started = time.perf_counter()
    about = {"host": machine, "set": args.set, "seeds": [seeds.start, seeds.stop - 1], "kind": args.kind,
             "noise": args.noise, "sun_sensor": args.sun_sensor, "jobs": args.jobs}

    def keep(rows: list[dict]) -> None:  # a run cut short leaves the missions it finished (``--table`` reads them)
        args.json.write_text(json.dumps({**about, "partial": True, "missions": rows}, indent=1) + "\n")

    results = run_all(chosen, args.kind, args.jobs, args.sim_cap, keep if args.json else None, args.sun_sensor)
    wall = time.perf_counter() - started
    agg = aggregate(results)
    print()
    print_table(agg)
    print_failures(agg, args.show_failures)
    walls = [row["wall_s"] for row in results]
    print(f"\n{len(results)} missions in {wall:.0f} s of wall ({args.jobs} jobs); one mission took "
          f"{statistics.fmean(walls):.1f} s on average (max {max(walls):.1f} s); {agg['errors']} failed with an error")
    if args.json:
        args.json.write_text(json.dumps({**about, "wall_s": round(wall, 1), "missions": results, "aggregate": agg},
                                        indent=1) + "\n")
        print(f"written {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
