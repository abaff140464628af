"""A Zenoh router in its own process: ``lunarsim router`` (``python -m deploy.router``)."""

from __future__ import annotations

import argparse

from bus.zenoh_config import DEFAULT_ENDPOINT, add_zenoh_arguments, build_config


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_zenoh_arguments(parser, listen=True)


def run(args: argparse.Namespace) -> int:
    from deploy.router import serve

    listen = args.listen or ([] if args.config else [DEFAULT_ENDPOINT])
    serve(build_config("router", args.config, args.connect, listen, scouting=args.scouting), listen, args.config)
    return 0
