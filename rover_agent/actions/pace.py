"""The speed level that goes with each move: slow among rovers at close quarters (``MoveTo.slow``), full elsewhere."""

from __future__ import annotations

import math
from dataclasses import dataclass

from rover_agent.decisions import MoveTo
from rover_agent.outgoing import Sender
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out

SLOW_LEVEL, FULL_LEVEL = 1, 3
"""``SpeedAction`` levels (report 10): 1.5 and 3.5 m/s with the default parameters; the world starts at full."""
FULL_AGAIN_S = 10.0
"""Back at full speed after slow moves, the rover sends the full level with every move for this long, so one
lost message does not leave it slow for the rest of the mission."""


@dataclass
class Pace:
    """Away from other rovers nothing is sent and the world keeps its full speed; every slow move says so, and so
    does every move for ``FULL_AGAIN_S`` from the first back at full speed, however long after the last slow one it
    comes. An agent restarted in between starts with nothing to resend: its rover walks slowly until its next slow
    move (the safe side)."""

    level: int = FULL_LEVEL  # the level the moves have asked for lately
    since: float = -math.inf  # when they began to

    def speed(self, decision: object, now: float, send: Sender) -> list[Out]:
        if not isinstance(decision, MoveTo):
            return []
        level = SLOW_LEVEL if decision.slow else FULL_LEVEL
        if level != self.level:
            self.level, self.since = level, now
        if level == FULL_LEVEL and now - self.since > FULL_AGAIN_S:
            return []
        return [(send.key(ks.SPEED_ACTION), m.SpeedAction(level=level))]
