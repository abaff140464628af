"""Ground commands as every ground tool builds them (``lunarsim command``, the web page's buttons): a
``GroundCommand`` with a fresh request id, checked for what each command needs."""

from __future__ import annotations

import uuid

from bus.errors import UsageError

RESEND_S = 1.0
"""Unanswered mission commands go again this often (the lander answers a repeat without acting twice)."""


def build_command(command: str, rover: int | None = None, x: float | None = None, z: float | None = None,
                  kind: str = "waypoint", seconds: float | None = None):
    """A GroundCommand with a fresh request id; UsageError names what a command lacks or which value is out of
    bounds (also for the web page)."""
    from pydantic import ValidationError

    from schemas import messages as m

    if command == "set-target" and (x is None or z is None):
        raise UsageError("set-target needs --x and --z")
    if command in ("stop", "return") and rover is None:
        raise UsageError(f"{command} needs --rover N")
    if command == "seek" and seconds is None:
        raise UsageError("seek needs --seconds S")
    try:
        return m.GroundCommand(request_id=uuid.uuid4().hex, command=command.replace("-", "_"), rover_id=rover, x=x,
                               z=z, kind=kind, seconds=seconds)
    except ValidationError as exc:
        first = exc.errors()[0]
        raise UsageError(f"--{'.'.join(map(str, first['loc']))}: {first['msg']}") from None
