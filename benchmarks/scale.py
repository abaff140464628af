"""Scale: rover agents as separate processes (or sharing processes) against the real world service, in real time
and in lockstep, on this machine; real-time factor, CPU and memory per rover, sensor delivery, start-up.

Each measurement starts the world service, the lander and the rover agents as OS processes on loopback, the
rovers forked from a warm server as ``lunarsim run`` does (see deploy/warm_start.py), on the scenario with N
rovers in its formation. ``--routing``: in the series of one process per rover and in lockstep the world is
the Zenoh router the others connect to, as in ``lunarsim run``; the real-time series of shared processes runs
behind a router process, as a ``lunarsim rover --ids`` deployment would: a world that also routes does the
routing on its own thread, and fell further behind at 750 and 1,000 rovers (``world`` or ``process`` sets one
for every series). The benchmark process watches through the same router (see scale_observe.py):

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

Then it fits cost against rover count (the slope) and checks the targets of issue 9.

    python benchmarks/scale.py --quick                      # a smoke check, under a minute
    python benchmarks/scale.py [--counts 10 50 100] [--seconds 30] [--shared-counts 1000 750 500]
                               [--per-process 250] [--lockstep-counts 5 20 100] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from functools import partial
from importlib import metadata
from pathlib import Path

import host
import scale_witness
from control_loop_latency import BenchmarkError, free_port
from proc_meter import ProcessMeter, cpu_seconds, with_descendants
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
from scale_report import holds, print_report, slopes, targets
from world_scale import SCENARIO

from bus import priority
from bus.priority import Priority, lower
from bus.zenoh_config import RouterUnreachable, build_config, open_session
from deploy.children import Children, wait_for_port
from rover_agent.app import PRELOAD
from schemas import keyspace as ks
from schemas.scenario import Scenario, dump_scenario, load_scenario
from world_service.sim import CLOCK_HZ, tick_length, ticks_per_period

WORLD = "bench"
WITNESS = Path(__file__).resolve().parent / "scale_witness.py"
HOST = "127.0.0.1"
MIN_SHARED = 50
"""The shared series halves its last count until one holds real time, down to this."""
REFINE_STEP = 50
"""Then it narrows the gap between the count that held and the lowest that did not, to this many rovers."""
STARTED_TIMEOUT_S = 60.0
"""After the last token: the world needs a clock period or two to see them all and start."""
QUICK = {"counts": [5, 10], "seconds": 5.0, "warmup": 2.0, "shared_counts": [20], "per_process": 10,
         "lockstep_counts": [5], "lockstep_sim_time": 10.0, "lockstep_repeats": 1}
FULL = {"counts": [10, 50, 100], "seconds": 30.0, "warmup": 5.0, "shared_counts": [1000, 750, 500],
        "per_process": 250, "lockstep_counts": [5, 20, 100], "lockstep_sim_time": 60.0, "lockstep_repeats": 3}

_t0 = time.monotonic()


def progress(text: str) -> None:
    print(f"[{time.monotonic() - _t0:6.0f} s] {text}", file=sys.stderr, flush=True)


@dataclass(frozen=True)
class Plan:
    """One measurement: how many rovers, how many agents share a process, real time or lockstep."""

    rovers: int
    per_process: int = 1
    lockstep: bool = False

    @property
    def processes(self) -> int:
        return -(-self.rovers // self.per_process)

    def rover_groups(self) -> list[list[str]]:
        """Command-line id arguments of each rover process."""
        if self.per_process == 1:
            return [["--id", str(i)] for i in range(1, self.rovers + 1)]
        starts = range(1, self.rovers + 1, self.per_process)
        return [["--ids", f"{a}-{min(a + self.per_process - 1, self.rovers)}"] for a in starts]

    def describe(self) -> str:
        share = "one process each" if self.per_process == 1 else f"{self.per_process} per process"
        return f"{self.rovers} rovers in {self.processes} processes ({share}), {self.mode}"

    @property
    def mode(self) -> str:
        return "lockstep" if self.lockstep else "real time"


class Cluster:
    """The router, world, lander and rover processes of one measurement; ``stop`` ends every one of them."""

    def __init__(self, logs: Path, plan: Plan, scenario_file: Path, scenario: Scenario,
                 router_process: bool = False, agents: Priority = "equal") -> None:
        self.children = Children(logs, preload=PRELOAD)
        self.plan, self.scenario_file, self.scenario = plan, scenario_file, scenario
        self.agents = agents
        """The agents' CPU priority (``bus.priority``), as ``lunarsim run`` would give them."""
        self.router_process = router_process
        self.port = free_port()
        self.endpoint = f"tcp/{HOST}:{self.port}"
        self.common = ["--world", WORLD, "--connect", self.endpoint]

    def start_router(self, world_args: list[str]) -> None:
        """The router everyone connects to: the world itself, or a router process (see ``--routing``)."""
        if self.router_process:
            hub = self.children.start("router", "deploy.router", "--listen", self.endpoint)
        else:
            hub = self.children.start("world", "world_service", str(self.scenario_file), "--world", WORLD,
                                      "--listen", self.endpoint, *world_args)
        if not wait_for_port(HOST, self.port, 30.0, hub):
            name = "router" if self.router_process else "world"
            raise BenchmarkError(f"the {name} did not open {self.endpoint}" + self.tail(name))

    def start_world_and_lander(self, world_args: list[str]) -> None:
        if self.router_process:
            self.children.start("world", "world_service", str(self.scenario_file), *self.common, *world_args)
        self.children.start("lander", "lander_agent", str(self.scenario_file), *self.common, priority=self.agents)

    def start_rovers(self) -> None:
        for ids in self.plan.rover_groups():
            self.children.start(f"rover{ids[1]}", "rover_agent", *ids, "--params", str(self.scenario_file),
                                "--behaviour", self.scenario.behaviour, *self.common, warm=True, priority=self.agents)

    def start_witness(self, out: Path, sampled: list[int]) -> None:
        """The second observer (scale_witness.py), stopped with the others; it writes ``out`` when stopped. It runs
        at the agents' priority, so what it receives, and when, is what a rover agent's Zenoh thread sees."""
        log = open(self.children.log_dir / "witness.log", "wb")  # noqa: SIM115 - the child's for its lifetime
        self.children.procs["witness"] = subprocess.Popen(
            [sys.executable, str(WITNESS), self.endpoint, WORLD, str(out), *map(str, sampled)],
            stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, preexec_fn=partial(lower, self.agents))
        log.close()
        deadline = time.monotonic() + 30.0
        while "witness ready" not in self.children.log_tail("witness", 1):
            if self.children.procs["witness"].poll() is not None or time.monotonic() > deadline:
                raise BenchmarkError("the witness did not start" + self.tail("witness"))
            time.sleep(0.05)

    def groups(self) -> dict[str, list[int]]:
        procs = self.children.procs
        roles = {"router": ["router"], "world": ["world"], "lander": ["lander"],
                 "rovers": [n for n in procs if n.startswith("rover")], "witness": ["witness"]}
        groups = {role: [procs[n].pid for n in names if n in procs] for role, names in roles.items()}
        groups["world"] = [p for pid in groups["world"] for p in with_descendants(pid)]
        return groups

    def check(self) -> None:
        dead = self.children.dead()
        if dead:
            name = next(iter(dead))
            raise BenchmarkError(f"{len(dead)} process(es) exited during the measurement: "
                                 f"{dict(list(dead.items())[:5])}" + self.tail(name))

    def tail(self, name: str) -> str:
        return f"\n--- last lines of {name}'s log:\n{self.children.log_tail(name, 10) or '(empty)'}"

    def stop(self) -> None:
        hub = "router" if self.router_process else "world"
        self.children.stop([n for n in self.children.procs if n != hub], grace_s=10.0)
        self.children.stop([hub])


# ---- one measurement ----


@dataclass
class Setting:
    """What every measurement shares, from the command line."""

    scenario: Path
    seconds: float
    warmup: float
    sample: int
    startup_timeout: float
    lockstep_sim_time: float
    lockstep_timeout: float
    work: Path
    witness: bool
    lockstep_sample: int = 0
    routing: str = "auto"
    agent_priority: str = "auto"

    def router_process(self, plan: Plan) -> bool:
        """Whether ``plan`` runs behind a router process rather than the world routing (see ``--routing``)."""
        if self.routing == "auto":
            return plan.per_process > 1 and not plan.lockstep
        return self.routing == "process"


def sampled_ids(rovers: int, k: int) -> list[int]:
    """``k`` rover ids spread evenly over 1..rovers, first and last included."""
    k = min(k, rovers)
    return [1] if k == 1 else sorted({round(1 + i * (rovers - 1) / (k - 1)) for i in range(k)})


def periods(scenario: Scenario) -> tuple[float, dict[str, int]]:
    """The world's tick and each sensor's period in ticks, from the scenario's rover parameters."""
    p = scenario.rover_params
    dt = tick_length(p)
    return dt, {ks.PERCEPTION: ticks_per_period(p.perception.publish_frequency, dt),
                ks.GYROSCOPE: ticks_per_period(p.perception.gyroscope_frequency, dt),
                ks.NAVIGATION_STATUS: ticks_per_period(p.navigation.publish_frequency, dt)}


def measure(plan: Plan, s: Setting) -> dict:
    progress(f"starting {plan.describe()}")
    scenario = load_scenario(s.scenario).with_overrides(rovers=plan.rovers)
    run_dir = Path(tempfile.mkdtemp(prefix=f"scale-{plan.rovers}-", dir=s.work))
    scenario_file = run_dir / "scenario.yaml"
    scenario_file.write_text(dump_scenario(scenario))
    cluster = Cluster(run_dir / "logs", plan, scenario_file, scenario, s.router_process(plan),
                      priority.for_mode(s.agent_priority, plan.lockstep))
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
    row.update(routing="router process" if cluster.router_process else "world", agent_priority=cluster.agents,
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


def code_version() -> dict:
    """The commit measured, and files changed since it (a benchmark of a working tree says which one)."""
    repo = Path(__file__).resolve().parents[1]

    def git(*cmd: str) -> str:
        out = subprocess.run(["git", "-C", str(repo), *cmd], capture_output=True, text=True)
        return out.stdout.rstrip("\n") if out.returncode == 0 else ""  # porcelain lines start with a space

    changed = [line[3:] for line in git("status", "--porcelain", "--untracked-files=no").splitlines()]
    return {"commit": git("rev-parse", "--short", "HEAD"), "uncommitted_changes": changed}


def run(args: argparse.Namespace) -> int:
    doc = {"benchmark": "scale", "cpus": os.cpu_count(), "python": platform.python_version(),
           "zenoh": metadata.version("eclipse-zenoh"), "platform": platform.platform(), "host": host.describe(),
           "code": code_version(), "scenario": str(args.scenario),
           "settings": {k: v for k, v in vars(args).items() if k != "json"},
           "load_at_start": os.getloadavg(), "rows": [], "notes": []}
    work = Path(tempfile.mkdtemp(prefix="lunarsim-scale-", dir=args.logs))
    s = Setting(args.scenario, args.seconds, args.warmup, args.sample, args.startup_timeout,
                args.lockstep_sim_time, args.lockstep_timeout, work, not args.no_witness, args.lockstep_sample,
                args.routing, args.agent_priority)
    try:
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


def median_run(rows: list[dict]) -> dict:
    """The run of median real-time factor (the lower middle of an even number), with every run's factor in run
    order (None for one that failed) under ``repeats``; the first failure if every run failed."""
    ok = sorted((r for r in rows if "error" not in r), key=lambda r: r["real_time_factor"])
    if not ok:
        return rows[0]
    return {**ok[(len(ok) - 1) // 2], "repeats": [r.get("real_time_factor") for r in rows]}



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
    too); then the highest count holding, found by halving the gap to the lowest that did not, to ``REFINE_STEP``
    (None if no count holds). After the counts asked for, the last one is halved until a count holds or it is below
    ``MIN_SHARED``."""

    def held(n: int) -> bool:
        tried.append(n)
        row = attempt(Plan(n, per_process=args.per_process), s)
        rows.append(row)
        return holds(row)

    counts = sorted(args.shared_counts, reverse=True)
    failed = None
    while counts:
        n = counts.pop(0)
        if held(n):
            return refine(n, failed, held)
        failed = n
        if not counts and n // 2 >= MIN_SHARED:
            counts.append(n // 2)
    return None


def refine(holding: int, failed: int | None, held) -> int:
    """The highest count that holds, between ``holding`` (holds) and ``failed`` (does not), to REFINE_STEP."""
    while failed is not None and failed - holding > REFINE_STEP:
        middle = round((holding + failed) / 2 / REFINE_STEP) * REFINE_STEP
        if middle in (holding, failed):
            break
        if held(middle):
            holding = middle
        else:
            failed = middle
    return holding


# ---- command line ----


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="a smoke check: small counts, short windows "
                        f"({', '.join(f'{k} {v}' for k, v in QUICK.items())})")
    parser.add_argument("--counts", type=int, nargs="+", metavar="N",
                        help=f"real time, one process per rover (default {FULL['counts']})")
    parser.add_argument("--seconds", type=float, metavar="S", help="measuring window in real time "
                        f"(default {FULL['seconds']:g})")
    parser.add_argument("--warmup", type=float, metavar="S", help="running clock before the window "
                        f"(default {FULL['warmup']:g})")
    parser.add_argument("--shared-counts", type=int, nargs="+", metavar="N", help="real time, rovers sharing "
                        f"processes, largest first until one holds (default {FULL['shared_counts']})")
    parser.add_argument("--per-process", type=int, metavar="K", help="agents per process in the shared series "
                        f"(default {FULL['per_process']})")
    parser.add_argument("--lockstep-counts", type=int, nargs="+", metavar="N",
                        help=f"lockstep, one process per rover (default {FULL['lockstep_counts']})")
    parser.add_argument("--lockstep-sim-time", type=float, metavar="S", help="cap of each lockstep mission in "
                        f"simulated seconds (default {FULL['lockstep_sim_time']:g})")
    parser.add_argument("--lockstep-repeats", type=int, metavar="R", help="runs of each lockstep measurement, "
                        f"interleaved; the median is reported (default {FULL['lockstep_repeats']}, "
                        f"--quick {QUICK['lockstep_repeats']})")
    parser.add_argument("--lockstep-timeout", type=float, default=900.0, metavar="S",
                        help="wall seconds a lockstep mission may take (default 900)")
    parser.add_argument("--skip-lockstep", action="store_true")
    parser.add_argument("--skip-1000", action="store_true", help="leave out the shared-process series")
    parser.add_argument("--no-witness", action="store_true", help="no second observer process (it tells a "
                        "sample lost before the router's per-subscriber queues from one lost on the way to the "
                        "benchmark)")
    parser.add_argument("--sample", type=int, default=10, metavar="K", help="rovers whose sensors are followed "
                        "(spread over the ids; default 10)")
    parser.add_argument("--lockstep-sample", type=int, default=0, metavar="K",
                        help="rovers whose sensors are followed in lockstep (default 0: the speed-up is the run's "
                             "own; following sensors makes the router copy them to this process and a witness, "
                             "which on two cores slowed a 5-rover mission from 10.1 to 7.1 times real time)")
    parser.add_argument("--startup-timeout", type=float, default=180.0, metavar="S",
                        help="seconds for every rover to connect (default 180)")
    parser.add_argument("--routing", choices=("auto", "world", "process"), default="auto",
                        help="who routes: the world (as lunarsim run), a router process, or auto (default): the "
                             "world, but a router process for the shared-process real-time series")
    parser.add_argument("--agent-priority", choices=priority.CHOICES, default="auto",
                        help="as lunarsim run's (the witness runs at it too): " + priority.HELP)
    parser.add_argument("--scenario", type=Path, default=SCENARIO, help="default: crater_observation.yaml")
    parser.add_argument("--logs", type=Path, metavar="DIR", help="keep the processes' logs under DIR")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures to FILE as JSON")
    args = parser.parse_args(argv)
    for key, value in (QUICK if args.quick else FULL).items():
        if getattr(args, key) is None:
            setattr(args, key, value)
    check_args(parser, args)
    return args


def check_args(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    counts = [*args.counts, *args.shared_counts, *args.lockstep_counts]
    if min(counts) < 1 or min(args.per_process, args.sample, args.lockstep_repeats) < 1 or args.lockstep_sample < 0:
        parser.error("rover counts, --per-process, --sample and --lockstep-repeats must be 1 or more, "
                     "--lockstep-sample 0 or more")
    if args.seconds <= 0 or args.warmup < 0 or args.lockstep_sim_time <= 0:
        parser.error("--seconds and --lockstep-sim-time must be more than 0, --warmup 0 or more")
    if not args.scenario.is_file():
        parser.error(f"--scenario {args.scenario}: no such file")
    if args.logs is not None:
        args.logs.mkdir(parents=True, exist_ok=True)


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    signal.signal(signal.SIGTERM, _interrupt)  # a terminated benchmark stops its processes as on Ctrl-C
    try:
        return run(args)
    except (BenchmarkError, RouterUnreachable) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("interrupted: every process it started is stopped", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
