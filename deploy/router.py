"""A Zenoh router serving until stopped: ``lunarsim router`` (``deploy.commands.router``), and
``python -m deploy.router`` with the same arguments."""

from __future__ import annotations

import sys

import zenoh

from bus import process
from bus.zenoh_config import open_router


def serve(conf: zenoh.Config, listen: list[str], config_file: str | None = None) -> None:
    """Route on ``listen`` (or the endpoints of ``config_file``) until SIGINT or SIGTERM."""
    session = open_router(conf, listen, config_file)
    print(f"router listening on {', '.join(listen) or f'the endpoints of {config_file}'}", file=sys.stderr,
          flush=True)
    with process.stop_on_signals(process.SHUTDOWN_DEADLINE_S) as stop:
        stop.wait()
    session.close()


if __name__ == "__main__":
    process.main_for("router", "deploy.commands.router")
