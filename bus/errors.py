"""The errors a LunarSim command turns into one line and an exit code (``bus.process.run_guarded``)."""

from __future__ import annotations


class UsageError(ValueError):
    """A command-line value that cannot work; the message is shown as is."""


class RouterUnreachable(RuntimeError):
    """No Zenoh router (or peer) answered at the configured endpoints."""
