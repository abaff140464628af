"""``lunarsim check-driver URL``: drive a hardware driver through the interface and list what it violates.

The rules and what the rover does meanwhile (about 5 m straight ahead, turns on the spot: give it clear
ground) are in ``hardware.check``. Each violated rule is printed with what was seen; the exit status
is 1 if there is any.
"""

from __future__ import annotations

import argparse

from bus import process


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("driver", metavar="URL", help="serial:///dev/ttyUSB0?baud=115200, or package.module:Class")
    parser.add_argument("--radio-echo", type=int, metavar="ID",
                        help="a radio partner that echoes comm_in transmissions back (the emulator's do)")


def run(args: argparse.Namespace) -> int:
    from hardware.check import Checker
    from hardware.driver import DriverError, InvalidCommand
    from hardware.drivers import UnknownDriver, load_driver

    try:
        driver = load_driver(args.driver)
    except (UnknownDriver, InvalidCommand) as exc:
        raise process.UsageError(f"{exc}") from None
    except DriverError as exc:
        print(f"violation: the driver opens: saw {type(exc).__name__}: {exc}")
        return 1
    try:
        checker = Checker(driver, args.radio_echo)
        violations = checker.run()
    finally:
        driver.close()
    print(f"driver contract: ok ({checker.passed} rules)" if not violations
          else f"driver contract: {len(violations)} violation(s), {checker.passed} rules kept")
    return 1 if violations else 0

