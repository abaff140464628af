"""What a daisy chain's relay does beyond holding its spot (``lander_agent.daisy_chain``): take up the goal it held
the route for, when the lander releases it at the last goal, or on its own once it has been cut off from the lander
there (``CommunicationParams.relay_cut_off_s``): a relay whose own route is gone carries nobody's traffic where it
stands. The lander places the spots knowing nothing of walls, and links need line of sight, so a wall between two
spots cuts a chain; the relays beyond it never hear the release. Both only with ``release_relays``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rover_agent.decisions import Goal
from schemas import messages as m
from schemas.params import CommunicationParams


@dataclass
class Relay:
    goal: Goal | None = None
    """The goal the rover holds a relay spot for (``MissionDirection.relay_for``)."""
    left_spot: int | None = None
    """The goal index whose relay spot the rover left, cut off: the chain's direction no longer holds it there."""

    def note(self, msg: m.MissionDirection) -> bool:
        """Keep what a relay's direction says of the goal behind it; False: ignore the direction (the rover left
        that spot, cut off, and the lander does not know)."""
        if msg.kind != "relay":
            return True
        if self.left_spot == msg.goal_index:
            return False
        place = msg.relay_for
        if place is not None:
            rad = math.radians(place.bearing_deg)
            self.goal = Goal(msg.goal_index, msg.goals_total, place.kind, place.distance_m * math.sin(rad),
                             place.distance_m * math.cos(rad))
        return True

    @staticmethod
    def released(goal: Goal, finished: tuple[int, str] | None) -> bool:
        """The goal this rover held a relay spot for, now its own: the chain was released at the last goal."""
        return finished == (goal.index, "relay") and goal.kind != "relay"

    def cut_off(self, finished: tuple[int, str] | None, silent_s: float, radio: CommunicationParams) -> Goal | None:
        """A relay on its spot at the last goal, with no word from the lander for ``relay_cut_off_s``, takes up the
        goal it held the route for, with no station (none can come): the report's rule, it stops where it meets
        the goal. That goal, when it does (the rover leaves its spot for good)."""
        goal = self.goal
        if (goal is None or not goal.final or finished != (goal.index, "relay") or not radio.release_relays
                or silent_s < radio.relay_cut_off_s):
            return None
        self.left_spot = goal.index
        return goal
