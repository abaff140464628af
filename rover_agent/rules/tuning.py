"""The default behaviour's tuning: thresholds in degrees, metres and seconds, each with the reason for its value.
Kept apart from the rules that use them (``rover_agent.behaviour``, ``crater``, ``crowd``) so they can be read, and
changed, together."""

from __future__ import annotations

CLIMB_PITCH = 2.0
"""Degrees of nose-up pitch that count as having started up the crater rim."""
CREST_PITCH = 0.5
"""At or below this pitch, after climbing, the rover stands on the crest."""
LEVEL_MARGIN_M = 2.0
"""A long step on level ground below a crest station ends at least this far, and two of the estimate's 1-sigma
errors, short of it (``CraterRules.level_step``)."""
NEAR_CREST_PITCH = 4.0
"""Below this pitch, after climbing, the crest is close: half steps."""
CREST_FACING = 30.0
"""Degrees within which the rover must face the crater for its pitch to say anything about the crest."""
WAYPOINT_IN_VIEW = 0.9
"""A waypoint is in view within this fraction of the perception radius (report 6.6)..."""
WAYPOINT_CLOSE = 0.5
"""...but the rover walks on to within this fraction, leaving room for dead-reckoning drift, unless rovers
already there block the way."""
RELAY_CLOSE_M = 1.5
"""A relay holds its spot within this distance: the chain's spacing margin is for drift, not for slack."""
SPOT_HELD_M = 3.0
"""A relay spot or a station this near that the rover walked ``NO_PROGRESS_ROUTE_M`` round without getting nearer
is taken (a rock or a wall on it, or in the last metres of the way): the rover holds where it is, rather than
circle it until the world's watchdog counts it stuck (development seed 175's first relay circled its spot 1.8-2.5
m off for 300 s). Twice ``RELAY_CLOSE_M``: a chain's link lengthens by no more than the circling did."""
STATION_CLOSE_M = 1.5
"""A station (the rover's own spot at a shared waypoint) is reached within ``STATION_CLOSE_M``; when rovers
leave no way in and first did ``CROWD_SQUEEZE_S`` before (``crowd``), wherever the waypoint is in
view (the report's rule), but not short of the station with the waypoint out of view: not at the goal."""
MAX_BLOCKED_ROTATIONS = 12
"""Rotations with every direction blocked by obstacles, without progress, before giving up on a goal."""
MAX_CROWD_WAIT_S = 90.0
"""Seconds without progress among other rovers before giving up: rovers move on, rocks do not."""
NO_PROGRESS_ROUTE_M = 20.0
"""Metres walked without getting any closer to the goal before the rover plans a route on its map: the
greedy scan can pace along a long wall (turn to the goal, slide right, turn, slide left...) without ever
being blocked everywhere in view, which is what otherwise switches routing on."""
NO_PROGRESS_WALK_M = 300.0
"""Metres walked without getting any closer to the goal, routing or not, before giving up."""
KNOT_ROUTE_RADII = 2.0
"""Farther than this many perception radii from its goal, a rover long held up by rovers plans a route round them
(``CrowdRules.rovers_in_way``); nearer, they are the team at the goal, and the route only led it to and fro
among their stations (within one radius, rovers of the 20-rover maze were stopped by the world's watchdog)."""
KNOT_MEMORY_S = 10.0
"""...and keeps clear of the rovers it saw in the last this many seconds, in view or not now: long enough to turn
round and look, short enough that a rover that walked on does not stay in the way."""
CROWD_SQUEEZE_S = 15.0
"""After this long without progress among rovers, the rover keeps only close-quarters gaps to squeeze by."""
GIVE_WAY_S = 30.0
"""After this long held up by rovers, a rover steps aside, away from its goal (``crowd``): rovers
that block each other, each waiting for the others (two head on in a gap, four in a knot in a corridor), would
otherwise all give up at ``MAX_CROWD_WAIT_S``."""
GIVE_WAY_TRIES = 2
"""Steps aside (or turns to look for room to step aside) in one jam."""
GIVE_WAY_OFF_GOAL_DEG = 60.0
"""A step aside leaves at least this far off the direction to the goal: it makes room, rather than pushing in."""
GIVE_WAY_HOLD_S = 10.0
"""After a step aside, the rover waits about this long for the others to pass before heading for the goal again
(half of it to one and a half times it, by rover id)."""
CROWD_LOOKS = 3
"""While waiting in a crowd, every this many waits the rover rotates to look for another way."""
FOLLOW_SHARE = 0.5
"""A rover ahead that leaves less than this share of the step the rover wanted: wait for it to walk on rather
than creep after it (``CrowdRules.follow``)."""
FOLLOW_WAITS = 3
"""...at most this many waits in a row; then the short step."""
RIGHT_OF_WAY_DEG = 10.0
"""A rover ahead, or to the right of this many degrees left of ahead, has right of way (report 7.2.1)."""
MAX_CREST_LOOKS = 3
BOWL_PITCH = 6.0
"""Degrees nose-down, facing the crater after a climb, that only the bowl's inner wall gives: a step took the
rover over the crest (the outer rim is still steep just below it, so steps there are whole). The report's rover
observes from there; this one turns round and steps back, since on the wall it is not on the crest that is its
goal (a narrow rim's crest is a step wide) and the rim hides it from a daisy chain's last relay outside. The
crest is then known, and it observes from where it stands once, facing the crater, the pitch says it is out of
the bowl."""
MAX_BACKS = 3
CHARGE_CHECK_S = 1.0
"""While charging in sunlight the rover looks at its battery again this often."""
