"""At a crater goal: to the foot of the station's spoke, up the rim by pitch, off the bowl's wall, out of a bowl
the rover found itself in, and the photographs once round (report 6.4, 7.2.2 and 10.5.3).

A mixin of ``DefaultBehaviour``, whose fields (``_crater_seen_at``, ``_max_pitch``, ``_on_spoke``...) and walking
(``_head_for``, ``_pacing``, ``_free_distance``) it uses: kept apart so the behaviour's module stays about getting
to a goal. Pure logic, no I/O.
"""

from __future__ import annotations

import math

from rover_agent import rim
from rover_agent.decisions import Decision, Finish, Goal, MoveTo, Rotate, TakePhoto, View
from rover_agent.tuning import (
    BOWL_PITCH,
    CLIMB_PITCH,
    CREST_FACING,
    CREST_PITCH,
    MAX_BACKS,
    MAX_CREST_LOOKS,
    NO_PROGRESS_ROUTE_M,
    STATION_CLOSE_M,
    WAYPOINT_CLOSE,
)
from schemas.frames import bearing_deg, wrap_deg
from schemas.params import RoverParams


def near_station_m(params: RoverParams) -> float:
    """Two bodies: how near its crest station a rover held up on the rim must be to take the crest as a body or
    two ahead (``CraterRules._near_station``)."""
    return 4 * params.behaviour.rover_radius


class CraterRules:
    def _observe(self, goal: Goal) -> Decision:
        """On the rim: a photo, a turn of ``photo_step_deg``, a photo... once round (report 10.5.3)."""
        step = self.params.behaviour.photo_step_deg
        if self._photos_taken >= max(1, round(360.0 / step)):
            return Finish("reached")
        if self._photo_due:
            self._photo_due = False
            self._photos_taken += 1
            # The label names the photo's file at the lander and its caption on the page: a person reads it, so
            # goals count from 1 there as in the terminal (goal_index, the wire's, stays 0-based beside it).
            return TakePhoto(f"goal{goal.index + 1}_{(self._photos_taken - 1) * step:05.1f}deg")
        self._photo_due = True
        return Rotate(step)

    def _to_spoke(self, view: View) -> Decision | None:
        """With a station on the crest: walk to the foot of its spoke first (``rim``); None from there on, or
        where the way to the foot stops getting shorter (the climb then starts where the rover stands)."""
        goal, pose = view.goal, view.pose
        if goal.station is None or self._on_spoke:
            return None
        fx, fz = rim.foot(goal)
        gap = math.hypot(fx - pose.x, fz - pose.z)
        if gap > STATION_CLOSE_M and not self._pacing(gap, NO_PROGRESS_ROUTE_M):
            return self._head_for(view.toward(fx, fz), gap, None)
        self._on_spoke, self._routing, self._closest = True, False, (math.inf, self._odometer)
        self._crater_seen_at, self.state = self._odometer, "climbing"
        return None

    def _climb(self, view: View) -> Decision | None:
        if self._crater_seen_at is None and any(h.kind == "crater_terrain" for h in view.hits):
            self._crater_seen_at = self._odometer
            self.state = "climbing"
        if self._crater_seen_at is None:
            return self._out_of_bowl(view)
        pose, goal = view.pose, view.goal
        to_crater = wrap_deg(bearing_deg(goal.x - pose.x, goal.z - pose.z) - pose.heading)
        facing = abs(to_crater) <= CREST_FACING
        if facing or (self._on_spoke and rim.facing_station(goal, pose)):
            self._max_pitch = max(self._max_pitch, view.pitch_deg)
        walked = self._odometer - self._crater_seen_at
        # At its crest station by its own estimate the rover has climbed, whichever way it came up the rim.
        at_station = self._on_spoke and math.dist(goal.target, (pose.x, pose.z)) <= STATION_CLOSE_M
        climbed = self._max_pitch >= CLIMB_PITCH or at_station
        if self._backing:
            self._backing = False
            step = self.params.behaviour.min_move_size / 2
            if self._free_distance(0.0, view.hits) >= step:
                return MoveTo(0.0, step)
            self._backs = MAX_BACKS  # a rover right behind: stay, rather than squeeze into it
        if climbed and facing and view.pitch_deg <= -BOWL_PITCH and self._backs < MAX_BACKS:
            # Past the crest, on the bowl's wall: turn round and step back onto the crest (a move must be in
            # view), where the rover is at its goal and its radio sees over the rim (to a daisy chain's last relay).
            self._backs, self._backing = self._backs + 1, True
            return Rotate(180.0)
        near = self._near_station(view) or self._jam_outlasted(view)
        if climbed and facing and self._squeezing and self._crowded(view) and near:
            # Up the rim, facing the crater, long held up by rovers ahead that leave no step towards it: they
            # stand on the crest a body or two ahead (the crater's counterpart of a waypoint crowded in view).
            return Finish("reached")
        after = rim.crest_after_m(goal) if self._on_spoke else self.params.perception.perception_radius
        if not (climbed and (self._backs or walked >= after or at_station)):
            return None
        if view.pitch_deg > CREST_PITCH and not self._backs:
            return None
        if facing or self._crest_looks >= MAX_CREST_LOOKS:
            return Finish("reached")
        # Pitch tells the crest only when facing the crater; across or away from it, turn and look again
        # (a few times: on a crowded rim other rovers may keep turning it aside).
        self._crest_looks += 1
        return Rotate(round(to_crater, 3))

    def _near_station(self, view: View) -> bool:
        """Within two bodies of its crest station by its own estimate, or with none (the report's rule: anywhere
        on the crest): where rovers that leave it no step towards the crater stand on the crest ahead. They may
        be climbing too: on development seed 139 two bound for neighbouring stations stopped each other on the
        steep outer flank, 3-4 m below the crest. Farther off, a rover holds on and the jam rules part them; held
        up until it would give up (``MAX_CROWD_WAIT_S``), it observes from there after all: its estimate may be
        what is off (high noise, development seed 11)."""
        goal = view.goal
        return goal.station is None or math.dist(goal.target, (view.pose.x, view.pose.z)) <= near_station_m(self.params)

    def _out_of_bowl(self, view: View) -> Decision | None:
        """Near a crater goal without its terrain ever in view, the rover is in the bowl (it started there, or
        came in with no rim in its way): a crater's terrain shows where a ray enters it, so from inside no rim
        ever shows, and walking on for the goal it crossed it to and fro for ever. It walks out towards the
        lander instead, looking back at the goal after each long step; outside, the rim shows, and it climbs as
        from anywhere else. None: not in a bowl, or no way out to take (a station's spoke leads out anyway)."""
        goal, pose, radius = view.goal, view.pose, self.params.perception.perception_radius
        if self._bowl_looked_at is None:
            if goal.station is not None or math.hypot(goal.x - pose.x, goal.z - pose.z) > WAYPOINT_CLOSE * radius:
                return None
            self._bowl_looked_at = self._odometer
        if self._odometer - self._bowl_looked_at >= 0.9 * radius:
            self._bowl_looked_at = self._odometer
            return Rotate(round(wrap_deg(bearing_deg(goal.x - pose.x, goal.z - pose.z) - pose.heading), 3))
        return self._head_for(view.toward(0.0, 0.0), math.hypot(pose.x, pose.z), None)
