"""A rover's own spot at a goal the team shares: asked of the lander as the rover nears the goal (the lander's side
is ``lander_agent.stations``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from rover_agent.decisions import Goal, Hit
from schemas import radio
from shared.pose import Pose

STATION_ASK_M = 15.0
"""Near a shared waypoint, closer than this, the rover asks the lander for its station: just before it reaches
a 20-rover formation (8.5 m in radius at the default spacing), so stations go out in the order rovers arrive."""
STATION_ASK_RETRY_S = 2.0
DRAW_IN_SIGMAS = 2.0
"""A rover walks to its station at a shared waypoint drawn in toward the waypoint so that this many of its own
1-sigma position errors still leave it within the perception radius of it, where the waypoint counts as reached
(``drawn_in``)."""
DRAW_IN_LEAST = 0.6
"""A station is drawn in to no less than this share of its offset: the team's formation shrinks alike (its rovers'
errors are alike), and the lander's spacing (2 m between centres at the least) keeps a body's gap between them."""


def drawn_in(goal: Goal | None, position_std: float, radius: float) -> Goal | None:
    """``goal`` with its station at a shared waypoint drawn in toward the waypoint while the rover's estimate is
    too unsure for the station's offset (``DRAW_IN_SIGMAS``): a rover off by its error on an outer station of a
    large formation stands beyond the radius within which the waypoint is reached, one nearer the middle does not.
    The rover's own figures alone: its station and its estimate's error."""
    if goal is None or goal.kind != "waypoint" or goal.station is None:
        return goal
    offset = math.hypot(*goal.station)
    room = radius - DRAW_IN_SIGMAS * position_std
    if offset <= room or offset == 0.0:
        return goal
    share = max(DRAW_IN_LEAST, room / offset)
    return replace(goal, station=(goal.station[0] * share, goal.station[1] * share))


@dataclass
class StationAsk:
    asked_at: float = -math.inf

    def ask(self, goal: Goal | None, pose: Pose | None, hits: tuple[Hit, ...],
            now: float) -> radio.StationRequest | None:
        """Near a goal the team shares and with no station yet: ask the lander for one, again every
        ``STATION_ASK_RETRY_S`` until it comes (a lost request, or a lander out of reach for now). Near is
        ``STATION_ASK_M`` from the goal; for a crater, whose size the rover does not know, also once its terrain is
        in view, some metres before the rim (a rover in the bowl sees no rim ahead: it asks by the distance)."""
        if (goal is None or pose is None or not goal.shared or goal.station is not None
                or now - self.asked_at < STATION_ASK_RETRY_S
                or not (math.hypot(goal.x - pose.x, goal.z - pose.z) <= STATION_ASK_M
                        or (goal.kind == "crater" and any(h.kind == "crater_terrain" for h in hits)))):
            return None
        self.asked_at = now
        return radio.StationRequest(goal_index=goal.index, x=round(pose.x, 3), z=round(pose.z, 3))
