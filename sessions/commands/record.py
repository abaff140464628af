"""``lunarsim record``: record every sample of a world (or a filtered set) into an MCAP session file.

Stops on Ctrl-C or SIGTERM and prints what it wrote, what it dropped and the gaps it knows of (spans it missed
while it had lost its router). With ``--snapshot N`` it keeps only the last N seconds and writes them to a new file
on SIGUSR1 or a ``snapshot`` ground command.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bus import paths, process
from bus.zenoh_config import add_zenoh_arguments


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("-o", "--output", type=paths.new_file, required=True, metavar="FILE.mcap",
                        help="the session file to write")
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--topics", nargs="+", metavar="GLOB", help="record only keys matching these globs")
    parser.add_argument("--exclude", nargs="+", metavar="GLOB", help="leave out keys matching these globs")
    parser.add_argument("--compression", choices=["zstd", "lz4", "none"], default="zstd",
                        help="how MCAP chunks are compressed (default zstd)")
    parser.add_argument("--split-size", type=_size, metavar="BYTES", help="start a new file after this much "
                        "payload (suffixes k, M, G)")
    parser.add_argument("--split-duration", type=float, metavar="S", help="start a new file every S seconds")
    parser.add_argument("--snapshot", type=float, metavar="N", help="keep only the last N seconds; write them "
                        "on SIGUSR1 or a 'snapshot' ground command")
    parser.add_argument("--scenario", type=Path, metavar="FILE", help="scenario to embed in the metadata, so "
                        "the recording says how to reproduce itself")
    parser.add_argument("--duration", type=float, metavar="S", help="stop after S seconds")
    add_zenoh_arguments(parser, agent=True)


def _size(text: str) -> int:
    units = {"k": 1 << 10, "m": 1 << 20, "g": 1 << 30}
    try:
        scale = units.get(text[-1].lower(), 1)
        value = int(float(text[:-1] if text[-1].lower() in units else text) * scale)
    except (ValueError, IndexError):
        raise argparse.ArgumentTypeError(f"not a size: {text!r} (e.g. 500M)") from None
    if value <= 0:
        raise argparse.ArgumentTypeError("a size must be positive")
    return value


def run(args: argparse.Namespace) -> int:
    from bus.zenoh_config import config_from_args, describe_endpoints, open_session
    from schemas.keyspace import Keyspace, check_world_name
    from sessions.recorder import RecordSpec, record, session_metadata

    try:
        check_world_name(args.world)
    except ValueError as exc:
        raise process.UsageError(f"--world: {exc}") from None
    if args.output.suffix != ".mcap":
        raise process.UsageError(f"{args.output}: the output file must end in .mcap")
    for option, seconds in (("--snapshot", args.snapshot), ("--split-duration", args.split_duration)):
        if seconds is not None:
            process.check_range(option, seconds, 0.1, 1e9)
    if args.snapshot is not None and (args.split_size or args.split_duration):
        raise process.UsageError("--snapshot writes one file per trigger: it cannot be combined with --split-*")
    args.output.parent.mkdir(parents=True, exist_ok=True)
    keys = Keyspace(args.world)
    info = session_metadata(args.world, args.scenario)
    session = open_session(config_from_args(args), describe_endpoints(args), args.router_timeout,
                           who="lunarsim record")
    record(session, keys, RecordSpec(args.output, args.compression, args.topics, args.exclude, args.split_size,
                                     args.split_duration, args.snapshot, args.duration), info)
    session.close()
    return 0
