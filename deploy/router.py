"""A Zenoh router in its own process: ``lunarsim router`` (``python -m deploy.router``)."""

from __future__ import annotations

import argparse
import sys

from deploy import process
from deploy.zenoh_config import DEFAULT_ENDPOINT, add_zenoh_arguments, build_config


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_zenoh_arguments(parser, listen=True)


def run_from_args(args: argparse.Namespace) -> int:
    import zenoh

    listen = args.listen or ([] if args.config else [DEFAULT_ENDPOINT])
    conf = build_config("router", args.config, args.connect, listen, scouting=args.scouting)
    where = ", ".join(listen) or f"the endpoints of {args.config}"
    try:
        session = zenoh.open(conf)
    except zenoh.ZError as exc:
        raise process.UsageError(f"cannot start a router listening on {where}: {exc} "
                                 "(is another router already using the port?)") from None
    print(f"router listening on {where}", file=sys.stderr, flush=True)
    with process.stop_on_signals() as stop:
        stop.wait()
    session.close()
    return 0


if __name__ == "__main__":
    process.main_for("router", "deploy.router")
