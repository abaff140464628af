"""An emulated rover base on a pseudo-terminal: ``lunarsim emulate-device``.

It opens a real pty, prints the path of its serial end, and answers the reference line protocol
(``hardware.protocol``) for a ``DeviceModel`` simulated in real time, so the serial driver, the
bridge and the checker are exercised through a real serial port opened by pyserial. Its radio links to the
ids given by ``--partners``; each emulated partner echoes back every ``comm_in`` transmission it receives
(a loopback for radio round trips). ``--garble-every N`` puts a garbage line before every Nth answer, to see
a driver survive noise on the wire.
"""

from __future__ import annotations

import argparse

from bus import process

MAX_SLOPE_DEG = 89.0
"""Ground at 90 degrees or beyond is a wall or an overhang, which the pitch the device reports cannot describe."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rocks", default=None, metavar="X,Z,R;...",
                        help="rocks around the start (x ahead-right frame, metres); 'none' for none; "
                             "default: three rocks off the line ahead")
    parser.add_argument("--slope", type=float, default=0.0, metavar="DEG",
                        help="the ground rises towards the start heading at this angle (pitch follows heading); "
                             f"-{MAX_SLOPE_DEG:g} to {MAX_SLOPE_DEG:g}")
    parser.add_argument("--partners", default="0", metavar="IDS",
                        help="radio ids in range, comma separated (default 0, the lander); '-' for none")
    parser.add_argument("--no-radio", action="store_true", help="a device without a radio")
    parser.add_argument("--no-camera", action="store_true", help="a device without a camera")
    parser.add_argument("--garble-every", type=int, default=0, metavar="N",
                        help="send a garbage line before every Nth answer (noise on the wire)")


def run(args: argparse.Namespace) -> int:
    from hardware import protocol as p
    from hardware.emulator import build, parse_rocks

    try:
        rocks = parse_rocks(args.rocks) if args.rocks is not None else None
    except ValueError as exc:
        raise process.UsageError(f"--rocks: {exc}") from None
    try:
        partners = None if args.no_radio else p.parse_ids(args.partners)
    except p.GarbledLine as exc:
        raise process.UsageError(f"--partners: {exc}") from None
    process.check_range("--slope", args.slope, -MAX_SLOPE_DEG, MAX_SLOPE_DEG)
    if args.garble_every < 0:
        raise process.UsageError(f"--garble-every must be 0 or more, got {args.garble_every}")
    emulator = build(rocks, args.slope, partners, camera=not args.no_camera, garble_every=args.garble_every)
    print(f"emulated device on {emulator.path}", flush=True)
    with process.stop_on_signals() as stop:
        emulator.start()
        stop.wait()
    emulator.close()
    m = emulator.server.model
    print(f"final pose x={m.x:.3f} z={m.z:.3f} heading={m.heading:.2f}", flush=True)
    return 0
