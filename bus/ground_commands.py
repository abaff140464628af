"""Ground commands as every ground tool builds them (``lunarsim command``, the web page's buttons): a
``GroundCommand`` with a fresh request id, checked for what each command needs; and sending one over a ``Bus``,
waiting for the lander's answer to a mission command."""

from __future__ import annotations

import time
import uuid
from typing import TYPE_CHECKING

from bus.errors import UsageError
from schemas.scenario_limits import MAX_ROVERS, clip

if TYPE_CHECKING:
    from bus.bus import Bus
    from schemas import messages as m
    from schemas.keyspace import Keyspace

RESEND_S = 1.0
"""Unanswered mission commands go again this often (the lander answers a repeat without acting twice)."""


def build_command(command: str, rover: int | None = None, x: float | None = None, z: float | None = None,
                  kind: str = "waypoint", seconds: float | None = None):
    """A GroundCommand with a fresh request id; UsageError names what a command lacks or which value is out of
    bounds (also for the web page): the command is built from a user's values, so it is checked here
    (``codec.checked``), not by the lander that would refuse it."""
    from schemas import codec
    from schemas import messages as m

    if command == "set-target" and (x is None or z is None):
        raise UsageError("set-target needs --x and --z")
    if command in ("stop", "return") and rover is None:
        raise UsageError(f"{command} needs --rover N")
    if command == "seek" and seconds is None:
        raise UsageError("seek needs --seconds S")
    if rover is not None and not 1 <= rover <= MAX_ROVERS:
        raise UsageError(f"--rover must be a rover id from 1 to {MAX_ROVERS}, got {clip(str(rover), 40)}")
    try:
        return codec.checked(m.GroundCommand(request_id=uuid.uuid4().hex, command=command.replace("-", "_"),
                                             rover_id=rover, x=x, z=z, kind=kind, seconds=seconds))
    except codec.DecodeError as exc:
        raise UsageError(f"--{str(exc).removeprefix('GroundCommand: ')}") from None


def send(bus: Bus, keys: Keyspace, command: m.GroundCommand) -> None:
    """Publish a command nobody answers (a clock or snapshot command), subscribed to the answers as for one that is
    answered, so the two leave the same trace on the router."""
    bus.subscribe(keys.ground_command_result)
    bus.publish(keys.ground_command, command)


def send_and_wait(bus: Bus, keys: Keyspace, command: m.GroundCommand, timeout: float) -> m.CommandResult | None:
    """Publish a mission command, again every ``RESEND_S`` (a lander that started later, a lost sample), until the
    lander answers it; None when no answer came within ``timeout`` seconds."""
    from schemas import codec
    from schemas import messages as m

    send(bus, keys, command)
    deadline = time.monotonic() + timeout
    next_send = time.monotonic() + RESEND_S
    while time.monotonic() < deadline:
        item = bus.receive(timeout=0.2)
        if time.monotonic() >= next_send:
            bus.publish(keys.ground_command, command)
            next_send += RESEND_S
        if item is None:
            continue
        result = codec.decode(m.CommandResult, item.payload)
        if result.request_id == command.request_id:
            return result
    return None
