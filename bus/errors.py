"""The errors a LunarSim command turns into one line and an exit code (``bus.process.run_guarded``)."""

from __future__ import annotations

from schemas.errors import EXIT_NO_ROUTER, EXIT_USAGE, LunarSimError


class UsageError(LunarSimError, ValueError):
    """A command-line value that cannot work; the message is shown as is."""

    exit_code = EXIT_USAGE


class RouterUnreachable(LunarSimError, RuntimeError):
    """No Zenoh router (or peer) answered at the configured endpoints."""

    exit_code = EXIT_NO_ROUTER
