"""``lunarsim command``: ground station commands to the lander (needs N5 and N6 of the report).

    lunarsim command set-target --x -590 --z -20 --kind crater   # every rover (or --rover N)
    lunarsim command stop --rover 3
    lunarsim command return --rover 3                             # back to the lander

Waits for the lander's answer and prints it. Exit status: 0 accepted, 1 refused (the reason is
printed), 3 no router, 4 no lander answered.

    lunarsim command snapshot                                     # a recorder in --snapshot mode writes
    lunarsim command pause | resume | step                        # the world's clock, or a running replay
    lunarsim command seek --seconds 30                            # a running replay

These go to the world service, recorders and replays, which do not answer: they are sent and the command
exits 0. A paused world publishes a stopped clock; each ``step`` advances it one tick.
"""

from __future__ import annotations

import argparse
import sys

from bus.ground_commands import build_command, send, send_and_wait
from bus.zenoh_config import add_zenoh_arguments, config_from_args, describe_endpoints, open_session

EXIT_REFUSED = 1
EXIT_NO_ANSWER = 4


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("command", choices=["set-target", "stop", "return", "snapshot", "pause", "resume",
                                            "step", "seek"],
                        help="what to do: set-target, stop, return (the lander answers); snapshot, pause, "
                             "resume, step, seek (sent, not answered)")
    parser.add_argument("--rover", type=int, metavar="N", help="the rover (set-target: every rover if omitted)")
    parser.add_argument("--x", type=float, help="set-target: target x in map coordinates, m")
    parser.add_argument("--z", type=float, help="set-target: target z in map coordinates, m")
    parser.add_argument("--kind", choices=["waypoint", "crater"], default="waypoint", help="set-target: goal kind")
    parser.add_argument("--seconds", type=float, metavar="S", help="seek: seconds from the start of the recording")
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--timeout", type=float, default=10.0, metavar="S", help="seconds to wait for the answer")
    add_zenoh_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from bus.bus import Bus
    from schemas import messages as m
    from schemas.keyspace import Keyspace

    keys = Keyspace(args.world)
    command = build_command(args.command, args.rover, args.x, args.z, args.kind, args.seconds)
    session = open_session(config_from_args(args), describe_endpoints(args), args.router_timeout, who="command")
    with Bus(session) as bus:
        if command.command not in m.MISSION_COMMANDS:
            send(bus, keys, command)
            print(f"sent {args.command} to world {args.world!r} (recorders and replays do not answer)")
            return 0
        result = send_and_wait(bus, keys, command, args.timeout)
    if result is None:
        print(f"error: no lander answered within {args.timeout:g} s (is one running in world {args.world!r}?)",
              file=sys.stderr)
        return EXIT_NO_ANSWER
    print(("accepted: " if result.accepted else "refused: ") + result.detail)
    return 0 if result.accepted else EXIT_REFUSED
