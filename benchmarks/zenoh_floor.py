"""The bare Zenoh ping-pong floor of the control-loop benchmark (``benchmarks/control_loop_latency.py``).

A round trip through the same router with nothing of LunarSim in it: an echo process, a zenoh-python client with
the session configuration and Zenoh threads the rover agent uses, puts every ping back from its subscriber's
callback, as zenoh-python's own ``z_pong`` example does. The benchmark pings it with the Perception bytes it sends
the rover (behind an 8-byte ping number), through a link built like the one it plays the world on, so the difference
between the two round trips is what LunarSim adds: the rover's inbox and loop, decoding, deciding, encoding.

    python benchmarks/zenoh_floor.py --connect tcp/127.0.0.1:7447   # the echo, as the benchmark starts it
"""

from __future__ import annotations

import argparse
import contextlib
import queue
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import zenoh

from bus.zenoh_config import build_config, open_session, receive_on_one_thread

PING = "bench/floor/ping"
PONG = "bench/floor/pong"


class FloorLink:
    """The benchmark's end of the ping-pong, on its own session: a declared publisher, a subscriber that only
    enqueues (the clock is read where the pong is taken, in the main thread), as the world's side of the loop."""

    def __init__(self, session: zenoh.Session) -> None:
        self.pongs: queue.SimpleQueue[bytes] = queue.SimpleQueue()
        self._sent = 0
        self._publisher = session.declare_publisher(PING)
        self._subscriber = session.declare_subscriber(PONG, lambda s: self.pongs.put(s.payload.to_bytes()))

    def ping(self, payload: bytes, timeout_s: float) -> int | None:
        """One round trip's nanoseconds, or None if the pong did not come within ``timeout_s``. Each ping carries
        its number, so a late pong of an earlier one is passed over, not taken for this one's."""
        self._sent += 1
        ping = self._sent.to_bytes(8, "big") + payload
        start = time.perf_counter_ns()
        deadline = start + int(timeout_s * 1e9)
        self._publisher.put(ping)
        while True:
            try:
                pong = self.pongs.get(timeout=max(0.0, (deadline - time.perf_counter_ns()) / 1e9))
            except queue.Empty:
                return None
            if pong == ping:
                return time.perf_counter_ns() - start

    def wait_for_echo(self, deadline_s: float) -> bool:
        """Ping until the echo answers (it may still be connecting)."""
        deadline = time.monotonic() + deadline_s
        while time.monotonic() < deadline:
            if self.ping(b"hello", 0.2) is not None:
                return True
        return False

    def close(self) -> None:
        for entity in (self._subscriber, self._publisher):
            with contextlib.suppress(zenoh.ZError):
                entity.undeclare()


def start_echo(endpoint: str, log: Path) -> subprocess.Popen:
    """This file as a child process, logging into ``log``."""
    with open(log, "wb") as out:
        return subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--connect", endpoint],
                                stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL)


def echo(conf: zenoh.Config, where: str, stop: threading.Event) -> None:
    receive_on_one_thread()  # Zenoh's threads as the rover agent has them
    with open_session(conf, where, 10.0, who="zenoh floor echo") as session:
        publisher = session.declare_publisher(PONG)
        subscriber = session.declare_subscriber(PING, lambda s: publisher.put(s.payload))
        stop.wait()
        subscriber.undeclare()
        publisher.undeclare()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--connect", required=True, metavar="ENDPOINT", help="the router, e.g. tcp/127.0.0.1:7447")
    args = parser.parse_args()
    stop = threading.Event()
    for signum in (signal.SIGTERM, signal.SIGINT):
        signal.signal(signum, lambda *_: stop.set())
    echo(build_config(connect=[args.connect]), args.connect, stop)
    return 0


if __name__ == "__main__":
    sys.exit(main())
