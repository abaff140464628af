"""The base of every LunarSim payload and the small vocabularies the message models share."""

from __future__ import annotations

from typing import Literal

from msgspec import Struct

HitKind = Literal["rover", "obstacle", "terrain", "lander", "crater_terrain"]
HIT_KINDS: tuple[HitKind, ...] = ("rover", "obstacle", "terrain", "lander", "crater_terrain")
GoalKind = Literal["crater", "waypoint"]
DirectionKind = Literal["crater", "waypoint", "relay"]
"""A mission direction may also send a rover to hold a relay spot of the daisy chain."""


class Message(Struct, frozen=True, forbid_unknown_fields=True, kw_only=True):
    """Base of every payload: strict about unknown fields so garbage is caught, not half-read.

    A msgspec Struct checks its fields' bounds when it is decoded or converted (``schemas.codec``), not when it is
    built: a value built from what crossed a trust boundary goes through ``schemas.codec.checked``. Cross-field
    rules live in ``__post_init__``, which runs on both. Every float is bounded (``schemas.wire_limits.finite``), so
    none is nan or inf. Each model is declared ``kw_only`` (msgspec does not inherit it): fields keep their order,
    required or not, and are named when built."""


RoverState = Literal["waiting", "migration", "avoiding", "climbing", "observing", "done", "stuck", "stopped",
                     "relay", "charging"]
