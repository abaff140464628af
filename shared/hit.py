"""One perceived thing (report 10.1), as a rover's behaviour and a hardware driver see it."""

from __future__ import annotations

from dataclasses import dataclass

from schemas.messages import HitKind

__all__ = ["Hit"]


@dataclass(frozen=True)
class Hit:
    """Angle relative to the rover in degrees (negative left), distance in metres, what it is."""

    angle_deg: float
    distance_m: float
    kind: HitKind
