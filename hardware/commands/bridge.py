"""``lunarsim bridge --id N --driver URL``: one real rover on the keys of rover N, for the unchanged rover agent.

Run it on the rover's flight computer beside ``lunarsim rover --id N``. With a world service in twin mode the
world's clock paces the agents; on a bench, with no world, ``--clock`` makes the bridge publish a real-time
clock itself. The driver is chosen by URL (``hardware.drivers.load_driver``): ``serial:///dev/ttyUSB0``
for the reference serial driver, or ``package.module:Class?key=value``.
"""

from __future__ import annotations

import argparse
import sys

from bus import process
from bus.zenoh_config import add_zenoh_arguments, config_from_args, describe_endpoints, open_session


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--id", type=int, required=True, help="rover id whose keys the bridge serves (1..N)")
    parser.add_argument("--driver", required=True, metavar="URL",
                        help="serial:///dev/ttyUSB0?baud=115200&timeout=0.5, or package.module:Class?key=value")
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--clock", action="store_true",
                        help="publish a real-time world clock (no world service running: one rover on a bench)")
    add_zenoh_arguments(parser, agent=True)


def run(args: argparse.Namespace) -> int:
    from hardware.driver import DriverError
    from hardware.drivers import UnknownDriver, load_driver
    from hardware.runtime import serve
    from schemas.keyspace import Keyspace

    if args.id < 1:
        raise process.UsageError(f"--id must be 1 or more (rover ids start at 1), got {args.id}")
    try:
        keys = Keyspace(args.world)
    except ValueError as exc:
        raise process.UsageError(str(exc)) from None
    try:
        driver = load_driver(args.driver)
    except (UnknownDriver, ValueError) as exc:
        raise process.UsageError(f"--driver: {exc}") from None
    except DriverError as exc:
        print(f"error: driver {args.driver}: {exc}", file=sys.stderr)
        return 1
    try:
        session = open_session(config_from_args(args), describe_endpoints(args), args.router_timeout,
                               who=f"bridge {args.id}")
        serve(driver, keys, args.id, args.clock, session)
    finally:
        driver.close()
    return 0


def main() -> None:
    """``lunarsim-bridge``: the flight computer's entry (the wheel there has no ``lunarsim`` command)."""
    process.main_for("bridge", "hardware.commands.bridge")

