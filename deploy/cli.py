"""The ``lunarsim`` command: one entry, one subcommand per job.

Subcommand modules are imported only to add their arguments; what they need to run (NumPy for the
world, rich for the launcher) is imported when they run, so ``lunarsim rover`` starts fast.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Callable

from bus import process

COMMANDS = {
    "run": ("deploy.launcher", "run a whole mission locally: router, world, lander and rovers"),
    "batch": ("deploy.batch", "N seeded runs in parallel, summarised as the report's Table 2"),
    "collect-batch": ("deploy.batch_collect", "one batch.json and Table 2 from runs written elsewhere (the "
                      "Kubernetes batch Job's)"),
    "router": ("deploy.router", "run a Zenoh router"),
    "world": ("world_service.app", "run the world service (simulated terrain, sensors, radio, clock)"),
    "lander": ("lander_agent.app", "run the lander agent"),
    "rover": ("rover_agent.app", "run one rover agent"),
    "scenario": ("deploy.scenario_cli", "import, export, check and generate scenarios"),
    "command": ("deploy.command_cli", "send a ground command to the lander: set-target, stop, return"),
    "check-behaviour": ("deploy.behaviour_check", "check that a rover behaviour keeps the contract"),
    "record": ("sessions.record_cli", "record a world's traffic into an MCAP session file"),
    "replay": ("sessions.replay_cli", "replay a recorded session onto Zenoh with its original timing"),
    "recover": ("sessions.recover_cli", "recover the readable part of a recording cut short"),
    "report": ("sessions.report_cli", "mission statistics and a trajectory plot from a recording alone"),
    "export-foxglove": ("sessions.export_cli",
                        "write Foxglove channels (3D scene, transforms, photos) for a recording"),
    "view": ("web.view_cli", "a live world or replay in the browser (--foxglove: in the Foxglove app)"),
    "bridge": ("hardware.bridge_app", "put one real rover (a hardware driver) on a rover's keys"),
    "emulate-device": ("hardware.emulator", "an emulated serial rover base on a pseudo-terminal"),
    "check-driver": ("hardware.check_cli", "drive a hardware driver through the interface, list violations"),
    "ros2": ("ros2_bridge.app", "a mission's rovers as ROS 2 topics for nodes on rmw_zenoh"),
    "export-rosbag": ("ros2_bridge.rosbag_cli", "write a recording as a rosbag2 (MCAP) with the ROS 2 bridge's topics"),
    "acl": ("deploy.security.acl_cli", "secured router config: TLS, mTLS, passwords, access control per role"),
}


MISSION_PROCESSES = frozenset({"world", "lander", "rover", "router", "record", "bridge", "ros2"})
"""Commands that run as a process of a mission, and log its events (``process.setup_logging``)."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="lunarsim", description="Distributed lunar rover middleware and "
                                     "digital twin over Zenoh.")
    parser.add_argument("--verbose", "-v", action="store_true", help="log progress at INFO level")
    sub = parser.add_subparsers(dest="subcommand", required=True, metavar="COMMAND")
    for name, (module_name, help_text) in COMMANDS.items():
        module = importlib.import_module(module_name)
        command = sub.add_parser(name, help=help_text, description=plain(module.__doc__),
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_arguments(command)
        command.set_defaults(run=_router_first(module.run_from_args) if name == "run" else module.run_from_args)
    return parser


Command = Callable[[argparse.Namespace], int]


def _subparser(parser: argparse.ArgumentParser, name: str) -> argparse.ArgumentParser:
    actions = (a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return next(actions).choices[name]


def _router_first(run: Command) -> Command:
    """``run --connect``: reach the router before anything starts. The launcher would start its recorder and world
    against it, write the run folder, and give up on them only after half a minute; this fails within
    ``ONE_SHOT_TIMEOUT_S``, exit code 3, with nothing written."""

    def checked(args: argparse.Namespace) -> int:
        if args.connect:
            from bus.zenoh_config import ONE_SHOT_TIMEOUT_S, build_config, open_session

            open_session(build_config(connect=[args.connect]), args.connect, ONE_SHOT_TIMEOUT_S,
                         who="lunarsim run").close()
        return run(args)

    return checked


def plain(doc: str | None) -> str | None:
    """A module docstring as a command's description: its paragraphs and example lines kept as written (the raw
    formatter), its reST literals (double backquotes) shown as plain text."""
    return doc.replace("``", "") if doc else doc


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # said by the command's own parser, with its usage, not the top-level one
        _subparser(parser, args.subcommand).error(f"unrecognized arguments: {' '.join(unknown)}")
    process.setup_logging(args.verbose, events=args.subcommand in MISSION_PROCESSES)
    return process.run_guarded(args.run, args)


if __name__ == "__main__":
    sys.exit(main())
