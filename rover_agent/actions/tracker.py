"""The agent's actions: the one in flight, the ids they take, the speed level sent with moves, and the moment the
last one ended, after which the agent decides again on fresh sensor data only."""

from __future__ import annotations

import logging

from rover_agent.actions.ids import ActionIds
from rover_agent.actions.in_flight import InFlight
from rover_agent.actions.pace import Pace
from rover_agent.decisions import MoveTo, Rotate, TakePhoto
from rover_agent.outgoing import Sender
from rover_agent.restarts.saved_state import SavedFlight
from schemas.messages import Out
from shared.pose import Pose

log = logging.getLogger("lunarsim.rover")

PHOTO_TIMEOUT_S = 10.0
"""A photo not back by then is given up (a rover without a working camera must not wait for ever)."""


class ActionTracker:
    def __init__(self, send: Sender) -> None:
        self.send = send
        self.ids = ActionIds()
        self.in_flight: InFlight | None = None
        self.pace = Pace()
        self.heard_action = 0
        """The last action whose end this agent has heard (``RoverStatus.action_id``)."""
        self.ids_heard = False
        """The world's answers name this agent's action ids (a driver's may not)."""
        self.settled_at = 0.0
        """When the last action ended: sensor data taken before then says nothing of where the rover is now."""

    def start(self, decision: MoveTo | Rotate | TakePhoto, pose: Pose, now: float) -> list[Out]:
        """Send an action, with its speed level if it is a move: it is in flight until the world answers."""
        self.in_flight = InFlight(decision, pose, self.ids.take(now), sent_at=now, heard_at=now)
        return [*self.pace.speed(decision, now, self.send), self.in_flight.request(self.send)]

    def answered(self, action_id: int) -> InFlight | None:
        """The navigating action in flight, if an answer naming ``action_id`` is about it. Once an answer has named
        this agent's own id, one naming 0 is about someone else's id-less action (a ground tool's), not this one."""
        flight = self.in_flight
        if flight is None or not flight.navigating:
            return None
        self.ids_heard = self.ids_heard or action_id == flight.action_id
        return flight if flight.mine(action_id, self.ids_heard) else None

    def photo(self, label: str) -> bool:
        """Whether a photo with this label is the action in flight."""
        flight = self.in_flight
        return flight is not None and isinstance(flight.decision, TakePhoto) and label == flight.decision.label

    def settle(self, stamp: float) -> None:
        """The action is over; decide again only on sensor data taken after ``stamp``."""
        if self.in_flight is not None:
            self.heard_action = max(self.heard_action, self.in_flight.action_id)
        self.in_flight = None
        self.settled_at = stamp

    def settled_by(self, stamp: float) -> bool:
        return stamp >= self.settled_at

    def query(self, now: float) -> Out | None:
        """The action in flight again once the world has said nothing of it for a while (``ACTION_QUERY_S``)."""
        flight = self.in_flight
        if flight is None or now < flight.query_due():
            return None
        log.info("rover %d: no word of action %d for a while; asking again", self.send.rover_id, flight.action_id)
        return flight.query(now, self.send)

    def photo_overdue(self, now: float) -> bool:
        """The photo in flight is ``PHOTO_TIMEOUT_S`` late: the agent goes on without it."""
        flight = self.in_flight
        if flight and isinstance(flight.decision, TakePhoto) and now - flight.sent_at > PHOTO_TIMEOUT_S:
            log.warning("rover %d: no photo %r after %g s; going on without it", self.send.rover_id,
                        flight.decision.label, PHOTO_TIMEOUT_S)
            return True
        return False

    def timers(self) -> list[float]:
        """When ``query`` or ``photo_overdue`` will next have something to say."""
        flight = self.in_flight
        if flight is None:
            return []
        if isinstance(flight.decision, TakePhoto):
            return [flight.query_due(), flight.sent_at + PHOTO_TIMEOUT_S]
        return [flight.query_due()]

    def stop(self) -> list[Out]:
        """Cancel a move or rotate under way (once)."""
        flight = self.in_flight
        if flight and flight.navigating and not flight.cancel_sent:
            return [flight.cancel(self.send)]
        return []

    def renew_ids(self) -> None:
        """The world has a later action of this rover than the agent knows of (one sent in an earlier life), or a
        run restarted its clock: go on from ids above it."""
        self.ids.renew()

    def resume(self, next_action: int, flight: SavedFlight | None, now: float) -> None:
        """Take up the ids and the action in flight a restarted agent saved."""
        self.ids = ActionIds(next_action)
        if flight is not None:
            self.in_flight = InFlight.resumed(flight, now)

    def drop(self) -> None:
        """Forget the action in flight: an agent that does not know where it is acts no more."""
        self.in_flight = None

    def saved(self) -> tuple[SavedFlight | None, int]:
        """What a restart resumes of the actions: the one in flight and the next id."""
        return (self.in_flight.saved() if self.in_flight is not None else None), self.ids.next_id
