"""What a daisy chain's relay does beyond holding its spot (``lander_agent.daisy_chain``): take up the goal it held
the route for, when the lander releases it at the last goal, or on its own once it has been cut off from the lander
there (``CommunicationParams.relay_cut_off_s``): a relay whose own route is gone carries nobody's traffic where it
stands. The lander places the spots knowing nothing of walls, and links need line of sight, so a wall between two
spots cuts a chain; the relays beyond it never hear the release. Both only with ``release_relays``.

A mixin of ``RoverAgent`` (its state: ``params``, ``goal``, ``finished_goal``, ``contact``, ``behaviour``,
``now``), kept apart so the agent's own module stays about its inputs and decisions.
"""

from __future__ import annotations

import logging
import math

from rover_agent.decisions import Goal
from schemas import messages as m

log = logging.getLogger("lunarsim.rover")


class Relaying:
    relay_goal: Goal | None = None
    """The goal the rover holds a relay spot for (``MissionDirection.relay_for``)."""
    left_spot: int | None = None
    """The goal index whose relay spot the rover left, cut off: the chain's direction no longer holds it there."""

    def _note_relay(self, msg: m.MissionDirection) -> bool:
        """Keep what a relay's direction says of the goal behind it; False: ignore the direction (the rover left
        that spot, cut off, and the lander does not know)."""
        if msg.kind != "relay":
            return True
        if self.left_spot == msg.goal_index:
            return False
        place = msg.relay_for
        if place is not None:
            rad = math.radians(place.bearing_deg)
            self.relay_goal = Goal(msg.goal_index, msg.goals_total, place.kind, place.distance_m * math.sin(rad),
                                   place.distance_m * math.cos(rad))
        return True

    def _relay_released(self, goal: Goal) -> bool:
        """The goal this rover held a relay spot for, now its own: the chain was released at the last goal."""
        return self.finished_goal == (goal.index, "relay") and goal.kind != "relay"

    def _walk_on_if_cut_off(self) -> bool:
        """A relay on its spot at the last goal, with no word from the lander for ``relay_cut_off_s``, takes up the
        goal it held the route for, with no station (none can come): the report's rule, it stops where it meets
        the goal. True when it did (its status changed)."""
        goal, radio = self.relay_goal, self.params.communication
        if (goal is None or not goal.final or self.finished_goal != (goal.index, "relay") or not radio.release_relays
                or self.now - self.contact.heard_at < radio.relay_cut_off_s):
            return False
        log.info("rover %d: no word from the lander for %.0f s on its relay spot; walking on to goal %d", self.id,
                 self.now - self.contact.heard_at, goal.index)
        self.goal, self.finished_goal, self.left_spot = goal, None, goal.index
        self.behaviour.start_goal(goal)
        return True
