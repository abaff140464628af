"""A look back at the rim of a crater goal the rover has just left, to fix its heading before the way on.

On the crest a rover photographs the crater once round (report 10.5.3): eleven turns of 30 degrees, each turning its
heading by a little it does not sense, so it sets out from the crater as unsure of its heading as some eleven
moves would leave it (3.3 degrees at the generator's high noise), and that error swings the whole of its way on
aside. Walking straight out from the crest it does not see the rim behind it, and from the crest itself no ray
enters the circle its terrain begins at. Just outside that circle, turned to face the crater, it sees the rim's near
side, whose fitted centre corrects its position and, through their covariance, its heading
(``sightings.rim_centre``); its next move turns it to its goal anyway, as part of the move. One turn, so it looks
once a crater, and only while its heading is unsure enough (``LOOK_HEADING_STD_DEG``) for the turn's own error to
be worth it. Pure logic: the agent sends the turn.
"""

from __future__ import annotations

import math

from rover_agent.estimation.pose_filter import Localisation
from schemas.frames import bearing_deg, wrap_deg

LOOK_HEADING_STD_DEG = 2.0
"""A rover looks back only when its heading's 1-sigma error is above this: the turn adds one action's heading
error, and a sighting of a rim some 20-50 m off gives the bearing of its centre to a degree or two."""
OUTSIDE_M = 1.0
"""It looks once its estimate puts it at least this far outside the circle its crater's terrain begins at..."""
NEAR_SHARE = 0.6
"""...and at most this share of its perception radius outside it, so the rim's near side is well within view."""
IN_VIEW_DEG = 75.0
"""A crater centre within this angle of the rover's heading is in view already: no turn needed."""


def turn(loc: Localisation, rims: dict[int, tuple[float, float, float]], goal_index: int, looked: set[int],
         radius: float) -> tuple[int, float] | None:
    """(goal index of the crater, degrees to turn to face its centre) when a look back is due: a crater goal before
    ``goal_index``, not looked back at yet, the rover just outside its rim and unsure of its heading."""
    if loc.exact or math.degrees(math.sqrt(max(0.0, loc.cov[2][2]))) <= LOOK_HEADING_STD_DEG:
        return None
    x, z = loc.pose.x, loc.pose.z
    for index, (cx, cz, edge) in sorted(rims.items()):
        if index >= goal_index or index in looked:
            continue
        if not edge + OUTSIDE_M <= math.dist((x, z), (cx, cz)) <= edge + NEAR_SHARE * radius:
            continue
        degrees = wrap_deg(bearing_deg(cx - x, cz - z) - loc.pose.heading)
        if abs(degrees) <= IN_VIEW_DEG:
            looked.add(index)  # in view as it walks: the rim corrects it without a turn
            continue
        return index, round(degrees, 3)
    return None
