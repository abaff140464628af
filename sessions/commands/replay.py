"""``lunarsim replay``: publish a recorded session onto Zenoh again, with its original timing.

    lunarsim replay run.mcap                       # as recorded, same world
    lunarsim replay run.mcap --remap-world review --rate 4 --loop
    lunarsim replay run.mcap --topics 'lunar/*/rover/1/*' --start-offset 30 --start-paused

The recorded world clock is left out unless ``--clock``: a replay beside a live world must not drive its
agents. Controls: on a terminal, space pauses/resumes, ``s`` or the right arrow steps one sample, ``q``
quits; from anywhere, ``pause``/``resume``/``step``/``seek`` ground commands on the target world's keyspace.
With no ``--connect`` and nothing listening on the default endpoint (the run that served as router has ended),
the replay serves as the router there. The file is checked before anything is published: only LunarSim keys of a
valid world go out (other channels are skipped and counted), and a file cut short is refused with the
``lunarsim recover`` command that mends it.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from bus import process
from bus.zenoh_config import add_zenoh_arguments


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", type=Path, metavar="FILE.mcap", help="a recording made by 'lunarsim record'")
    parser.add_argument("--rate", type=float, default=1.0, metavar="R", help="playback speed (default 1: as "
                        "recorded; 2: twice as fast)")
    parser.add_argument("--loop", action="store_true", help="start again at the end, until stopped")
    parser.add_argument("--topics", nargs="+", metavar="GLOB", help="replay only keys matching these globs")
    parser.add_argument("--exclude", nargs="+", metavar="GLOB", help="leave out keys matching these globs")
    parser.add_argument("--start-offset", type=float, default=0.0, metavar="S",
                        help="start S seconds into the recording")
    parser.add_argument("--remap-world", metavar="NAME", help="publish into world NAME instead of the recorded one")
    parser.add_argument("--clock", action="store_true", help="also replay the recorded world clock (left out by "
                        "default so a replay beside a live world does not drive its agents)")
    parser.add_argument("--start-paused", action="store_true", help="wait for resume/step before publishing")
    parser.add_argument("--quiet", "-q", action="store_true", help="no progress bar")
    add_zenoh_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from schemas.keyspace import check_world_name
    from sessions.playback import ReplaySpec, open_recording, replay

    process.check_range("--rate", args.rate, 1e-3, 1e6)
    process.check_range("--start-offset", args.start_offset, 0.0, 1e9)
    try:
        target = check_world_name(args.remap_world) if args.remap_world else None
    except ValueError as exc:
        raise process.UsageError(f"--remap-world: {exc}") from None
    recording = open_recording(args.file)
    spec = ReplaySpec(rate=args.rate, loop=args.loop, topics=args.topics, exclude=args.exclude,
                      start_offset=args.start_offset, remap_world=target, clock=args.clock,
                      start_paused=args.start_paused, quiet=args.quiet)
    return replay(recording, spec, lambda: _open(args))


def _open(args: argparse.Namespace):
    """The run's router, or, when none was named and none listens on the default endpoint (the run that served
    as router has ended), a router of its own there: viewers left open on the default find the replay."""
    from bus.zenoh_config import (
        DEFAULT_ENDPOINT,
        build_config,
        config_from_args,
        default_router_missing,
        describe_endpoints,
        open_router,
        open_session,
    )

    if default_router_missing(args):
        print(f"lunarsim replay: no router at {DEFAULT_ENDPOINT}; serving as the router there", file=sys.stderr,
              flush=True)
        return open_router(build_config("router", listen=[DEFAULT_ENDPOINT]), [DEFAULT_ENDPOINT])
    return open_session(config_from_args(args), describe_endpoints(args), args.router_timeout,
                        who="lunarsim replay")
