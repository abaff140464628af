"""``lunarsim recover BROKEN.mcap -o FIXED.mcap``: keep everything a killed recorder had written."""

from __future__ import annotations

import argparse
from pathlib import Path

from bus import paths, process


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("broken", type=Path, metavar="BROKEN.mcap",
                        help="a recording cut short (its recorder was killed, or the disk filled)")
    parser.add_argument("-o", "--output", type=paths.new_file, required=True, metavar="FIXED.mcap",
                        help="where to write what could be read of it")


def run(args: argparse.Namespace) -> int:
    from sessions.recover import NotARecording, recover

    if not args.broken.is_file():
        problem = "not a regular file" if args.broken.exists() else "no such file"
        raise process.UsageError(f"{args.broken}: {problem}")
    if args.output.resolve() == args.broken.resolve():
        raise process.UsageError("write the recovered file somewhere else than the broken one")
    try:
        result = recover(args.broken, args.output)
    except NotARecording as exc:
        raise process.UsageError(str(exc)) from None
    tail = f"; the end was cut off ({result.error})" if result.truncated else "; the file was complete"
    print(f"recovered {result.messages} messages on {result.channels} channels into {args.output}{tail}")
    return 0
