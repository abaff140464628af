"""Ground commands from the page: built as ``lunarsim command`` builds them, answered by the lander.

Mission commands (set-target, stop, return) are resent every second until the lander answers or the
deadline passes, as the command line does; the lander answers a repeat without acting twice. Clock
commands (pause, resume, step) go to a replay, which does not answer.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Callable

from bus import process
from bus.ground_commands import RESEND_S, build_command
from schemas import codec
from schemas import messages as m
from schemas.errors import LunarSimError

PAGE_COMMANDS = ("set-target", "stop", "return", "pause", "resume", "step")
ANSWER_TIMEOUT_S = 10.0


class CommandError(LunarSimError, ValueError):
    """A command the page asked for that cannot be sent; the message is shown on the page."""


def _number(data: dict, key: str, kind: type) -> float | int | None:
    value = data.get(key)
    if value is None or value == "":
        return None
    try:
        return kind(value)
    except (TypeError, ValueError):
        raise CommandError(f"{key} must be a number, got {value!r}") from None


def command_from_request(data: object) -> m.GroundCommand:
    """The page's JSON ({command, rover_id, x, z, kind}) as a GroundCommand; CommandError says what is wrong."""
    if not isinstance(data, dict):
        raise CommandError("expected a JSON object")
    name = str(data.get("command", ""))
    if name not in PAGE_COMMANDS:
        raise CommandError(f"unknown command {name!r}: use one of {', '.join(PAGE_COMMANDS)}")
    try:
        return build_command(name, _number(data, "rover_id", int), _number(data, "x", float),
                             _number(data, "z", float), str(data.get("kind") or "waypoint"))
    except process.UsageError as exc:
        text = str(exc).replace("--x and --z", "x and z").replace("--rover N", "a rover")
        raise CommandError(text.removeprefix("--")) from None


class Commands:
    """Publishes commands and matches the lander's answers to the waiting requests by request id."""

    def __init__(self, publish: Callable[[m.GroundCommand], None]) -> None:
        self.publish = publish
        self.loop: asyncio.AbstractEventLoop | None = None
        self.waiting: dict[str, asyncio.Future] = {}

    def on_result(self, payload: bytes) -> None:
        """Zenoh's thread: hand the answer to the event loop."""
        if self.loop is not None:
            self.loop.call_soon_threadsafe(self._resolve, payload)

    def _resolve(self, payload: bytes) -> None:
        try:
            result = codec.decode(m.CommandResult, payload)
        except codec.DecodeError:
            return
        future = self.waiting.get(result.request_id)
        if future is not None and not future.done():
            future.set_result(result)

    async def send(self, command: m.GroundCommand, timeout: float = ANSWER_TIMEOUT_S) -> dict:
        """Send and, for a mission command, wait for the lander's answer."""
        if command.command not in m.MISSION_COMMANDS:
            self.publish(command)
            return {"sent": True, "accepted": True, "detail": f"{command.command} sent (a replay does not answer)"}
        future = asyncio.get_running_loop().create_future()
        self.waiting[command.request_id] = future
        try:
            loop_end = asyncio.get_running_loop().time() + timeout
            while (left := loop_end - asyncio.get_running_loop().time()) > 0:
                self.publish(command)
                with contextlib.suppress(TimeoutError):
                    result = await asyncio.wait_for(asyncio.shield(future), min(RESEND_S, left))
                    return {"sent": True, "accepted": result.accepted, "detail": result.detail,
                            "request_id": command.request_id}
            return {"sent": True, "accepted": False, "answered": False,
                    "detail": f"no lander answered within {timeout:g} s"}
        finally:
            self.waiting.pop(command.request_id, None)
