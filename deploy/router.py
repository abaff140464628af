"""A Zenoh router in its own process: ``lunarsim router`` (``python -m deploy.router``)."""

from __future__ import annotations

import argparse
import sys

from bus import process
from bus.zenoh_config import DEFAULT_ENDPOINT, add_zenoh_arguments, build_config, open_router


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_zenoh_arguments(parser, listen=True)


def run_from_args(args: argparse.Namespace) -> int:
    listen = args.listen or ([] if args.config else [DEFAULT_ENDPOINT])
    conf = build_config("router", args.config, args.connect, listen, scouting=args.scouting)
    session = open_router(conf, listen, args.config)
    print(f"router listening on {', '.join(listen) or f'the endpoints of {args.config}'}", file=sys.stderr,
          flush=True)
    with process.stop_on_signals() as stop:
        stop.wait()
    session.close()
    return 0


if __name__ == "__main__":
    process.main_for("router", "deploy.router")
