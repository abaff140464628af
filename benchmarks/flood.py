"""A client floods one rover's move_action during a real-time mission: does the world keep its pace?

Starts ``lunarsim run`` (the world routing), waits for the clock, then one client process puts rover 2's
``move_action`` as fast as it can for ``--seconds`` (valid payloads, fresh action ids, as a buggy rover would).
Meanwhile an observer follows the world's clock and every other rover's actions and their first answers, and
samples the world's RSS from /proc. Prints the clock's pace during the flood, the world's RSS growth, the other
rovers' action-to-reply latency (p50/p99), the flood's rate, and the mission's outcome.

    python benchmarks/flood.py                # 30 s flood, crater scenario
    python benchmarks/flood.py --seconds 10   # shorter
    python benchmarks/flood.py --quick        # 2 s flood, 3 rovers, the mission cut at 8 simulated seconds
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import zenoh

sys.path.insert(0, str(Path(__file__).resolve().parent))
import host
import quick

from bus.zenoh_config import build_config, open_session
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m

ROOT = Path(__file__).resolve().parents[1]
REPLY_TOPICS = (ks.NAVIGATION_STATUS, ks.ACTION_REJECTED)
QUICK = {"seconds": 2.0, "baseline": 1.0, "rovers": 3, "max_sim_time": 8.0}


def flood(endpoint: str, key: str, seconds: float, counter) -> None:
    """Put as fast as one Python client can; ``counter`` gets how many."""
    with zenoh.open(build_config(connect=[endpoint])) as session:
        publisher = session.declare_publisher(key)
        payloads = [codec.encode(m.MoveAction(x=0.0, z=2.0, action_id=10**12 + i)) for i in range(1000)]
        end, n = time.monotonic() + seconds, 0
        while time.monotonic() < end:
            for payload in payloads:
                publisher.put(payload)
            n += len(payloads)
        counter.value = n


class Observer:
    def __init__(self, keys: ks.Keyspace, flooded: int) -> None:
        self.keys, self.flooded = keys, flooded
        self.clock: list[tuple[float, float]] = []  # (wall, sim)
        self.sent: dict[tuple[int, int], float] = {}  # (rover, action id) -> wall
        self.latency: list[float] = []
        self.lock = threading.Lock()

    def on_sample(self, sample: zenoh.Sample) -> None:
        now, key = time.monotonic(), str(sample.key_expr)
        if key == self.keys.clock:
            clock = codec.decode(m.Clock, sample.payload.to_bytes())
            if clock.running:
                self.clock.append((now, clock.sim_time))
            return
        rover, topic = self.keys.parse_rover_key(key)
        if rover == self.flooded:
            return
        payload = sample.payload.to_bytes()
        if topic in (ks.MOVE_ACTION, ks.ROTATE_ACTION):
            action_id = codec.decode(m.TOPIC_MODELS[topic], payload).action_id
            with self.lock:
                self.sent.setdefault((rover, action_id), now)
        elif topic in REPLY_TOPICS:
            action_id = codec.decode(m.TOPIC_MODELS[topic], payload).action_id
            with self.lock:
                start = self.sent.pop((rover, action_id), None)
            if start is not None:
                self.latency.append(now - start)

    def pace(self, start: float, end: float) -> float | None:
        inside = [(w, s) for w, s in self.clock if start <= w <= end]
        if len(inside) < 2:
            return None
        return (inside[-1][1] - inside[0][1]) / (inside[-1][0] - inside[0][0])


def rss_mib(pid: int) -> float:
    """0 once the process has gone (the mission ended, or the world died: the outcome says which)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return 0.0
    for line in status.splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    return 0.0


def world_pid(launcher: int) -> int | None:
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                cmd = (entry / "cmdline").read_bytes().split(b"\0")
                status = (entry / "status").read_text()
            except OSError:
                continue
            if b"world_service" in b" ".join(cmd) and f"PPid:\t{launcher}" in status:
                return int(entry.name)
    return None


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))] if ordered else float("nan")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=30.0, help="how long the flood lasts")
    parser.add_argument("--scenario", type=Path, default=ROOT / "scenarios" / "crater_observation.yaml")
    parser.add_argument("--port", type=int, default=7461)
    parser.add_argument("--baseline", type=float, default=3.0, metavar="S",
                        help="seconds of running clock before the flood (default 3)")
    parser.add_argument("--rovers", type=int, help="respawn the scenario with this many rovers, 2 or more "
                        "(default: its own)")
    parser.add_argument("--max-sim-time", type=float, metavar="S",
                        help="stop the mission after S simulated seconds (default: when it ends)")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = quick.parse_args(parser, QUICK)
    if args.rovers is not None and args.rovers < 2:
        parser.error("--rovers: the flood goes to rover 2, so 2 or more")
    print(host.line(host.describe()))
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True)
    print(f"commit {commit.stdout.strip()}")
    endpoint, keys = f"tcp/127.0.0.1:{args.port}", ks.Keyspace("default")
    out = Path(tempfile.mkdtemp(prefix="flood-"))
    sizes = [*(["--rovers", str(args.rovers)] if args.rovers else []),
             *(["--max-sim-time", str(args.max_sim_time)] if args.max_sim_time else [])]
    run = subprocess.Popen([sys.executable, "-m", "deploy.cli", "run", str(args.scenario), "--quiet", "--out",
                            str(out / "run"), "--port", str(args.port), "--no-record", *sizes], cwd=ROOT,
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    observer = Observer(keys, flooded=2)
    try:
        with open_session(build_config(connect=[endpoint]), endpoint, 60.0, who="flood benchmark") as session:
            subs = [session.declare_subscriber(keys.clock, observer.on_sample)]
            for topic in (ks.MOVE_ACTION, ks.ROTATE_ACTION, *REPLY_TOPICS):
                subs.append(session.declare_subscriber(keys.rovers(topic), observer.on_sample))
            deadline = time.monotonic() + 60
            while not observer.clock and time.monotonic() < deadline:
                time.sleep(0.1)
            world = world_pid(run.pid)
            if world is None or not observer.clock:
                print("the run did not start", file=sys.stderr)
                return 1
            time.sleep(args.baseline)  # a baseline stretch before the flood
            rss_before = rss_mib(world)
            spawn = multiprocessing.get_context("spawn")  # a forked child would inherit this Zenoh session's
            counter = spawn.Value("q", 0)                 # runtime without its threads, and hang in zenoh.open
            flooder = spawn.Process(target=flood, args=(endpoint, keys.rover(2, ks.MOVE_ACTION), args.seconds,
                                                        counter))
            start = time.monotonic()
            flooder.start()
            rss_peak = rss_before
            while flooder.is_alive():
                rss_peak = max(rss_peak, rss_mib(world))
                flooder.join(timeout=0.5)
            end = time.monotonic()
            latency_during = list(observer.latency)
            run.wait(timeout=600)
            for sub in subs:
                sub.undeclare()
    finally:
        if run.poll() is None:
            os.kill(run.pid, signal.SIGINT)
            run.wait(timeout=30)
    report = json.loads((out / "run" / "report.json").read_text())
    figures = {
        "flood_seconds": round(end - start, 1),
        "flood_puts_per_s": round(counter.value / (end - start)),
        "clock_pace_during_flood": observer.pace(start, end),
        "world_rss_before_mib": round(rss_before, 1),
        "world_rss_peak_growth_mib": round(rss_peak - rss_before, 1),
        "other_rovers_replies": len(latency_during),
        "other_rovers_reply_p50_ms": round(1000 * percentile(latency_during, 0.5), 2),
        "other_rovers_reply_p99_ms": round(1000 * percentile(latency_during, 0.99), 2),
        "reached": f"{report['rovers_reached_final_goal']}/{report['rovers_total']}",
        "complete": report["complete"],
        "dropped_messages": report.get("dropped_messages"),
        "rejected_messages": report.get("rejected_messages"),
    }
    width = max(map(len, figures))
    for name, value in figures.items():
        shown = f"{value:.3f}" if isinstance(value, float) else value
        print(f"{name:<{width}}  {shown}")
    if args.json:
        args.json.write_text(json.dumps(figures, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
