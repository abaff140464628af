"""The base of every LunarSim payload and the small vocabularies the message models share."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict

HitKind = Literal["rover", "obstacle", "terrain", "lander", "crater_terrain"]
HIT_KINDS: tuple[HitKind, ...] = ("rover", "obstacle", "terrain", "lander", "crater_terrain")
GoalKind = Literal["crater", "waypoint"]
DirectionKind = Literal["crater", "waypoint", "relay"]
"""A mission direction may also send a rover to hold a relay spot of the daisy chain."""


class Message(BaseModel):
    """Base of every payload: strict about unknown fields so garbage is caught, not half-read."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)
RoverState = Literal["waiting", "migration", "avoiding", "climbing", "observing", "done", "stuck", "stopped",
                     "relay", "charging"]
