"""The reference serial line protocol, spoken by ``serial_driver`` (host) and ``emulator`` (device).

ASCII lines ending in ``\\n`` (a ``\\r`` before it is ignored), at most ``MAX_LINE`` bytes, fields separated by
single spaces. Request/response: the host numbers each request, the device answers with the same number,
so a late answer to a request the host gave up on is recognised and dropped::

    host:   <seq> <VERB> [args...]            seq: 1..999999, increasing, wraps to 1
    device: <seq> OK [fields...]
            <seq> ERR <code> [detail text]

    HELLO?                 OK <device> <version> [key=value ...]   (fov=<deg> range=<m> radio=0|1 camera=0|1)
    MOVE <x> <z>           OK <action-id>      ERR out_of_view | out_of_range | blocked | busy
    ROT <deg>              OK <action-id>      ERR busy
    CANCEL                 OK                  ERR no_action
    SPEED <level>          OK                  ERR bad_value (level not 1..3)
    STATUS?                OK <stamp> NONE
                           OK <stamp> <action-id> <move|rotate> <running|completed|cancelled|collided>
                              <remaining> <x> <z> <angle>     (one line; x z angle relative to the action's start)
    SCAN?                  OK <stamp> [<angle>:<distance>:<kind> ...]
    IMU?                   OK <stamp> <pitch>
    POSE?                  OK <stamp> <x> <z> <heading> <moving 0|1>
    PHOTO                  OK <base64 PNG>     ERR unsupported
    TX <channel> <ids> <base64 payload>        OK    (ids: comma separated, e.g. 0,2; an empty payload is =)
    RX?                    OK NONE | OK <sender> <channel> <base64 payload>   (oldest first, one per request)
    LINKS?                 OK <ids> | OK -    (ids in direct range, comma separated)

Any request may be answered ``ERR bad_request <detail>`` (unknown verb, wrong arguments). Units and frames
are the driver interface's (``hardware.driver``): metres, degrees, +z ahead, +x right, stamps in
seconds of the device's monotonic clock. Numbers are decimal (no nan or inf).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from schemas.errors import LunarSimError

MAX_LINE = 65536
"""A photo travels as one base64 line: 64 KiB holds a 160x120 PNG of the emulator's view with room to spare."""
MAX_SEQ = 999_999
ERROR_CODES = ("out_of_view", "out_of_range", "blocked", "busy", "no_action", "bad_value", "bad_request",
               "unsupported")
_WORD = re.compile(r"^[!-~]+$")  # printable ASCII without space


class GarbledLine(LunarSimError, ValueError):
    """A line that is not a valid reply (noise on the wire, a reset device, a wrong baud rate)."""


@dataclass(frozen=True)
class Reply:
    seq: int
    ok: bool
    fields: tuple[str, ...]
    """After OK: the fields. After ERR: (code, detail)."""

    @property
    def code(self) -> str:
        return self.fields[0] if not self.ok else ""

    @property
    def detail(self) -> str:
        return self.fields[1] if not self.ok and len(self.fields) > 1 else ""


def _text(line: bytes) -> str:
    if len(line) > MAX_LINE:
        raise GarbledLine(f"line of {len(line)} bytes is longer than {MAX_LINE}")
    try:
        text = line.decode("ascii")
    except UnicodeDecodeError:
        raise GarbledLine(f"not ASCII: {line[:40]!r}") from None
    text = text.removesuffix("\n").removesuffix("\r")
    if not text.isprintable():
        raise GarbledLine(f"control characters in {text[:40]!r}")
    return text


def _seq(word: str, line: str) -> int:
    if not (word.isdigit() and 1 <= int(word) <= MAX_SEQ):
        raise GarbledLine(f"no sequence number at the start of {line[:40]!r}")
    return int(word)


def parse_reply(line: bytes) -> Reply:
    """One device line as a ``Reply``; ``GarbledLine`` says why it is not one."""
    text = _text(line)
    head, _, rest = text.partition(" ")
    seq = _seq(head, text)
    status, _, rest = rest.partition(" ")
    if status == "OK":
        return Reply(seq, True, tuple(rest.split(" ")) if rest else ())
    if status == "ERR":
        code, _, detail = rest.partition(" ")
        if code not in ERROR_CODES:
            raise GarbledLine(f"unknown error code {code!r} in {text[:60]!r}")
        return Reply(seq, False, (code, detail))
    raise GarbledLine(f"expected OK or ERR after the sequence number in {text[:60]!r}")


def parse_request(line: bytes) -> tuple[int, str, tuple[str, ...]]:
    """One host line as (seq, verb, args); ``GarbledLine`` if it is not one."""
    text = _text(line)
    words = text.split(" ")
    if len(words) < 2 or not all(words):
        raise GarbledLine(f"expected '<seq> <VERB> [args]', got {text[:60]!r}")
    return _seq(words[0], text), words[1], tuple(words[2:])


def format_request(seq: int, verb: str, *args: str) -> bytes:
    for word in (verb, *args):
        if not _WORD.match(word):
            raise ValueError(f"protocol field {word!r} is empty or holds spaces or non-ASCII characters")
    return " ".join((str(seq), verb, *args)).encode("ascii") + b"\n"


def format_reply(seq: int, *fields: str) -> bytes:
    return " ".join((str(seq), "OK", *fields)).encode("ascii") + b"\n"


def format_error(seq: int, code: str, detail: str = "") -> bytes:
    if code not in ERROR_CODES:
        raise ValueError(f"unknown error code {code!r}: one of {', '.join(ERROR_CODES)}")
    clean = detail.encode("ascii", "replace").decode().replace("\n", " ")
    return " ".join(w for w in (str(seq), "ERR", code, clean) if w).encode("ascii") + b"\n"


def number(text: str, what: str) -> float:
    """A finite decimal field; ``GarbledLine`` names the field when it is not one."""
    try:
        value = float(text)
    except ValueError:
        raise GarbledLine(f"{what}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise GarbledLine(f"{what}: {text!r} is not finite")
    return value


def fmt(value: float, digits: int = 3) -> str:
    return f"{value:.{digits}f}"


def format_ids(ids: list[int]) -> str:
    return ",".join(str(i) for i in ids) or "-"


def parse_ids(text: str) -> list[int]:
    if text == "-":
        return []
    try:
        ids = [int(part) for part in text.split(",")]
    except ValueError:
        raise GarbledLine(f"ids: {text!r} is not a comma separated list of integers") from None
    if any(i < 0 for i in ids):
        raise GarbledLine(f"ids: {text!r} holds a negative id")
    return ids
