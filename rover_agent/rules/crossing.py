"""Rovers on a collision course, from two scans in a row: the time-to-contact rule of a move under way.

The right-of-way rule (``behaviour.should_cancel``) judges a rover seen by where it is. That is enough ahead,
where the rover stops for traffic well before it, but not across: rovers walk at up to 3.5 m/s and scan five
times a second, so two crossing at right angles close by up to a metre a scan, and a rover seen to the side
first a body's length away is hit before a stop can take effect. What a real rover can know of the other's
motion is how it moved between two of its own scans. Each rover seen is placed by its centre (``sightings``),
matched to the nearest centre of the scan before, and the pair's relative velocity tells whether the two will
come closer than contact, and when. A move runs straight, so the scans' frames differ only by the rover's own
advance, which the relative velocity includes: a rover standing to the side is passed, one crossing is closed on
from the side.

Pure logic on perception hits; the behaviour asks it on every scan of a move.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from rover_agent.decisions import Hit
from rover_agent.estimation.sightings import rover_centres
from schemas.params import RoverParams

CONTACT_MARGIN_M = 0.3
"""Passing closer than two rover radii and this is a collision course."""
STOP_WITHIN_S = 0.6
"""A move stops when contact would come sooner than this: a scan (0.2 s), a tick for the cancel to reach the
legs, and the stop itself, with as much again to spare."""
MATCH_M = 1.5
"""A rover seen now is the one seen the scan before at most this far off (2.5 m/s closing, a scan apart, and
the centre's own jitter)."""
MAX_GAP_S = 0.5
"""Two scans further apart than this say nothing about motion now."""
MIN_ACROSS_M_S = 1.0
"""A rover seen moving across this rover's way at least this fast is walking itself (the centres of a rover
standing still jitter by a few centimetres a scan). One standing, or walking straight at or away from this one,
is the position rules' (``behaviour.should_cancel``), which stop for it ahead in time: a move then ends at its
gap from a rover standing there, which contact time alone would take for a collision."""


@dataclass
class CrossingWatch:
    rover_radius: float
    ray_step_deg: float
    _last: tuple[float, list[tuple[float, float]]] | None = field(default=None, repr=False)

    @classmethod
    def of(cls, params: RoverParams) -> CrossingWatch:
        return cls(params.behaviour.rover_radius, params.perception.ray_step_deg)

    def reset(self) -> None:
        """A new move: the frame of the scans before it is not this one's."""
        self._last = None

    def danger(self, time: float, hits: tuple[Hit, ...]) -> bool:
        """Whether a rover in this scan will come into contact within ``STOP_WITHIN_S``."""
        centres = rover_centres(hits, self.rover_radius, self.ray_step_deg)
        last, self._last = self._last, (time, centres)
        if last is None or not 0.0 < time - last[0] <= MAX_GAP_S:
            return False
        dt = time - last[0]
        contact = 2 * self.rover_radius + CONTACT_MARGIN_M
        for now in centres:
            before = min(last[1], key=lambda c: math.dist(c, now), default=None)
            if before is None or math.dist(before, now) > MATCH_M:
                continue
            velocity = ((now[0] - before[0]) / dt, (now[1] - before[1]) / dt)
            if abs(velocity[0]) < MIN_ACROSS_M_S:
                continue
            if (when := contact_time(now, velocity, contact)) is not None and when < STOP_WITHIN_S:
                return True
        return False


def contact_time(p: tuple[float, float], v: tuple[float, float], contact: float) -> float | None:
    """When a point at ``p`` moving at ``v`` first comes within ``contact`` of the origin (0: it is already, and
    closing); None: never, or only moving away."""
    closing = p[0] * v[0] + p[1] * v[1]
    if closing >= 0.0:
        return None
    a = v[0] ** 2 + v[1] ** 2
    c = p[0] ** 2 + p[1] ** 2 - contact ** 2
    if c <= 0.0:
        return 0.0
    disc = closing ** 2 - a * c
    if disc < 0.0:
        return None
    return (-closing - math.sqrt(disc)) / a
