"""A crater goal with a station on the crest (``lander_agent.stations.rim_offsets``): the way to it.

The rover first walks to the foot of its station's spoke, a point outside the rim on the line from the goal
(within the bowl, near the crater's centre) through the station, and only then climbs, along the spoke. So a
team meets the crest spread all round it, each rover on its own stretch, instead of all climbing to the crest
point nearest where they came from, where the later ones are held off the crest behind the first. The climb
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


def crest_after_m(goal: Goal) -> float:
    """Metres to walk from the foot before the crest can be told by pitch."""
    return CREST_AFTER * _out_m(goal)


def facing_station(goal: Goal, pose: Pose) -> bool:
    """Facing its crest station: a rover that could not reach the spoke's foot climbs the rim slantwise, not
    facing the crater's centre, and its pitch still tells the climb."""
    tx, tz = goal.target
    return abs(wrap_deg(bearing_deg(tx - pose.x, tz - pose.z) - pose.heading)) <= CREST_FACING
