"""What it costs a process to be woken by a Zenoh sample, with nothing of LunarSim in it: the CPU floor under every
agent's per-tick work.

A router process (``lunarsim router``) and a bare zenoh-python subscriber process (the session configuration the
rover agent uses, a callback that only counts) on loopback; this script publishes small samples to it, one at a
time or in bursts, a fixed gap apart, and reads both processes' CPU time from /proc before and after. The same
span with nothing sent is measured too and taken off, so what is left is the samples' own cost. The modes take
turns, round by round, and the medians are printed.

Through processes, a lockstep tick wakes every agent (its gyroscope sample and the clock come together): the
figure per wake, times the agents, is CPU each tick spends before any agent code runs.

    python benchmarks/wake_cost.py [--samples 2000] [--rounds 3] [--json out.json]
    python benchmarks/wake_cost.py --quick
    python benchmarks/wake_cost.py --subscriber tcp/127.0.0.1:7447   # the subscriber, as the benchmark starts it
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

import host
import quick
import zenoh
from proc_meter import cpu_seconds

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bus.zenoh_config import build_config, open_session, port_in_use  # noqa: E402
from deploy.children import wait_for_port  # noqa: E402

KEY = "bench/wake/rover/1/gyroscope"
PAYLOAD = bytes(40)  # about a gyroscope sample's size
BURSTS = (1, 2, 4)
QUICK = {"samples": 200, "rounds": 1}
STOP_WAIT_S = 10.0


def subscriber(endpoint: str) -> int:
    """Count samples until stdin closes; say "ready" once subscribed."""
    with open_session(build_config(connect=[endpoint]), endpoint, 10.0, who="wake_cost") as session:
        count = [0]
        session.declare_subscriber(KEY, lambda sample: count.__setitem__(0, count[0] + 1))
        print("ready", flush=True)
        sys.stdin.read()
        print(count[0], flush=True)
    return 0


def measure(publisher: zenoh.Publisher, pids: dict[str, int], samples: int, burst: int, gap_s: float,
            send: bool = True) -> dict:
    """CPU seconds of each process over ``samples`` sent ``burst`` at a time, ``gap_s`` apart; with ``send`` False,
    the same span with nothing sent."""
    before = {name: cpu_seconds(pid) for name, pid in pids.items()}
    for _ in range(samples // burst):
        for _ in range(burst if send else 0):
            publisher.put(PAYLOAD)
        time.sleep(gap_s)
    time.sleep(0.2)  # the last samples delivered
    return {name: cpu_seconds(pid) - before[name] for name, pid in pids.items()}


def run(args: argparse.Namespace) -> dict:
    endpoint = f"tcp/127.0.0.1:{args.port}"
    if port_in_use("127.0.0.1", args.port):
        raise SystemExit(f"error: port {args.port} on 127.0.0.1 is in use: pass --port")
    router = subprocess.Popen([sys.executable, "-m", "deploy.cli", "router", "--listen", endpoint], cwd=REPO,
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    sub = None
    try:
        if not wait_for_port("127.0.0.1", args.port, 30, router):
            raise SystemExit(f"error: the router did not open {endpoint}")
        sub = subprocess.Popen([sys.executable, __file__, "--subscriber", endpoint], cwd=REPO, text=True,
                               stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        if sub.stdout.readline().strip() != "ready":
            raise SystemExit("error: the subscriber did not start")
        pids = {"subscriber": sub.pid, "router": router.pid}
        per_sample: dict[int, dict[str, list[float]]] = {b: {name: [] for name in pids} for b in BURSTS}
        with open_session(build_config(connect=[endpoint]), endpoint, 10.0, who="wake_cost") as session:
            publisher = session.declare_publisher(KEY)
            time.sleep(0.5)  # the subscription known to the router
            for _ in range(args.rounds):
                for burst in BURSTS:
                    gap_s = args.gap_ms / 1000 * burst
                    busy = measure(publisher, pids, args.samples, burst, gap_s)
                    idle = measure(publisher, pids, args.samples, burst, gap_s, send=False)
                    for name in pids:
                        per_sample[burst][name].append((busy[name] - idle[name]) / args.samples * 1e6)
        sub.stdin.close()
        received = int(sub.stdout.readline())
    finally:
        for proc in (p for p in (sub, router) if p is not None):
            proc.terminate()
            try:
                proc.wait(timeout=STOP_WAIT_S)
            except subprocess.TimeoutExpired:  # measured already: a slow exit must not lose the figures
                proc.kill()
                proc.wait()
    return {"samples": args.samples, "rounds": args.rounds, "gap_ms": args.gap_ms, "received": received,
            "sent": args.samples * len(BURSTS) * args.rounds, "host": host.describe(),
            "us_per_sample": {str(b): {name: round(statistics.median(v), 1) for name, v in per_sample[b].items()}
                              for b in BURSTS}}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=2000, help="samples a mode sends in a round (default 2000)")
    parser.add_argument("--rounds", type=int, default=3, help="rounds; the modes take turns in each (default 3)")
    parser.add_argument("--gap-ms", type=float, default=2.0, metavar="MS",
                        help="quiet after each sample's share of a burst (default 2 ms: a burst of 4 is 8 ms apart)")
    parser.add_argument("--port", type=int, default=7548, help="the router's port on 127.0.0.1 (default 7548)")
    parser.add_argument("--json", type=Path, help="write the figures here")
    parser.add_argument("--subscriber", metavar="ENDPOINT", help=argparse.SUPPRESS)
    args = quick.parse_args(parser, QUICK)
    if args.subscriber:
        return subscriber(args.subscriber)
    result = run(args)
    print(host.line(result["host"]))
    print(f"{result['received']} of {result['sent']} samples received; CPU per sample, medians of {args.rounds} "
          f"round(s) of {args.samples}, the same span with nothing sent taken off:")
    for burst, row in result["us_per_sample"].items():
        print(f"  {burst} a wake, {args.gap_ms * int(burst):g} ms apart: subscriber {row['subscriber']:.0f} us, "
              f"router {row['router']:.0f} us a sample")
    if args.json:
        args.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
