"""ROS 2 messages as plain dicts, and the CDR bytes and type hashes rmw_zenoh puts on the wire, from ``rosbags``.

The mapping (``ros2_bridge.mapping``) speaks dicts: ``{"header": {"stamp": {...}, "frame_id": ...}, ...}``, readable
and testable without any ROS class. Here they become rosbags' message objects and CDR (with the encapsulation
header, little-endian) through the Jazzy typestore, whose RIHS01 hashes are those of the ROS 2 Jazzy interfaces,
and back. No CDR is written by hand.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.base import Nodetype

from schemas.errors import LunarSimError

Fields = dict[str, Any]

_DTYPES = {"bool": np.bool_, "byte": np.uint8, "char": np.uint8, "int8": np.int8, "uint8": np.uint8,
           "int16": np.int16, "uint16": np.uint16, "int32": np.int32, "uint32": np.uint32, "int64": np.int64,
           "uint64": np.uint64, "float32": np.float32, "float64": np.float64}
_DEFAULTS = {"string": "", "bool": False, "float32": 0.0, "float64": 0.0}
MAX_INBOUND_BYTES = 64 * 1024
"""The largest CDR sample the bridge decodes: its inbound types (a pose, a point, a label) are a few hundred bytes."""


class CdrError(LunarSimError, ValueError):
    """A payload that is not a CDR encoding of the expected type (or too large to be one)."""


@cache
def typestore():
    return get_typestore(Stores.ROS2_JAZZY)


@cache
def type_hash(ros_type: str) -> str:
    """``RIHS01_<sha256 hex>``, REP 2016's hash, as rmw_zenoh puts it in keys and tokens."""
    return typestore().hash_rihs01(ros_type)


def build(ros_type: str, fields: Fields) -> Any:
    """A rosbags message of ``ros_type`` from a dict; fields left out take ROS's defaults (zero, empty)."""
    return _builder(ros_type)(fields)


Builder = Callable[[Any], Any]


@cache
def _builder(ros_type: str) -> Builder:
    """A function dict -> message for one type, made once: the type's fields and how to convert each. Plain values
    are taken as given (a default for what is left out), nested messages and arrays through their converter."""
    store = typestore()
    cls = store.types[ros_type]
    plain: list[tuple[str, Any]] = []
    converted: list[tuple[str, Builder]] = []
    for name, desc in store.fielddefs[ros_type][1]:
        if desc[0] == Nodetype.BASE:
            plain.append((name, _DEFAULTS.get(desc[1][0], 0)))
        else:
            converted.append((name, _converter(desc)))

    def make(fields: Fields | None) -> Any:
        given = fields or {}
        values = {name: convert(given.get(name)) for name, convert in converted}
        for name, default in plain:
            value = given.get(name)
            values[name] = default if value is None else value
        return cls(**values)

    return make


def _converter(desc: tuple) -> Builder:
    node, detail = desc
    if node == Nodetype.NAME:
        return _builder(detail)
    if node == Nodetype.BASE:
        default = _DEFAULTS.get(detail[0], 0)
        return lambda given: default if given is None else given
    (inner_node, inner), length = detail
    if inner_node == Nodetype.BASE and inner[0] in _DTYPES:
        dtype = _DTYPES[inner[0]]
        empty = length if node == Nodetype.ARRAY else 0

        def array(given: Any) -> np.ndarray:
            if given is None:
                return np.zeros(empty, dtype=dtype)
            return np.frombuffer(given, dtype) if isinstance(given, bytes) else np.asarray(given, dtype=dtype)

        return array
    item = _converter((inner_node, inner))
    missing = length if node == Nodetype.ARRAY else 0
    return lambda given: [item(v) for v in (given if given else [None] * missing)]


def to_dict(message: Any) -> Fields:
    """A rosbags message as plain Python: nested dicts, lists for arrays, ``bytes`` for uint8 arrays."""
    out: Fields = {}
    for name in message.__dataclass_fields__:
        if name == "__msgtype__" or name.isupper():
            continue
        value = getattr(message, name)
        if hasattr(value, "__msgtype__"):
            out[name] = to_dict(value)
        elif isinstance(value, np.ndarray):
            out[name] = value.tobytes() if value.dtype == np.uint8 else value.tolist()
        elif isinstance(value, list):
            out[name] = [to_dict(v) if hasattr(v, "__msgtype__") else v for v in value]
        else:
            out[name] = value
    return out


def encode(ros_type: str, fields: Fields) -> bytes:
    return bytes(typestore().serialize_cdr(build(ros_type, fields), ros_type))


def decode(ros_type: str, payload: bytes) -> Fields:
    """The dict of a CDR sample; ``CdrError`` for anything that is not one (rosbags raises several kinds)."""
    if len(payload) > MAX_INBOUND_BYTES:
        raise CdrError(f"{ros_type}: {len(payload)} bytes, more than {MAX_INBOUND_BYTES}")
    try:
        return to_dict(typestore().deserialize_cdr(payload, ros_type))
    except Exception as exc:  # SerdeError, struct.error, UnicodeDecodeError, ValueError...
        raise CdrError(f"{ros_type}: not CDR ({type(exc).__name__}: {str(exc)[:120]})") from None
