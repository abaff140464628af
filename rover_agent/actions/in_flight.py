"""The one action an agent keeps in flight: what it asked, from where, and what the world has said of it since.

Every action carries an id. While a move or rotate runs the world reports it several times a second; an agent
that has heard nothing of its action for ``ACTION_QUERY_S`` sends it again with the same id (or its cancel),
and the world answers how that action stands instead of starting it again (``world_service.actions``). So no
lost sample, either way, leaves the agent waiting for ever.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rover_agent.decisions import MoveTo, Rotate, TakePhoto
from rover_agent.outgoing import Sender
from rover_agent.restarts.saved_state import SavedFlight
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from shared.pose import Pose

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
    walked: float = 0.0  # metres along a move so far, from its latest status
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

    def walking(self, stamp: float, remaining: float) -> None:
        """A running move's status: how far along it the rover has got (the world says what is still to go)."""
        if isinstance(self.decision, MoveTo):
            self.walked = max(0.0, math.hypot(self.decision.x, self.decision.z) - remaining)
            self.walked_at = stamp

    def request(self, send: Sender) -> Out:
        decision, aid = self.decision, self.action_id
        if isinstance(decision, TakePhoto):
            return send.key(ks.PHOTO_ACTION), m.PhotoAction(label=decision.label, action_id=aid)
        if isinstance(decision, MoveTo):
            return send.key(ks.MOVE_ACTION), m.MoveAction(x=decision.x, z=decision.z, action_id=aid)
        return send.key(ks.ROTATE_ACTION), m.RotateAction(degrees=decision.degrees, action_id=aid)

    def cancel(self, send: Sender) -> Out:
        self.cancel_sent = True
        return send.key(ks.CANCEL_ACTION), m.CancelAction(action_id=self.action_id)

    def query_due(self) -> float:
        return self.heard_at + ACTION_QUERY_S if self.navigating else math.inf

    def query(self, now: float, send: Sender) -> Out:
        """The action (or its cancel) again, same id: the world answers how it stands."""
        self.heard_at = now
        if self.cancel_sent:
            return send.key(ks.CANCEL_ACTION), m.CancelAction(action_id=self.action_id)
        return self.request(send)

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
