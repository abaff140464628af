"""Scale: rover agents as separate processes (or sharing processes) against the real world service, in real time
and in lockstep, on this machine; real-time factor, CPU and memory per rover, sensor delivery, start-up.

Each measurement starts the world service, the lander and the rover agents as OS processes on loopback, the rovers
forked from a warm server as ``lunarsim run`` does (see deploy/warm_start.py), on the scenario with N rovers in its
formation. ``--routing``: in the series of one process per rover and in lockstep the world is the Zenoh router the
others connect to, as in ``lunarsim run``; the real-time series of shared processes runs behind a router process, as
a ``lunarsim rover --ids`` deployment would (``world`` or ``process`` sets one for every series; docs/benchmarks.md
has 1,000 shared rovers both ways). The benchmark process watches through the same router (see scale_observe.py):

- real time (``--time-scale 1``): after every agent is connected and ``--warmup`` seconds of running clock,
  a window of ``--seconds``: simulated seconds per wall second (from the world's own clock samples), CPU of
  every process (/proc), memory at the end (Rss and Pss), and delivery of the sampled rovers' sensors;
- lockstep: the whole mission (or ``--lockstep-sim-time`` simulated seconds), timed from the first running
  clock to the world's final statistics, so start-up is left out; unwatched by default (the first running clock
  and the statistics), since following sensors, or the clock at every tick, would make the router copy them
  here and slow the clock it times (``--lockstep-sample K`` follows K rovers, and the clock, anyway); each
  lockstep measurement is run ``--lockstep-repeats`` times, interleaved with the others, and its median kept;
- start-up: from spawning the rover processes until the benchmark sees every rover's liveliness token.

The agents run at the CPU priority ``lunarsim run`` gives them (``--agent-priority``, see bus/priority.py):
in real time below the world's. The benchmark's own observer keeps the default priority; the witness process
runs at the agents', so its delivery figures are those a rover agent's Zenoh thread sees.

Then it fits cost against rover count (the slope) and checks the scale targets.

    python benchmarks/scale.py --quick                      # a smoke check in seconds
    python benchmarks/scale.py [--counts 10 50 100] [--seconds 30] [--shared-counts 1000 750 500]
                               [--per-process 250] [--lockstep-counts 5 20 100] [--json FILE]
    python benchmarks/scale.py --two-hosts ...               # the rovers on a second host (scale_hosts.py)
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

import host
import scale_witness
from control_loop_latency import BenchmarkError, guarded
from proc_meter import ProcessMeter, cpu_seconds
from scale_args import parse_args
from scale_cluster import WORLD, Cluster, Plan, Setting, periods, progress, sampled_ids
from scale_hosts import two_hosts
from scale_observe import (
    Observer,
    agent_lag,
    clock_missing,
    combined_latency,
    delivery,
    drop_events,
    late_events,
    missing_samples,
    no_collector_pauses,
    schedule_lateness,
    sim_rate,
)
from scale_report import highest_holding, holds, median_run, print_report, slopes, targets

from bus import priority
from bus.zenoh_config import build_config, open_session
from schemas import keyspace as ks
from schemas.scenario import Scenario, dump_scenario, load_scenario
from world_service.clock import CLOCK_HZ, ticks_per_period

STARTED_TIMEOUT_S = 60.0
"""After the last token: the world needs a clock period or two to see them all and start."""
# ---- one measurement ----


def measure(plan: Plan, s: Setting) -> dict:
    progress(f"starting {plan.describe()}")
    scenario = load_scenario(s.scenario).with_overrides(rovers=plan.rovers)
    run_dir = Path(tempfile.mkdtemp(prefix=f"scale-{plan.rovers}-", dir=s.work))
    scenario_file = run_dir / "scenario.yaml"
    scenario_file.write_text(dump_scenario(scenario))
    cluster = Cluster(run_dir / "logs", plan, scenario_file, scenario, s.router_process(plan),
                      priority.for_mode(s.agent_priority, plan.lockstep, plan.rovers), s.hosts)
    observer = None
    load_before = os.getloadavg()
    try:
        cluster.start_router(world_arguments(plan, s))
        session = open_session(build_config(connect=[cluster.endpoint]), cluster.endpoint, 10.0, who="benchmark")
        k = s.lockstep_sample if plan.lockstep else s.sample
        observer = Observer(session, ks.Keyspace(WORLD), sampled_ids(plan.rovers, k) if k else [],
                            first_clock_only=plan.lockstep and not k)
        watched = s.witness and bool(observer.sampled)
        if watched:
            cluster.start_witness(run_dir / "witness.json", observer.sampled)
        cluster.start_world_and_lander(world_arguments(plan, s))
        startup, startup_cpu = start_rovers(cluster, observer, s.startup_timeout)
        waited = observer.pump_until(lambda: observer.started, STARTED_TIMEOUT_S, cluster.check)
        if not waited:
            raise BenchmarkError("every rover is connected but the world's clock did not start" + cluster.tail("world"))
        with no_collector_pauses():
            window = (lockstep_window if plan.lockstep else realtime_window)(cluster, observer, s)
    finally:
        if observer is not None:
            observer.close()
            observer.session.close()
        cluster.stop()
    row = summarise(plan, s, scenario, observer, window)
    if watched:
        row["witness"] = compare_witness(run_dir / "witness.json", observer, window, scenario, plan.lockstep)
    row.update(routing="router process" if cluster.router_process else "world", hosts=2 if s.hosts else 1,
               agent_priority=cluster.agents,
               startup_s=round(startup, 2), startup_cpu_s_per_process=round(startup_cpu, 3), load_before=load_before,
               load_after=os.getloadavg())
    progress(f"done: real-time factor {row['real_time_factor']:.3f}, CPU per rover "
             f"{row['cpu_per_rover_pct']:.2f} % of a core, start-up {startup:.1f} s")
    return row


def world_arguments(plan: Plan, s: Setting) -> list[str]:
    args = ["--start-timeout", str(s.startup_timeout + STARTED_TIMEOUT_S)]
    if plan.lockstep:
        return [*args, "--lockstep", "--max-sim-time", str(s.lockstep_sim_time)]
    # long enough that the window never outlives the mission's cap (a completed mission ends it early: reported)
    return [*args, "--time-scale", "1", "--max-sim-time", str(10 * (s.warmup + s.seconds) + 60)]


def start_rovers(cluster: Cluster, observer: Observer, timeout: float) -> tuple[float, float]:
    """Spawn the rover processes: seconds until the benchmark sees every rover's liveliness token, and the CPU
    seconds each rover process had used by then (on a small machine, start-up is mostly that CPU, queued)."""
    start = time.monotonic()
    cluster.start_rovers()
    n = cluster.plan.rovers
    if not observer.pump_until(lambda: len(observer.alive) >= n, timeout, cluster.check):
        raise BenchmarkError(f"only {len(observer.alive)} of {n} rovers connected within {timeout:g} s"
                             + cluster.tail(next(name for name in cluster.children.procs if name.startswith("rover"))))
    took = time.monotonic() - start
    pids = cluster.groups()["rovers"]
    cpu = sum(cpu_seconds(pid) for pid in pids) / len(pids)
    progress(f"all {n} rovers connected after {took:.1f} s ({cpu:.2f} CPU s per rover process); waiting for the clock")
    return took, cpu


@dataclass
class Window:
    start_ns: int
    end_ns: int
    cpu: dict[str, float]
    machine: dict[str, float]
    memory: dict[str, dict[str, float]]
    benchmark_cpu: float
    ended_early: bool
    outsiders: dict[str, float]


def realtime_window(cluster: Cluster, observer: Observer, s: Setting) -> Window:
    observer.pump_until(lambda: observer.final is not None, s.warmup, cluster.check)
    progress(f"clock running; measuring for {s.seconds:g} s")
    return timed(cluster, observer, lambda: observer.pump_until(lambda: observer.final is not None, s.seconds,
                                                               cluster.check))


def lockstep_window(cluster: Cluster, observer: Observer, s: Setting) -> Window:
    progress(f"clock running; waiting for the end of the mission (at most {s.lockstep_sim_time:g} s simulated)")

    def until_final() -> bool:
        if not observer.pump_until(lambda: observer.final is not None, s.lockstep_timeout, cluster.check):
            raise BenchmarkError(f"the lockstep mission did not end within {s.lockstep_timeout:g} s")
        return True

    window = timed(cluster, observer, until_final)
    window.start_ns, window.end_ns = observer.ticks[0].published_ns, observer.final.published_ns
    window.ended_early = False
    return window


def timed(cluster: Cluster, observer: Observer, wait) -> Window:
    """CPU of every process and of the benchmark over ``wait()`` (True when the mission ended), memory at its end."""
    meter = ProcessMeter(cluster.groups())
    meter.mark()
    own = _own_cpu()
    start_ns, start = time.time_ns(), time.monotonic()
    ended = wait()
    end_ns = time.time_ns()
    meter.mark()
    own = (_own_cpu() - own) / (time.monotonic() - start)
    return Window(start_ns, end_ns, meter.cpu(), meter.machine(), meter.memory(), own, ended, meter.outsiders())


def _own_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def summarise(plan: Plan, s: Setting, scenario: Scenario, observer: Observer, w: Window) -> dict:
    dt, per = periods(scenario)
    if plan.lockstep:
        first, final = observer.ticks[0], observer.final
        sim = final.stamp - first.sim_time
        wall = (final.published_ns - first.published_ns) / 1e9
        factor = sim / wall
    else:
        sim, wall, factor = sim_rate(observer.ticks, w.start_ns, w.end_ns)
    witness = w.cpu.pop("witness", 0.0)
    cpu = {**w.cpu, "total": sum(w.cpu.values())}
    machine = {**w.machine, "other_cores": w.machine["busy_cores"] - cpu["total"] - w.benchmark_cpu - witness}
    memory = {name: mem for name, mem in w.memory.items() if name != "witness"}
    memory["total"] = {k: sum(g[k] for g in memory.values()) for k in ("rss_mib", "pss_mib")}
    n = plan.rovers
    return {
        "mode": "lockstep" if plan.lockstep else "realtime", "rovers": n, "processes": plan.processes,
        "agents_per_process": plan.per_process, "sampled_rovers": observer.sampled,
        "sim_s": round(sim, 3), "wall_s": round(wall, 3), "real_time_factor": round(factor, 4),
        "mission_ended_in_window": w.ended_early,
        "mission_duration_s": observer.final.report.mission_duration_s if observer.final else None,
        "cpu_cores": {k: round(v, 4) for k, v in cpu.items()},
        "cpu_seconds_per_sim_second": {k: round(v / factor, 4) if factor > 0 else None for k, v in cpu.items()},
        "machine_cores": {k: round(v, 3) for k, v in machine.items()},
        "cpu_per_rover_pct": round(100 * cpu["rovers"] / n, 3),
        "memory_mib": {k: {kk: round(vv, 1) for kk, vv in v.items()} for k, v in memory.items()},
        "memory_per_rover_mib": {k: round(v / n, 2) for k, v in memory["rovers"].items()},
        "latency_ms": combined_latency(observer.readings, w.start_ns, w.end_ns),
        "delivery": delivery(observer.readings, w.start_ns, w.end_ns, dt, per, None if plan.lockstep else 1.0),
        "agent_lag_ms": agent_lag(observer.readings, observer.ticks, w.start_ns, w.end_ns, dt,
                                  None if plan.lockstep else 1.0),
        # lockstep publishes a clock only on ticks that wait for an ack: a gap there is no loss
        "clock_samples_missing": None if plan.lockstep else clock_missing(observer.ticks, w.start_ns, w.end_ns,
                                                                           clock_ticks(dt)),
        "drop_events": drop_events(observer.readings, w.start_ns, w.end_ns, dt, per),
        "late_events": [] if plan.lockstep else late_events(observer.readings, w.start_ns, w.end_ns, dt, per),
        "schedule": None if plan.lockstep else schedule_lateness(observer.readings, w.start_ns, w.end_ns, dt, per),
        "benchmark_cpu_cores": round(w.benchmark_cpu, 4),
        "outside_processes_cores": w.outsiders,
        "witness_cpu_cores": round(witness, 4),
        "undecodable_samples": observer.rejected,
    }


def compare_witness(path: Path, observer: Observer, w: Window, scenario: Scenario, lockstep: bool) -> dict:
    """Samples missing at the benchmark, at the witness, and at both (lost before the router's per-subscriber
    queues, so the agents lose them too); in real time, how late the samples reached the witness, which runs at the
    agents' priority: what a rover agent's Zenoh thread sees."""
    dt, per = periods(scenario)
    readings, ticks = scale_witness.load(path)
    ours = missing_samples(observer.readings, w.start_ns, w.end_ns, dt, per)
    theirs = missing_samples(readings, w.start_ns, w.end_ns, dt, per)
    out = {"received": sum(1 for r in readings if w.start_ns <= r.received_ns <= w.end_ns),
           "dropped": len(theirs), "dropped_at_both": len(ours & theirs),
           "clock_samples_missing": clock_missing(ticks, w.start_ns, w.end_ns, clock_ticks(dt))}
    if not lockstep:
        topics = delivery(readings, w.start_ns, w.end_ns, dt, per, 1.0)
        out.update(latency_ms=combined_latency(readings, w.start_ns, w.end_ns),
                   over_one_period=sum(t["over_one_period"] for t in topics.values()),
                   schedule=schedule_lateness(readings, w.start_ns, w.end_ns, dt, per))
    return out


def clock_ticks(dt: float) -> int:
    """Ticks between two clock samples in real time."""
    return ticks_per_period(CLOCK_HZ, dt)


# ---- the whole benchmark ----


def supports_ids() -> bool:
    """``lunarsim rover --ids`` (many agents in one process) is what the shared-process series needs."""
    out = subprocess.run([sys.executable, "-m", "deploy.cli", "rover", "--help"], capture_output=True, text=True)
    return "--ids" in out.stdout


def run(args: argparse.Namespace) -> int:
    doc = {"benchmark": "scale", "cpus": os.cpu_count(), "python": platform.python_version(),
           "zenoh": metadata.version("eclipse-zenoh"), "platform": platform.platform(), "host": host.describe(),
           "code": host.code_version(), "scenario": str(args.scenario),
           "settings": {k: v for k, v in vars(args).items() if k != "json"},
           "load_at_start": os.getloadavg(), "rows": [], "notes": []}
    work = Path(tempfile.mkdtemp(prefix="lunarsim-scale-", dir=args.logs))
    s = Setting(args.scenario, args.seconds, args.warmup, args.sample, args.startup_timeout,
                args.lockstep_sim_time, args.lockstep_timeout, work, not args.no_witness, args.lockstep_sample,
                args.routing, args.agent_priority)
    try:
        with contextlib.ExitStack() as stack:
            if args.two_hosts:
                s.hosts = stack.enter_context(two_hosts())
                doc["hosts"] = {"hub": s.hosts.hub, "fleet": s.hosts.fleet}
                progress(f"two hosts: namespace {s.hosts.hub} (world, lander, router) and {s.hosts.fleet} (rovers, "
                         "router)")
            run_series(args, s, doc)
    finally:
        doc["load_at_end"] = os.getloadavg()
        doc["slopes"] = slopes(doc["rows"], os.cpu_count() or 1)
        doc["targets"] = targets(doc)
        if args.logs is None:
            shutil.rmtree(work, ignore_errors=True)
        else:
            doc["logs"] = str(work)
        print_report(doc)
        if args.json:
            args.json.write_text(json.dumps(doc, indent=2, default=str) + "\n", encoding="utf-8")
            print(f"figures written to {args.json}")
    return 0


def run_series(args: argparse.Namespace, s: Setting, doc: dict) -> None:
    rows = doc["rows"]
    for n in args.counts:
        rows.append(attempt(Plan(n), s))
    if not args.skip_1000:
        if supports_ids():
            doc["shared_counts_tried"] = []
            doc["highest_shared_holding"] = step_down(args, s, rows, doc["shared_counts_tried"])
        else:
            doc["notes"].append("skipped the shared-process series: this lunarsim rover has no --ids yet")
            progress(doc["notes"][-1])
    if not args.skip_lockstep:
        rows += lockstep_series(args, s)


def lockstep_series(args: argparse.Namespace, s: Setting) -> list[dict]:
    """Each lockstep count, and the smallest with every rover agent in one process (the cost of processes),
    ``--lockstep-repeats`` times, interleaved so that each sees the machine as the others do: a lockstep factor
    swings by a quarter with the host's load from one minute to the next. Reports each plan's median run."""
    n = min(args.lockstep_counts)
    plans = [*(Plan(c, lockstep=True) for c in args.lockstep_counts), Plan(n, per_process=n, lockstep=True)]
    runs: list[list[dict]] = [[] for _ in plans]
    for _ in range(args.lockstep_repeats):
        for plan, done in zip(plans, runs, strict=True):
            done.append(attempt(plan, s))
    return [median_run(done) for done in runs]


def attempt(plan: Plan, s: Setting) -> dict:
    """One measurement; one that cannot finish (rovers not connected in time, a process died) is a row saying why,
    and the series goes on: a count that does not start does not hold real time either."""
    try:
        return measure(plan, s)
    except BenchmarkError as exc:
        progress(f"failed: {exc}")
        return {"mode": "lockstep" if plan.lockstep else "realtime", "rovers": plan.rovers,
                "processes": plan.processes, "agents_per_process": plan.per_process, "error": str(exc)}


def step_down(args: argparse.Namespace, s: Setting, rows: list[dict], tried: list[int]) -> int | None:
    """Shared processes, largest count first, until one holds real time (``scale_report.holds``: its agents keep up
    too); the counts tried as ``highest_holding`` picks them."""

    def held(n: int) -> bool:
        tried.append(n)
        row = attempt(Plan(n, per_process=args.per_process), s)
        rows.append(row)
        return holds(row)

    return highest_holding(args.shared_counts, held, args.step_down)


def main(argv: list[str] | None = None) -> int:
    return guarded(run, parse_args(argv, __doc__.split("\n\n")[0]), "interrupted: every process it started is stopped")


if __name__ == "__main__":
    sys.exit(main())
