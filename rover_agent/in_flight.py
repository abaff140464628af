"""The one action an agent keeps in flight, and how it recovers when the world's answer is lost.

Every action carries an id. While a move or rotate runs the world reports it several times a second; an agent
that has heard nothing of its action for ``ACTION_QUERY_S`` sends it again with the same id (or its cancel),
and the world answers how that action stands instead of starting it again (``world_service.actions``). So no
lost sample, either way, leaves the agent waiting for ever.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rover_agent.dead_reckoning import Pose
from rover_agent.decisions import MoveTo, Rotate, TakePhoto
from rover_agent.saved_state import SavedFlight
from schemas import keyspace as ks
from schemas import messages as m
from schemas.wire_limits import ACTION_ID_STRIDE

SLOW_LEVEL, FULL_LEVEL = 1, 3
"""``SpeedAction`` levels (report 10): 1.5 and 3.5 m/s with the default parameters; the world starts at full."""
FULL_AGAIN_S = 10.0
"""Back at full speed after slow moves, the rover sends the full level with every move for this long, so one
lost message does not leave it slow for the rest of the mission."""

Out = tuple[str, m.Message]
ACTION_QUERY_S = 2.0
"""Silence after which the agent asks again: ten navigation status periods at the report's 5 Hz."""


UNDER_WAY_M = 0.5
"""A move is under way, facing along its way, once it has walked this far: before, the rover may still be turning
to face its goal (the world turns it first), and what lies ahead of it then is not on its way."""


@dataclass
class InFlight:
    decision: MoveTo | Rotate | TakePhoto
    start: Pose
    action_id: int = 0
    sent_at: float = 0.0
    heard_at: float = 0.0
    cancel_sent: bool = False
    queries: int = 0
    walked: float = 0.0  # metres along a move so far, from its latest status (``rover_agent.localising``)
    walked_at: float = 0.0  # that status's stamp

    def mine(self, action_id: int, ids_heard: bool = False) -> bool:
        """Whether an answer is about this action. 0 comes from a world or driver that sends no ids; once answers
        have carried ids, a 0 names someone else's id-less action (a ground tool's), never this one."""
        return action_id == self.action_id or (action_id == 0 and not ids_heard)

    @property
    def remaining_m(self) -> float:
        """Metres of a move under way still to go (``UNDER_WAY_M``); 0 before, or for another action."""
        if not isinstance(self.decision, MoveTo) or self.walked < UNDER_WAY_M:
            return 0.0
        return max(0.0, math.hypot(self.decision.x, self.decision.z) - self.walked)

    @property
    def navigating(self) -> bool:
        return isinstance(self.decision, MoveTo | Rotate)

    def request(self, keys: ks.Keyspace, rover_id: int) -> Out:
        decision, aid = self.decision, self.action_id
        if isinstance(decision, TakePhoto):
            return keys.rover(rover_id, ks.PHOTO_ACTION), m.PhotoAction(label=decision.label, action_id=aid)
        if isinstance(decision, MoveTo):
            return keys.rover(rover_id, ks.MOVE_ACTION), m.MoveAction(x=decision.x, z=decision.z, action_id=aid)
        return keys.rover(rover_id, ks.ROTATE_ACTION), m.RotateAction(degrees=decision.degrees, action_id=aid)

    def cancel(self, keys: ks.Keyspace, rover_id: int) -> Out:
        self.cancel_sent = True
        return keys.rover(rover_id, ks.CANCEL_ACTION), m.CancelAction(action_id=self.action_id)

    def query_due(self) -> float:
        return self.heard_at + ACTION_QUERY_S if self.navigating else math.inf

    def query(self, now: float, keys: ks.Keyspace, rover_id: int) -> Out:
        """The action (or its cancel) again, same id: the world answers how it stands."""
        self.heard_at, self.queries = now, self.queries + 1
        if self.cancel_sent:
            return keys.rover(rover_id, ks.CANCEL_ACTION), m.CancelAction(action_id=self.action_id)
        return self.request(keys, rover_id)

    def saved(self) -> SavedFlight | None:
        decision = self.decision
        if isinstance(decision, MoveTo):
            return SavedFlight(self.action_id, "move", self.start, x=decision.x, z=decision.z)
        if isinstance(decision, Rotate):
            return SavedFlight(self.action_id, "rotate", self.start, degrees=decision.degrees)
        return None  # a photo lost with a restart is given up, as one whose answer is lost

    @classmethod
    def resumed(cls, saved: SavedFlight, now: float) -> InFlight:
        """The action a restarted agent had in flight: asked about at once."""
        decision = MoveTo(saved.x, saved.z) if saved.kind == "move" else Rotate(saved.degrees)
        return cls(decision, saved.start, saved.action_id, sent_at=now, heard_at=now - ACTION_QUERY_S)


class ActionIds:
    def __init__(self, next_id: int = 0) -> None:
        self.next_id = next_id
        self.renewing = next_id == 0

    def take(self, now: float) -> int:
        if self.renewing:
            self.next_id, self.renewing = max(self.next_id, _first_id(now)), False
        action_id, self.next_id = self.next_id, self.next_id + 1
        return action_id

    def renew(self) -> None:
        """Go on from ids based on the time of the next action: above every id of an earlier life of this agent
        (based on an earlier millisecond), which the world has when it refuses one of these as stale."""
        self.renewing = True


def _first_id(now: float) -> int:
    """Based on the simulated millisecond (``schemas.wire_limits.ACTION_ID_STRIDE``): an agent restarted without its
    saved state never reuses an id of its earlier life, which the world would answer with the end of an old
    action."""
    return max(0, int(now * 1000)) * ACTION_ID_STRIDE + 1


@dataclass
class Pace:
    """The speed level that goes with each move (``MoveTo.slow``). Away from other rovers nothing is sent and the
    world keeps its full speed; every slow move says so, and so does every move for ``FULL_AGAIN_S`` from the
    first back at full speed, however long after the last slow one it comes. An agent restarted in between
    starts with nothing to resend: its rover walks slowly until its next slow move (the safe side)."""

    level: int = FULL_LEVEL  # the level the moves have asked for lately
    since: float = -math.inf  # when they began to

    def speed(self, decision: object, now: float, keys: ks.Keyspace, rover_id: int) -> list[Out]:
        if not isinstance(decision, MoveTo):
            return []
        level = SLOW_LEVEL if decision.slow else FULL_LEVEL
        if level != self.level:
            self.level, self.since = level, now
        if level == FULL_LEVEL and now - self.since > FULL_AGAIN_S:
            return []
        return [(keys.rover(rover_id, ks.SPEED_ACTION), m.SpeedAction(level=level))]
