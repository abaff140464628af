"""msgpack codec for every LunarSim payload: ``[schema_version, {fields}]``.

Decoding validates against the message model (a msgspec Struct: types, bounds, unknown fields, its cross-field
rules) and raises one error type, ``DecodeError``, naming the model, the field and the problem, so every receiver
can log-and-count instead of crashing.
"""

from __future__ import annotations

import functools
import re
from typing import Any, Final, TypeVar

import msgspec

from schemas.errors import LunarSimError

SCHEMA_VERSION: Final = 1

M = TypeVar("M", bound=msgspec.Struct)


class DecodeError(LunarSimError, ValueError):
    """A payload that is not a valid encoding of the expected message, or a message out of its bounds
    (``checked``)."""


def _plain_number(value: object) -> object:
    """A NumPy scalar (the world computes with NumPy) as the Python number it holds; anything else is refused."""
    item = getattr(value, "item", None)
    if item is not None and getattr(value, "shape", None) == ():
        return item()
    raise TypeError(f"cannot encode {type(value).__name__}")


_ENCODER = msgspec.msgpack.Encoder(enc_hook=_plain_number)


def encode(message: msgspec.Struct) -> bytes:
    """The envelope and the message's fields in their declared order, nested messages the same way: the bytes
    msgpack-python made of ``[SCHEMA_VERSION, fields]`` (``tests/unit/schemas/test_codec.py`` checks both)."""
    return _ENCODER.encode((SCHEMA_VERSION, message))


@functools.cache
def _decoder(model: type[M]) -> msgspec.msgpack.Decoder[tuple[int, M]]:
    return msgspec.msgpack.Decoder(tuple[int, model])


def decode(model: type[M], payload: bytes | bytearray | memoryview) -> M:
    try:
        version, message = _decoder(model).decode(payload)
    except msgspec.ValidationError as exc:
        raise DecodeError(_refusal(model.__name__, payload, exc)) from None
    except msgspec.DecodeError as exc:
        raise DecodeError(f"{model.__name__}: payload is not msgpack ({exc})") from None
    if version != SCHEMA_VERSION:
        raise DecodeError(_version_refusal(model.__name__, version))
    return message


def _refusal(name: str, payload: bytes | bytearray | memoryview, exc: msgspec.ValidationError) -> str:
    """Why a well-formed msgpack payload is not the message: its envelope first, then its schema version, then
    the first field that fails, as ``Model: path.to.field: problem``."""
    try:
        envelope: Any = msgspec.msgpack.decode(payload)
    except Exception as exc:  # trailing bytes, a string not UTF-8, ...: the typed decoder stopped before them
        return f"{name}: payload is not msgpack ({type(exc).__name__}: {exc})"
    if not (isinstance(envelope, list) and len(envelope) == 2 and isinstance(envelope[1], dict)):
        return f"{name}: expected [schema_version, {{fields}}], got {type(envelope).__name__}"
    if type(envelope[0]) is not int or envelope[0] != SCHEMA_VERSION:
        return _version_refusal(name, envelope[0])
    return f"{name}: {field_problem(exc, prefix='$[1]')}"


def _version_refusal(name: str, version: object) -> str:
    return f"{name}: schema version {version!r} is not supported (this build speaks {SCHEMA_VERSION})"


_NAMED = re.compile(r"^Object (missing required|contains unknown) field `([^`]*)`$")
_NAMED_PROBLEM = {"missing required": "required field missing", "contains unknown": "unknown field"}


def field_problem(exc: msgspec.ValidationError, prefix: str = "$") -> str:
    """``path.to.field: problem`` of a msgspec refusal (``rovers.0.x``, ``<root>`` for the message as a whole):
    the path of the value that failed, in the form pydantic gave and ``schemas.scenario_errors`` still does."""
    problem, _, where = str(exc).rpartition(" - at `")
    if not problem:
        problem, where = str(exc), prefix + "`"
    parts = re.sub(r"\[(\d+)\]", r".\1", where.removesuffix("`").removeprefix(prefix)).strip(".")
    if (named := _NAMED.match(problem)) is not None:  # a field missing or unknown: the path names it
        parts, problem = f"{parts}.{named[2]}".strip("."), _NAMED_PROBLEM[named[1]]
    return f"{parts or '<root>'}: {problem}"


def checked(message: M) -> M:
    """``message`` as a receiver would accept it, or ``DecodeError`` naming the field that fails.

    A Struct checks its bounds when it is decoded, not when it is built: a message built from values that crossed
    a trust boundary (a driver's reading, a user's command, a ROS 2 sample, a page's request) goes through here
    before it is used or sent, so it is refused where the bad value came in, not counted as a rejection by every
    receiver."""
    try:
        payload = encode(message)
    except TypeError as exc:  # a value of a type the wire does not carry
        raise DecodeError(f"{type(message).__name__}: {exc}") from None
    return decode(type(message), payload)
