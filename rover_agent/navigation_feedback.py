"""How a rover agent follows the world's answers to its actions: each ends with a completion, a cancel's result or a
refusal, and only then does the agent move its pose estimate (``rover_agent.localisation``) and decide again.

A mixin of ``RoverAgent`` (its state: ``in_flight``, ``pose``, ``behaviour``...), kept apart so the agent's own
module stays about its inputs and decisions.
"""

from __future__ import annotations

import logging
import math

from rover_agent.decisions import MoveTo
from rover_agent.in_flight import InFlight
from schemas import messages as m

log = logging.getLogger("lunarsim.rover")


class NavigationFeedback:
    def _answered(self, action_id: int) -> InFlight | None:
        """The navigating action in flight, if an answer naming ``action_id`` is about it. Once an answer has named
        this agent's own id, one naming 0 is about someone else's id-less action (a ground tool's), not this one."""
        flight = self.in_flight
        if flight is None or not flight.navigating:
            return None
        self.ids_heard = self.ids_heard or action_id == flight.action_id
        return flight if flight.mine(action_id, self.ids_heard) else None

    def _on_navigation_status(self, msg: m.NavigationStatus) -> list:
        self.now = max(self.now, msg.stamp)
        flight = self._answered(msg.action_id)
        if flight is None:
            return []  # an old action's end sent again, or a photo's (not a navigation action)
        flight.heard_at = self.now
        if msg.outcome == "running":
            self._walking(msg.stamp, msg.remaining)
            return []
        if msg.outcome == "completed":
            decision = flight.decision
            if isinstance(decision, MoveTo):
                self._estimate(flight.start).moved(flight.start, decision.x, decision.z)
                self.behaviour.moved(math.hypot(decision.x, decision.z))
            else:
                self._estimate(flight.start).rotated(flight.start, decision.degrees)
            self._settle(msg.stamp)
        # otherwise the action ended early: the CancelResult that follows says where the rover stopped
        return []

    def _on_cancel_result(self, msg: m.CancelResult) -> list:
        flight = self._answered(msg.action_id)
        if flight is None:
            return []
        self._estimate(flight.start).stopped_early(flight.start, msg.x, msg.z, msg.angle_deg)
        self.behaviour.moved(math.hypot(msg.x, msg.z))
        self.behaviour.cancelled(self.now)
        self._settle(self.now)
        return []

    def _on_action_rejected(self, msg: m.ActionRejected) -> list:
        flight = self._answered(msg.action_id)
        if flight is None:
            return []
        if msg.action == "cancel":  # the world never had the action (its sample was lost): the rover did not move
            if msg.action_id == flight.action_id:
                self._settle(self.now)
            return []
        if msg.action not in ("move", "rotate"):
            return []
        if msg.reason in ("stale", "out_of_sequence"):  # the world has a later action of this rover than the agent
            self.ids.renew()  # knows of (one sent in an earlier life), or a run restarted its clock: nothing about the
            # ground, only the ids to renew
        elif isinstance(flight.decision, MoveTo):
            self.behaviour.rejected(math.degrees(math.atan2(flight.decision.x, flight.decision.z)))
        log.info("rover %d: %s rejected (%s): %s", self.id, msg.action, msg.reason, msg.detail)
        self._settle(self.now)
        return []

    def _settle(self, stamp: float) -> None:
        """The action is over; decide again only on sensor data taken after this moment."""
        if self.in_flight is not None:
            self.heard_action = max(self.heard_action, self.in_flight.action_id)
        self.in_flight = None
        self.settled_at = stamp
        self._save()
