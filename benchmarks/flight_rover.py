"""The rover agent as a flight computer runs it: resident memory and start-up time, beside a bare Zenoh client.

Builds the ``lunarsim-rover`` wheel, installs it into a fresh virtual environment (only what the rover needs),
starts a Zenoh router, then starts, several times each:

- a bare Zenoh client process (open a session, one subscriber, one liveliness token): the floor;
- the rover agent from the flight environment (``lunarsim-rover --id 1``).

Start-up is the wall time from process start until its liveliness token is seen on the router (the world
would now count it present); memory is the resident set (VmRSS) once it has run for a few seconds, and its peak
(VmHWM). Both are printed, with the agent's share over the bare client, and written as JSON.

    python benchmarks/flight_rover.py [--runs 5] [--venv DIR] [--json out.json]
    python benchmarks/flight_rover.py --quick    # one run of each, memory after 1 s (the build is the same)
"""

from __future__ import annotations

import argparse
import json
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import BinaryIO

import quick
import zenoh

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bus.zenoh_config import build_config  # noqa: E402
from deploy.children import wait_for_port  # noqa: E402
from deploy.flight.build_wheel import build  # noqa: E402
from schemas.keyspace import Keyspace  # noqa: E402

SETTLE_S = 3.0
"""Memory is read once a process has run this long (``--settle``)."""
STOP_WAIT_S = 30.0
"""How long a process may take to end after SIGTERM: the agent's own shutdown deadline, with room to spare."""
QUICK = {"runs": 1, "settle": 1.0}
BARE_CLIENT = """
import sys, time, zenoh
conf = zenoh.Config()
conf.insert_json5("mode", '"client"')
conf.insert_json5("connect/endpoints", '["' + sys.argv[1] + '"]')
conf.insert_json5("scouting/multicast/enabled", "false")
conf.insert_json5("transport/shared_memory/enabled", "false")  # as LunarSim's own sessions
session = zenoh.open(conf)
sub = session.declare_subscriber("lunar/bench/rover/1/**", lambda s: None)
token = session.liveliness().declare_token(sys.argv[2])
time.sleep(3600)
"""


def flight_venv(where: Path) -> Path:
    wheel = build(where / "dist", REPO)
    venv = where / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
    subprocess.run([str(venv / "bin" / "pip"), "install", "--quiet", str(wheel)], check=True)
    return venv


def memory_kib(pid: int) -> tuple[int, int]:
    fields = {}
    for line in Path(f"/proc/{pid}/status").read_text().splitlines():
        name, _, value = line.partition(":")
        if name in ("VmRSS", "VmHWM"):
            fields[name] = int(value.split()[0])
    return fields["VmRSS"], fields["VmHWM"]


def measure(argv: list[str], session: zenoh.Session, token_key: str, settle_s: float) -> dict:
    seen = threading.Event()
    sub = session.liveliness().declare_subscriber(token_key, lambda s: s.kind == zenoh.SampleKind.PUT and seen.set())
    start = time.monotonic()
    with tempfile.TemporaryFile() as log:
        proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=log)
        try:
            if not seen.wait(30):
                raise RuntimeError(f"{argv[0]} announced no liveliness token within 30 s")
            startup = time.monotonic() - start
            time.sleep(settle_s)
            rss, hwm = memory_kib(proc.pid)
        finally:
            sub.undeclare()
            _stop(proc, argv[0], log)
    return {"startup_s": startup, "rss_mib": rss / 1024, "peak_mib": hwm / 1024}


def _stop(proc: subprocess.Popen, name: str, log: BinaryIO) -> None:
    """The agent ends within its shutdown deadline (``bus.process.SHUTDOWN_DEADLINE_S``) of SIGTERM: waiting
    longer is a failure worth one clear line. One that ended with a failure status (its clean-up hung and its
    watchdog ended it, with every thread's stack in its log) is reported with the end of that log, and the figures
    still stand: they were read before the signal."""
    proc.terminate()
    try:
        proc.wait(timeout=STOP_WAIT_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        raise SystemExit(f"error: {name} did not end within {STOP_WAIT_S:g} s of SIGTERM") from None
    if proc.returncode not in (0, -signal.SIGTERM):
        log.seek(0)
        tail = log.read().decode(errors="replace").strip().splitlines()[-12:]
        print(f"warning: {name} ended with status {proc.returncode} on SIGTERM; the end of its log:",
              *tail, sep="\n  ", file=sys.stderr)


def summarise(samples: list[dict]) -> dict:
    return {key: statistics.median(s[key] for s in samples) for key in samples[0]}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=5)
    parser.add_argument("--venv", type=Path, help="an existing flight environment (default: build one)")
    parser.add_argument("--port", type=int, default=7547, help="the router's port on 127.0.0.1 (default 7547)")
    parser.add_argument("--settle", type=float, default=SETTLE_S, metavar="S",
                        help=f"seconds each process runs before its memory is read (default {SETTLE_S:g})")
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = quick.parse_args(parser, QUICK)
    with tempfile.TemporaryDirectory(prefix="flight-bench-") as tmp:
        venv = args.venv or flight_venv(Path(tmp))
        rover_bin = venv / "bin" / "lunarsim-rover"
        port = args.port
        endpoint = f"tcp/127.0.0.1:{port}"
        router = subprocess.Popen([sys.executable, "-m", "deploy.router", "--listen", endpoint], cwd=REPO,
                                  stderr=subprocess.DEVNULL)
        keys = Keyspace("bench")
        try:
            if not wait_for_port("127.0.0.1", port, 30, router):
                raise SystemExit(f"the router did not open {endpoint}")
            with zenoh.open(build_config(connect=[endpoint])) as session:
                bare = [measure([sys.executable, "-c", BARE_CLIENT, endpoint, keys.alive_rover(1)], session,
                                keys.alive_rover(1), args.settle) for _ in range(args.runs)]
                rover = [measure([str(rover_bin), "--id", "1", "--world", "bench", "--connect", endpoint],
                                 session, keys.alive_rover(1), args.settle) for _ in range(args.runs)]
        finally:
            router.terminate()
            router.wait(timeout=10)
    result = {"runs": args.runs, "bare_zenoh_client": summarise(bare), "rover_agent": summarise(rover)}
    b, r = result["bare_zenoh_client"], result["rover_agent"]
    print(f"{'process':22s} {'start-up s':>10s} {'RSS MiB':>8s} {'peak MiB':>8s}   (medians of {args.runs} runs)")
    for name, row in (("bare Zenoh client", b), ("rover agent (flight)", r)):
        print(f"{name:22s} {row['startup_s']:10.2f} {row['rss_mib']:8.1f} {row['peak_mib']:8.1f}")
    print(f"rover agent over the bare client: +{r['rss_mib'] - b['rss_mib']:.1f} MiB resident, "
          f"x{r['startup_s'] / b['startup_s']:.2f} start-up")
    if args.json:
        args.json.write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
