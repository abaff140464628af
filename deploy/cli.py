"""The ``lunarsim`` command: one entry, one subcommand per job.

Each command is a module of its own, ``<package>/commands/<command>.py`` (``COMMANDS`` names the package), with
``add_arguments(parser)`` and ``run(args) -> int``; its docstring is the command's description. Command modules are
imported only to add their arguments; what they need to run (NumPy for the world, rich for the launcher) is
imported when they run, so ``lunarsim rover`` starts fast.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from dataclasses import dataclass

from bus import process

COMMANDS: dict[str, tuple[str, str]] = {
    "run": ("deploy", "run a whole mission locally: router, world, lander and rovers"),
    "batch": ("deploy", "N seeded runs in parallel, summarised as the report's Table 2"),
    "collect-batch": ("deploy", "one batch.json and Table 2 from runs written elsewhere (the Kubernetes batch "
                      "Job's)"),
    "router": ("deploy", "run a Zenoh router"),
    "world": ("world_service", "run the world service (simulated terrain, sensors, radio, clock)"),
    "lander": ("lander_agent", "run the lander agent"),
    "rover": ("rover_agent", "run one rover agent"),
    "scenario": ("deploy", "import, export, check and generate scenarios"),
    "command": ("deploy", "send a ground command to the lander: set-target, stop, return"),
    "check-behaviour": ("deploy", "check that a rover behaviour keeps the contract"),
    "record": ("sessions", "record a world's traffic into an MCAP session file"),
    "replay": ("sessions", "replay a recorded session onto Zenoh with its original timing"),
    "recover": ("sessions", "recover the readable part of a recording cut short"),
    "report": ("sessions", "mission statistics and a trajectory plot from a recording alone"),
    "export-foxglove": ("sessions", "write Foxglove channels (3D scene, transforms, photos) for a recording"),
    "view": ("web", "a live world or replay in the browser (--foxglove: in the Foxglove app)"),
    "bridge": ("hardware", "put one real rover (a hardware driver) on a rover's keys"),
    "emulate-device": ("hardware", "an emulated serial rover base on a pseudo-terminal"),
    "check-driver": ("hardware", "drive a hardware driver through the interface, list violations"),
    "ros2": ("ros2_bridge", "a mission's rovers as ROS 2 topics for nodes on rmw_zenoh"),
    "export-rosbag": ("ros2_bridge", "write a recording as a rosbag2 (MCAP) with the ROS 2 bridge's topics"),
    "acl": ("deploy", "secured router config: TLS, mTLS, passwords, access control per role"),
}
"""Every command: the package whose ``commands/<command>.py`` (dashes as underscores) runs it, and its help line."""


MISSION_PROCESSES = frozenset({"world", "lander", "rover", "router", "record", "bridge", "ros2"})
"""Commands that run as a process of a mission, and log its events (``process.setup_logging``)."""


def command_module(name: str) -> str:
    """The module of command ``name``: ``lunarsim collect-batch`` is ``deploy.commands.collect_batch``."""
    return f"{COMMANDS[name][0]}.commands.{name.replace('-', '_')}"


@dataclass(frozen=True)
class Parsers:
    """The ``lunarsim`` parser and each command's, by name; a command's own subcommands as ``"scenario list"``."""

    top: argparse.ArgumentParser
    commands: dict[str, argparse.ArgumentParser]


def build_parsers(only: str | None = None) -> Parsers:
    """Every command's parser; with ``only``, that command's alone is built (its module imported), the others
    listed by name and help line."""
    top = argparse.ArgumentParser(prog="lunarsim", description="Distributed lunar rover middleware and digital twin "
                                  "over Zenoh.")
    top.add_argument("--verbose", "-v", action="store_true", help="log progress at INFO level")
    sub = top.add_subparsers(dest="subcommand", required=True, metavar="COMMAND")
    commands: dict[str, argparse.ArgumentParser] = {}
    for name, (_, help_text) in COMMANDS.items():
        if only is not None and name != only:
            sub.add_parser(name, help=help_text)
            continue
        module = importlib.import_module(command_module(name))
        command = commands[name] = sub.add_parser(name, help=help_text, description=plain(module.__doc__),
                                                  formatter_class=argparse.RawDescriptionHelpFormatter)
        nested = module.add_arguments(command) or {}
        commands.update({f"{name} {inner}": parser for inner, parser in nested.items()})
        command.set_defaults(run=module.run)
    return Parsers(top, commands)


def build_parser() -> argparse.ArgumentParser:
    return build_parsers().top


def plain(doc: str | None) -> str | None:
    """A module docstring as a command's description: its paragraphs and example lines kept as written (the raw
    formatter), its reST literals (double backquotes) shown as plain text."""
    return doc.replace("``", "") if doc else doc


def named_command(argv: list[str]) -> str | None:
    """The command ``argv`` names, when its first word is one (after ``--verbose``): only that command's module is
    imported to parse it, not every command's."""
    for arg in argv:
        if not arg.startswith("-"):
            return arg if arg in COMMANDS else None
    return None


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    process.one_blas_thread()
    parsers = build_parsers(only=named_command(argv))
    args, unknown = parsers.top.parse_known_args(argv)
    if unknown:  # said by the command's own parser, with its usage, not the top-level one
        parsers.commands[args.subcommand].error(f"unrecognized arguments: {' '.join(unknown)}")
    process.setup_logging(args.verbose, events=args.subcommand in MISSION_PROCESSES)
    return process.run_guarded(args.run, args)


if __name__ == "__main__":
    sys.exit(main())
