"""A scripted real rover for the twin tests: publishes what a driver bridge and its rover agent would.

As the driver bridge: ``Telemetry`` at ``--rate`` Hz (odometry relative to where it started, +z ahead at the
start, +x to the right) and the radio's ``comm_partners``. As the rover agent: its liveliness token and
``RoverStatus``. It stands still until the world's clock runs, then drives ``--legs`` (``drive:M`` straight
ahead, ``turn:D`` in place, positive right), reports itself done, prints ``drive done`` and stands still
until SIGTERM.

    python tests/support/twin_driver.py --connect tcp/127.0.0.1:7447 --world twin --id 1 --legs drive:4,turn:90,drive:3
"""

from __future__ import annotations

import argparse
import math
import signal
import threading
import time
from collections.abc import Iterator

import zenoh

from bus.zenoh_config import build_config
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m


def parse_legs(text: str) -> list[tuple[str, float]]:
    legs = []
    for part in text.split(","):
        kind, _, amount = part.partition(":")
        if kind not in ("drive", "turn"):
            raise argparse.ArgumentTypeError(f"leg {part!r}: use drive:METRES or turn:DEGREES")
        legs.append((kind, float(amount)))
    return legs


def drive(legs: list[tuple[str, float]], speed: float, turn_rate: float, period: float
          ) -> Iterator[tuple[float, float, float]]:
    """Odometry (x, z, heading) at each sample along the legs; every leg ends exactly on its end pose."""
    x = z = heading = 0.0
    for kind, amount in legs:
        steps = max(1, math.ceil(abs(amount) / ((speed if kind == "drive" else turn_rate) * period)))
        for _ in range(steps):
            if kind == "drive":
                x += amount / steps * math.sin(math.radians(heading))
                z += amount / steps * math.cos(math.radians(heading))
            else:
                heading += amount / steps
            yield x, z, heading


class Driver:
    def __init__(self, session: zenoh.Session, keys: ks.Keyspace, rover_id: int, partners: list[int]) -> None:
        self.session, self.keys, self.id, self.partners = session, keys, rover_id, partners
        self.t0 = time.monotonic()
        self.pose = (0.0, 0.0, 0.0)
        self.state, self.goal_index = "waiting", -1

    def publish(self, moving: bool) -> None:
        x, z, heading = self.pose
        stamp = time.monotonic() - self.t0
        self._put(ks.TELEMETRY, m.Telemetry(stamp=stamp, x=x, z=z, heading_deg=heading, moving=moving))
        self._put(ks.STATUS, m.RoverStatus(stamp=stamp, state=self.state, goal_index=self.goal_index))
        self._put(ks.COMM_PARTNERS, m.CommPartners(ids=self.partners))

    def _put(self, topic: str, message: m.Message) -> None:
        self.session.put(self.keys.rover(self.id, topic), codec.encode(message))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--connect", required=True)
    parser.add_argument("--world", default="default")
    parser.add_argument("--id", type=int, required=True)
    parser.add_argument("--legs", type=parse_legs, required=True)
    parser.add_argument("--speed", type=float, default=1.5, help="m/s")
    parser.add_argument("--turn-rate", type=float, default=90.0, help="degrees per second")
    parser.add_argument("--rate", type=float, default=5.0, help="telemetry samples per second")
    parser.add_argument("--partners", default="", help="ids the radio reports hearing, comma separated")
    args = parser.parse_args()
    stop = threading.Event()
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, lambda *_: stop.set())
    keys, period = ks.Keyspace(args.world), 1.0 / args.rate
    running = threading.Event()
    with zenoh.open(build_config(connect=[args.connect])) as session:
        token = session.liveliness().declare_token(keys.alive_rover(args.id))  # noqa: F841 (held while it runs)
        clock = session.declare_subscriber(  # noqa: F841
            keys.clock, lambda s: codec.decode(m.Clock, s.payload.to_bytes()).running and running.set())
        driver = Driver(session, keys, args.id, [int(p) for p in args.partners.split(",") if p])
        while not stop.is_set() and not running.is_set():
            driver.publish(moving=False)
            stop.wait(period)
        driver.state, driver.goal_index = "migration", 0
        for pose in drive(args.legs, args.speed, args.turn_rate, period):
            if stop.is_set():
                return 0
            driver.pose = pose
            driver.publish(moving=True)
            stop.wait(period)
        driver.state = "done"
        print("drive done", flush=True)
        while not stop.is_set():
            driver.publish(moving=False)
            stop.wait(period)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
