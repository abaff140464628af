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
  stands at the end, median and p90 over the rovers that walked at least ``LOCALISED_AFTER_M``;
- a failure taxonomy: for each rover that did not reach, its classes, role, final state, distance to its final
  goal and whether it ever heard the lander (it holds a goal index only once a mission direction reached it); a
  rover done off its goal is told apart by whether its own estimate allowed for the error (``UNSURE_SIGMAS``):
  one that knew it was unsure had nothing left to fix it with, one sure of a wrong estimate is the estimator's
  fault.
``MissionReport`` carries no per-rover figures, so they come from the world's last published state.

Path: ``harness.loopback.run_mission``, the world, lander and rover agents wired in one process through their pure
handlers, every message still through the codec, the world waiting on each tick for exactly the agents it would
wait for in lockstep (``AckPlan``); an agent publishing on a tick nobody waits for is an error there. It gives
the same report.json as ``lunarsim run --lockstep`` but for ``wall_time_s`` and the map scores, which only the
launcher adds (tests/e2e/test_loopback_equals_processes.py: the shipped crater mission, the daisy chain, a generated
one with a rover out of range, a team of twelve). It needs no router, ports or processes: a generated maze took
5.9 s of wall against 21.6 s, crater_observation 1.5 s against 4.9 s.

Each mission stops at a simulated-time cap (``sim_cap``: from the longest rover's ideal path) so a rover that
never finishes cannot hang the suite; the world's watchdog counts a rover stuck after 300 s without progress.
Seed sets are fixed: tune on DEVELOPMENT, then report HELD_OUT, which tuning must not look at (OLD_HELD_OUT, the
held-out set before it, for reference).

    python benchmarks/behaviour_suite.py [--set dev|held-out|old-held-out] [--seeds A-B] [--kind K] [--jobs 2]
                                         [--json FILE]
    python benchmarks/behaviour_suite.py --quick    # two missions cut at 30 simulated seconds: a smoke check

With ``--json``, the file holds the missions finished so far while the suite runs (``"partial": true``), so a run
cut short can still be tabled with ``--table``.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import statistics
import sys
import time
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import host
import quick

from harness.loopback import run_mission_agents
from rover_agent.agent import RoverAgent
from scenarios.generator import CLASS_VALUES, GeneratedScenario, generate
from schemas.scenario import Scenario
from world_service.outcome import statistics as stats
from world_service.sim import World

DEVELOPMENT = range(0, 200)
HELD_OUT = range(500_000, 500_200)
"""Fixed before any tuning it measures: run it once, at the end of a round of changes, never to tune on."""
OLD_HELD_OUT = range(100_000, 100_200)
"""The held-out set before ``HELD_OUT``: run after several rounds of changes, so no longer held out; kept to
compare with figures measured on it."""
SETS = {"dev": DEVELOPMENT, "held-out": HELD_OUT, "old-held-out": OLD_HELD_OUT}
BASE_CAP_S, CAP_S_PER_M, MAX_CAP_S = 600.0, 3.0, 1800.0
"""Simulated-time cap: 600 s (twice the watchdog's stall time) plus 3 s a metre of the longest ideal path."""
SHOWN_FAILURES = 25
UNSURE_SIGMAS = 3.0
"""A rover done off its goal "knew it was unsure" when its estimate's error was within this many of its own 1-sigma
position errors (``Localisation.position_std``)."""
QUICK = {"seeds": range(6, 8), "sim_cap": 30.0}
"""Two small teams (a crater mission started in the crater, a maze with a rover out of range), cut short."""
LOCALISED_AFTER_M = 400.0
"""The localisation figure counts rovers that walked at least this far: dead reckoning's error grows with the
distance walked, so short walks would flatter it."""


def sim_cap(scenario: Scenario, cap_s: float | None = None) -> float:
    """The mission's simulated-time cap: ``cap_s`` when given, else from its longest ideal path."""
    if cap_s is not None:
        return cap_s
    longest = max(stats.relative_path_length(scenario, (r.x, r.z)) for r in scenario.rovers)
    return min(MAX_CAP_S, BASE_CAP_S + CAP_S_PER_M * longest)


def run_one(seed: int, kind: str | None, cap_s: float | None = None) -> dict:
    """One generated mission in lockstep; never raises (an error is a result of its own)."""
    logging.disable(logging.WARNING)  # the world's per-sample warnings would drown the progress lines
    made = generate(seed, kind)
    result = {"seed": seed, "name": made.scenario.name, "classes": made.classes, "cap_s": sim_cap(made.scenario, cap_s)}
    started = time.perf_counter()
    try:
        world, agents = run_mission_agents(made.scenario, result["cap_s"])
        report = world.report()
    except Exception as exc:  # a bug in the behaviour or the wiring: record it, go on with the suite
        return {**result, "error": f"{type(exc).__name__}: {exc}", "wall_s": time.perf_counter() - started}
    return {**result, "wall_s": round(time.perf_counter() - started, 3), "report": report.model_dump(mode="json"),
            "rovers": _rovers(world, made, agents)}


def _estimate_error(agent: RoverAgent, scenario: Scenario, x: float, z: float) -> float | None:
    """Metres between the rover's estimate (lander frame) and its true position (map frame)."""
    if agent.pose is None:
        return None
    return round(math.hypot(agent.pose.x - (x - scenario.lander.x), agent.pose.z - (z - scenario.lander.z)), 3)


def _estimate_std(agent: RoverAgent) -> float | None:
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
                    "estimate_error_m": _estimate_error(agents[r.id], scenario, r.x, r.z),
                    "estimate_std_m": _estimate_std(agents[r.id]),
                    "distance_covered_m": r.distance_covered_m, "ideal_path_m": round(ideal, 3),
                    "efficiency": round(ideal / r.distance_covered_m, 4) if r.distance_covered_m > 0 else None,
                    "walked_by_cause": {k: round(v, 2) for k, v in sorted(agents[r.id].walked.items())},
                    "detail": referee.status[r.id].detail})
    return out


# ---- aggregates ----


def failure_kind(rover: dict) -> str:
    """Why a rover did not reach, the first that applies."""
    if not rover["heard_lander"]:
        return "never heard the lander"
    if rover["state"] == "relay":
        return "relay (daisy chain)"
    if rover["state"] == "stuck":
        return "stuck (said so)"
    if rover["stalled"]:
        return "stalled (world's watchdog)"
    if rover["state"] == "done" and rover["goal_index"] == rover["final_goal_index"]:
        error, std = rover.get("estimate_error_m"), rover.get("estimate_std_m")  # runs saved before have no std
        if error is None or std is None:
            return "done but not at the goal"
        knew = error <= UNSURE_SIGMAS * std
        return f"done but not at the goal, {'knowing it was unsure' if knew else 'sure of a wrong estimate'}"
    if rover["state"] == "done":
        return "done at an earlier goal"
    return f"unfinished ({rover['state']}) at the cap"


def summarise(rows: list[dict]) -> dict:
    """Reach, collisions, stuck, efficiency and pose error of some missions' rovers."""
    rovers = [r for row in rows for r in row["rovers"]]
    reached = [r for r in rovers if r["reached"]]
    errors = sorted(r["goal_error_m"] for r in rovers)
    walked = sorted(r["estimate_error_m"] for r in rovers  # runs saved before the figure have none
                    if r.get("estimate_error_m") is not None and r["distance_covered_m"] >= LOCALISED_AFTER_M)
    efficiencies = [r["efficiency"] for r in reached if r["efficiency"] is not None]
    collisions = sum(row["report"]["rover_collisions"] + row["report"]["obstacle_collisions"] for row in rows)
    sent = [r for r in rovers if r["state"] != "relay"]  # a relay holds its spot for the others: its job
    return {"missions": len(rows), "rovers": len(rovers), "reached": len(reached),
            "reach": round(len(reached) / len(rovers), 4) if rovers else None,
            "relays": len(rovers) - len(sent),
            "reach_sent": round(sum(r["reached"] for r in sent) / len(sent), 4) if sent else None,
            "collisions": collisions, "collisions_per_mission": round(collisions / len(rows), 3) if rows else None,
            "stuck": sum(r["state"] == "stuck" or r["stalled"] for r in rovers),
            "efficiency_reached": round(statistics.fmean(efficiencies), 4) if efficiencies else None,
            "pose_error_median_m": round(statistics.median(errors), 3) if errors else None,
            "pose_error_p90_m": _p90(errors),
            "walked_400m": len(walked),
            "estimate_error_median_m": round(statistics.median(walked), 3) if walked else None,
            "estimate_error_p90_m": _p90(walked),
            "complete": sum(row["report"]["complete"] for row in rows),
            "sim_s_mean": round(statistics.fmean(row["report"]["mission_duration_s"] for row in rows), 1)
            if rows else None}


def _p90(ordered: list[float]) -> float | None:
    return round(ordered[min(len(ordered) - 1, int(0.9 * len(ordered)))], 3) if ordered else None


def aggregate(results: list[dict]) -> dict:
    ok = [row for row in results if "error" not in row]
    by_class = {f"{key}={value}": summarise([row for row in ok if row["classes"][key] == value])
                for key, values in CLASS_VALUES.items() for value in values}
    by_role = {}
    for role in ("formation", "in_crater", "out_of_range"):
        rows = [{**row, "rovers": [r for r in row["rovers"] if r["role"] == role]} for row in ok]
        by_role[role] = summarise([row for row in rows if row["rovers"]])
    failures = [{"seed": row["seed"], "classes": row["classes"], **r, "why": failure_kind(r)}
                for row in ok for r in row["rovers"] if not r["reached"]]
    return {"overall": summarise(ok), "by_class": by_class, "by_role": by_role, "errors": len(results) - len(ok),
            "stranded": stranded(ok), "walked": walked_by_cause(ok),
            "failure_kinds": dict(Counter(f["why"] for f in failures).most_common()), "failures": failures}


def walked_by_cause(rows: list[dict]) -> dict:
    """Metres the rovers that reached walked, by what they walked for (``RoverAgent.walked``), beside their ideal
    paths: where path efficiency goes. Runs saved before the figure have none."""
    reached = [r for row in rows for r in row["rovers"] if r["reached"] and "walked_by_cause" in r]
    causes: Counter = Counter()
    for r in reached:
        causes.update(r["walked_by_cause"])
    return {"rovers": len(reached), "ideal_m": round(sum(r["ideal_path_m"] for r in reached), 1),
            "covered_m": round(sum(r["distance_covered_m"] for r in reached), 1),
            "by_cause_m": {k: round(v, 1) for k, v in causes.most_common()},
            "rovers_by_cause": dict(Counter(k for r in reached for k, v in r["walked_by_cause"].items() if v > 0))}


def stranded(rows: list[dict]) -> dict:
    """Relays still holding a daisy chain's spot at the end, over the daisy family's missions: a spot the mission
    no longer needs (at the end nobody needs the route), per mission and the missions with any."""
    daisy = [row for row in rows if row["classes"]["family"] == "daisy"]
    counts = [sum(r["state"] == "relay" for r in row["rovers"]) for row in daisy]
    return {"daisy_missions": len(daisy), "relays": sum(counts), "missions_with_any": sum(c > 0 for c in counts),
            "per_mission": round(sum(counts) / len(daisy), 3) if daisy else None,
            "elsewhere": sum(r["state"] == "relay" for row in rows if row["classes"]["family"] != "daisy"
                             for r in row["rovers"])}


# ---- output ----


def _fmt(value, spec: str = "") -> str:
    return "-" if value is None else format(value, spec)


def print_table(agg: dict) -> None:
    head = (f"{'class':<24}{'missions':>9}{'rovers':>8}{'reach':>8}{'sent':>8}{'coll/m':>8}{'stuck':>7}{'eff':>7}"
            f"{'err p50':>9}{'err p90':>9}{'est p50':>9}{'est p90':>9}{'complete':>10}")
    print(head)
    print("-" * len(head))
    rows = {"all": agg["overall"], **agg["by_class"], **{f"role={k}": v for k, v in agg["by_role"].items()}}
    for label, s in rows.items():
        if not s["missions"]:
            print(f"{label:<24}{0:>9}")
            continue
        print(f"{label:<24}{s['missions']:>9}{s['rovers']:>8}{_fmt(s['reach'], '.1%'):>8}"
              f"{_fmt(s['reach_sent'], '.1%'):>8}"
              f"{_fmt(s['collisions_per_mission'], '.2f'):>8}{s['stuck']:>7}{_fmt(s['efficiency_reached'], '.2f'):>7}"
              f"{_fmt(s['pose_error_median_m'], '.1f'):>9}{_fmt(s['pose_error_p90_m'], '.1f'):>9}"
              f"{_fmt(s['estimate_error_median_m'], '.1f'):>9}{_fmt(s['estimate_error_p90_m'], '.1f'):>9}"
              f"{s['complete']:>6}/{s['missions']:<3}")
    print(f"err: distance from the final goal at the end; est: distance of each rover's own estimate from the truth "
          f"at the end, over the {agg['overall']['walked_400m']} rovers that walked {LOCALISED_AFTER_M:.0f} m or more")
    if (w := agg.get("walked")) is not None and w["rovers"]:
        causes = ", ".join(f"{k} {v:.0f} m ({w['rovers_by_cause'].get(k, 0)} rovers)"
                           for k, v in w["by_cause_m"].items())
        print(f"walked by the {w['rovers']} rovers that reached: {w['covered_m']:.0f} m for {w['ideal_m']:.0f} m of "
              f"ideal paths; by cause: {causes}")
    if (st := agg.get("stranded")) is not None:  # runs saved before the figure have none
        print(f"relays stranded: {st['relays']} in {st['missions_with_any']} of {st['daisy_missions']} daisy missions "
              f"({_fmt(st['per_mission'], '.2f')} a mission); {st['elsewhere']} in other missions")


def print_failures(agg: dict, shown: int) -> None:
    print(f"\nfailure taxonomy ({len(agg['failures'])} rovers did not reach their final goal):")
    for why, count in agg["failure_kinds"].items():
        print(f"  {count:>5}  {why}")
    for f in agg["failures"][:shown]:
        labels = " ".join(f"{k}={v}" for k, v in f["classes"].items())
        print(f"  seed {f['seed']} rover {f['id']} ({f['role']}): {f['why']}; state {f['state']}, goal "
              f"{f['goal_index']}/{f['final_goal_index']}, {f['goal_error_m']:.1f} m from its final goal, heard the "
              f"lander: {'yes' if f['heard_lander'] else 'no'}; {labels}")
    if len(agg["failures"]) > shown:
        print(f"  ... {len(agg['failures']) - shown} more in --json")


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


def run_all(seeds: range, kind: str | None, jobs: int, cap_s: float | None = None,
            keep: Callable[[list[dict]], None] | None = None) -> list[dict]:
    """Every mission's results, in seed order; ``keep`` is handed those so far after each one."""
    results = []
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        futures = [pool.submit(run_one, seed, kind, cap_s) for seed in seeds]
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
    machine = host.describe()
    print(host.line(machine))
    print(describe_seeds(args.set, seeds) + (f", kind {args.kind}" if args.kind else "") + f", {args.jobs} jobs")
    started = time.perf_counter()
    about = {"host": machine, "set": args.set, "seeds": [seeds.start, seeds.stop - 1], "kind": args.kind,
             "jobs": args.jobs}

    def keep(rows: list[dict]) -> None:  # a run cut short leaves the missions it finished (``--table`` reads them)
        args.json.write_text(json.dumps({**about, "partial": True, "missions": rows}, indent=1) + "\n")

    results = run_all(seeds, args.kind, args.jobs, args.sim_cap, keep if args.json else None)
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
