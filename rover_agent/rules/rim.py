"""A crater goal with a station on the crest (``lander_agent.stations.rim_offsets``): the way to it.

The rover first walks to the foot of its station's spoke, a point outside the rim on the line from the goal
(within the bowl, near the crater's centre) through the station, and only then climbs, along the spoke. So a
team meets the crest spread all round it, each rover on its own stretch, instead of all climbing to the crest
point nearest where they came from, where the later ones are held off the crest behind the first. A rover
already between the foot and the crest, near its spoke (``joins_spoke``), climbs from where it stands: a station
comes once the crater's terrain is in view, often with the rover past the foot already. The climb
itself is the default behaviour's: at its station by its own estimate a rover counts as up the rim, and pitch,
facing the crater, still says whether it stands on the crest.
"""

from __future__ import annotations

import math

from rover_agent.decisions import Goal
from rover_agent.rules.tuning import CREST_FACING
from schemas.frames import bearing_deg, wrap_deg
from shared.pose import Pose

FOOT_OUT = 0.6
"""The foot of a spoke stands this share of the crest's radius outside the crest: beyond the rim's outer slope
(0.3 of the radius for the default crater), so the climb from it starts on level ground."""
FOOT_LEAST_M = 4.0
"""...and at least this far out, for small craters."""
CREST_AFTER = 0.5
"""Climbing from the foot, a crest told by pitch counts only after this share of the way in: a bump at the foot
is not the crest (the default behaviour's rule, walking the perception radius, is for a rover that does not know
how far the crest is)."""
SPOKE_CONE_DEG = 45.0
"""Seen from its station, a rover within this angle of the spoke, outside the crest and no farther out than the
foot, is on its way up the spoke already: walking back out to the foot only to climb the same slope again cost a
rover of the crater mission 43 m of walking and 22 s, the last to finish."""


def _out_m(goal: Goal) -> float:
    return max(FOOT_LEAST_M, FOOT_OUT * math.hypot(*goal.station))


def foot(goal: Goal) -> tuple[float, float]:
    """The foot of the spoke of ``goal``'s station, in the frame of the goal."""
    sx, sz = goal.station
    reach = math.hypot(sx, sz)
    if reach < 1e-9:  # a station at the goal's own point: no spoke to walk along
        return goal.x, goal.z
    scale = (reach + _out_m(goal)) / reach
    return goal.x + sx * scale, goal.z + sz * scale


def crest_after_m(goal: Goal, out_m: float | None = None) -> float:
    """Metres to walk from the foot (or from where the rover joined its spoke, ``out_m`` outside the station)
    before the crest can be told by pitch."""
    return CREST_AFTER * (_out_m(goal) if out_m is None else out_m)


def joins_spoke(goal: Goal, pose: Pose) -> float | None:
    """How far outside its station, along the spoke, a rover stands that is on its way up the spoke already (within
    ``SPOKE_CONE_DEG`` of it, no farther out than the foot); None when it is not, and walks to the foot."""
    sx, sz = goal.station
    reach = math.hypot(sx, sz)
    if reach < 1e-9:
        return None
    ux, uz = sx / reach, sz / reach
    rx, rz = pose.x - goal.x - sx, pose.z - goal.z - sz  # from the station to the rover
    along, across = rx * ux + rz * uz, abs(rx * uz - rz * ux)
    if not 0.0 < along <= _out_m(goal) or across > along * math.tan(math.radians(SPOKE_CONE_DEG)):
        return None
    return along


def facing_station(goal: Goal, pose: Pose) -> bool:
    """Facing its crest station: a rover that could not reach the spoke's foot climbs the rim slantwise, not
    facing the crater's centre, and its pitch still tells the climb."""
    tx, tz = goal.target
    return abs(wrap_deg(bearing_deg(tx - pose.x, tz - pose.z) - pose.heading)) <= CREST_FACING
