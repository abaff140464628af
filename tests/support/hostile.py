"""Hostile but well-formed payloads, drawn from the message models themselves: what a buggy or taken-over process
holding a valid certificate can send.

Each field gets values an attacker would try: integers at and past the codec's and the models' bounds, huge and
tiny floats, path-like, long and control-character strings, large bytes, long lists, unknown literals. The payload
is packed as the codec would, bypassing validation, so the receiver sees exactly what arrives on the wire.
"""

from __future__ import annotations

import types
import typing
from typing import Annotated, Any, Literal, get_args, get_origin

import msgpack
import msgspec
from hypothesis import strategies as st

from schemas import codec, radio

EXTREME_INTS = [0, 1, -1, 2**31 - 1, 2**31, 2**53 + 1, 2**63 - 1, -(2**63), 2**64 - 1]
EXTREME_FLOATS = [0.0, -0.0, 1.0, -1.0, 1e-300, 5e-324, 1e15, -1e15, 1e300, -1e300, float("inf"), float("nan")]
PATHS = ["../../../../tmp/lunarsim-escape/x", "/tmp/lunarsim-escape/x", "a/b", "..", ".", "", "x" * 300,
         "line\nbreak", "\x1b[31mred", "nul\x00", "CON", "é" * 70, "%s%n", "${HOME}"]
BIG_BYTES = 2 * 2**20
"""Large enough to matter, small enough to draw quickly: payload size bounds are tested at their limit elsewhere."""


def _strip(annotation: Any) -> Any:
    while get_origin(annotation) is Annotated:
        annotation = get_args(annotation)[0]
    return annotation


def _ints() -> st.SearchStrategy:
    return st.sampled_from(EXTREME_INTS) | st.integers(-(2**63), 2**64 - 1)  # what msgpack can carry


def _floats() -> st.SearchStrategy:
    return st.sampled_from(EXTREME_FLOATS) | st.floats()


def _strings() -> st.SearchStrategy:
    return st.sampled_from(PATHS) | st.text(max_size=80)


def _bytes() -> st.SearchStrategy:
    return (st.sampled_from([b"", b"\x89PNG\r\n\x1a\n", b"\x00" * BIG_BYTES, b"\xff" * 70_000])
            | st.binary(max_size=64))


def _list(item: st.SearchStrategy) -> st.SearchStrategy:
    return st.lists(item, max_size=6) | st.integers(4097, 6000).map(lambda n: [0] * n)


def value_for(annotation: Any) -> st.SearchStrategy:
    """Hostile values of one field's type."""
    annotation = _strip(annotation)
    origin, args = get_origin(annotation), get_args(annotation)
    if annotation is bool:
        return st.booleans() | st.sampled_from([0, 2, "yes"])
    if annotation is int:
        return _ints()
    if annotation is float:
        return _floats() | _ints()
    if annotation is str:
        return _strings()
    if annotation is bytes:
        return _bytes()
    if isinstance(annotation, type) and issubclass(annotation, msgspec.Struct):
        return fields_for(annotation)
    if origin is Literal:
        return st.sampled_from([*args, "bogus", ""])
    if origin in (typing.Union, types.UnionType):
        return st.one_of([value_for(a) for a in args])
    if origin is list:
        return _list(value_for(args[0]))
    if origin is tuple:
        return st.tuples(*(value_for(a) for a in args)) if args and args[-1] is not Ellipsis else st.just(())
    if origin is dict:
        return st.dictionaries(value_for(args[0]), value_for(args[1]), max_size=4)
    if annotation is type(None):
        return st.none()
    return st.none()


@st.composite
def fields_for(draw: st.DrawFn, model: type[msgspec.Struct]) -> dict:
    """A field dict of ``model``: every field hostile or default, now and then one left out or one too many."""
    fields = {}
    for info in msgspec.structs.fields(model):
        if info.required or draw(st.booleans()):
            fields[info.name] = draw(value_for(info.type))
    if draw(st.integers(0, 20)) == 0:
        fields["bogus_field"] = 1
    return fields


def pack(fields: dict) -> bytes:
    """As ``schemas.codec.encode`` frames a payload, without validating it."""
    return msgpack.packb([codec.SCHEMA_VERSION, fields], use_bin_type=True)


def pack_radio(tag: str, fields: dict) -> bytes:
    """A radio application payload (``schemas.radio.pack``), unvalidated."""
    return msgpack.packb([tag, pack(fields)], use_bin_type=True)


def payloads(model: type[msgspec.Struct]) -> st.SearchStrategy[bytes]:
    return fields_for(model).map(pack)


@st.composite
def radio_payloads(draw: st.DrawFn) -> bytes:
    """A radio transmission's payload: a hostile application message of any radio type."""
    tag = draw(st.sampled_from(sorted(radio.RADIO_TYPES)))
    return pack_radio(tag, draw(fields_for(radio.RADIO_TYPES[tag])))


def huge_lander_map(width: int = 4096, height: int = 2048) -> bytes:
    """A valid LanderMap of width x height cells (8 million by default: twice a viewer's bound), an obstacle in
    its first cell and the rest free, in a few kilobytes of zlib."""
    import zlib

    from schemas import messages as m

    packer = zlib.compressobj(6)
    cells = packer.compress(b"\x02" + b"\x01" * (width - 1)) + packer.compress(b"\x01" * (width * (height - 1)))
    return codec.encode(m.LanderMap(stamp=1.0, cell_m=1.0, origin_x=0.0, origin_z=0.0, width=width, height=height,
                                    classes=["unknown", "free", "obstacle", "crater", "rover"],
                                    cells=cells + packer.flush()))
