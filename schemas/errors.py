"""The root of every error LunarSim raises on purpose, and the exit codes a command ends with.

``except LunarSimError`` catches anything LunarSim refused: a scenario, a recording, a driver, a received sample.
Each error also keeps the standard base its callers catch (``ValueError`` for a value refused, ``RuntimeError``
for a part that failed), so code that catches those still does.

A ``LunarSimError`` that reaches a command ends it with its ``exit_code`` (``bus.process.run_guarded``). An error
worded for the user (bad input, no router) is shown as its message alone; any other is a failure the command did
not expect there, shown with its type (and, with ``--verbose``, its traceback) and exit code 1.
"""

from __future__ import annotations

from typing import ClassVar

EXIT_FAILED = 1
"""A process of the run died, or an unexpected error."""
EXIT_USAGE = 2
"""Bad input: usage, a scenario, a file that cannot be read or written."""
EXIT_NO_ROUTER = 3
"""No Zenoh router reachable."""
EXIT_INTERRUPTED = 130
"""Stopped by Ctrl-C or SIGTERM."""


class LunarSimError(Exception):
    """Anything LunarSim refused or that failed in LunarSim's own code, as opposed to a bug in it."""

    exit_code: ClassVar[int] = EXIT_FAILED
    """What a command ends with when this error reaches it: anything but ``EXIT_FAILED`` says the message is worded
    for the user and shown as it is."""

    @property
    def for_the_user(self) -> bool:
        """Whether a command shows this error's message alone (it names what to mend), not as a failure."""
        return self.exit_code != EXIT_FAILED
