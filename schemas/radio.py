"""Application messages carried inside radio payloads (rover <-> lander, rover <-> rover).

The radio itself moves opaque bytes (report 10.4.3); these payloads say what they are with a tag,
so a receiver can tell a goal report from anything else and reject what it does not know.
"""

from __future__ import annotations

from typing import Literal

import msgpack

from schemas import codec
from schemas.messages import Message


class GoalReport(Message):
    """A rover tells the lander it finished (or gave up on) a goal, so the lander sends the next one."""

    goal_index: int
    outcome: Literal["reached", "stuck", "relay"]


class PhotoReport(Message):
    """A crater photo on its way to the lander; the rover holds it until a PhotoAck comes back."""

    goal_index: int
    label: str
    stamp: float
    png: bytes


class PhotoAck(Message):
    """The lander archived these photos (by label): the rover may forget them."""

    labels: list[str]


class CraterFound(Message):
    """Told to the rovers in range when a rover stands on the rim of the crater of a goal (report 6.4)."""

    goal_index: int


class StopCommand(Message):
    """The lander tells a rover to stop where it is until it is given a new goal (need N6)."""


RADIO_TYPES: dict[str, type[Message]] = {"goal_report": GoalReport, "photo_report": PhotoReport, "photo_ack": PhotoAck,
                                         "crater_found": CraterFound, "stop_command": StopCommand}
_TAGS = {model: tag for tag, model in RADIO_TYPES.items()}


def pack(message: Message) -> bytes:
    return msgpack.packb([_TAGS[type(message)], codec.encode(message)], use_bin_type=True)


def unpack(payload: bytes) -> Message:
    try:
        tag, body = msgpack.unpackb(payload, raw=False)
    except Exception as exc:
        raise codec.DecodeError(f"radio payload: not a [tag, body] pair ({type(exc).__name__})") from None
    model = RADIO_TYPES.get(tag) if isinstance(tag, str) else None
    if model is None or not isinstance(body, bytes):
        raise codec.DecodeError(f"radio payload: unknown tag {tag!r}")
    return codec.decode(model, body)
