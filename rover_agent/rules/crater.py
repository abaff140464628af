"""At a crater goal: to the foot of the station's spoke, up the rim by pitch, off the bowl's wall, out of a bowl
the rover found itself in, and the photographs once round (report 6.4, 7.2.2 and 10.5.3).

A part of the default behaviour (``rover_agent.behaviour``), which asks it at a crater goal and hands it its walking
(``walking.Walking``) and its crowd rules. Pure logic, no I/O.
"""

from __future__ import annotations

import math

from rover_agent.decisions import Decision, Finish, Goal, MoveTo, Rotate, TakePhoto, View
from rover_agent.rules import rim
from rover_agent.rules.crowd import CrowdRules
from rover_agent.rules.tuning import (
    BOWL_PITCH,
    CLIMB_PITCH,
    CREST_FACING,
    CREST_PITCH,
    LEVEL_MARGIN_M,
    MAX_BACKS,
    MAX_CREST_LOOKS,
    NEAR_CREST_PITCH,
    NO_PROGRESS_ROUTE_M,
    STATION_CLOSE_M,
    WAYPOINT_CLOSE,
)
from rover_agent.rules.walking import Walking
from schemas.frames import bearing_deg, wrap_deg
from schemas.params import RoverParams


def near_station_m(params: RoverParams) -> float:
    """Two bodies: how near its crest station a rover held up on the rim must be to take the crest as a body or
    two ahead (``CraterRules.climb``)."""
    return 4 * params.behaviour.rover_radius


class CraterRules:
    def __init__(self, params: RoverParams) -> None:
        self.params = params
        self.seen_at: float | None = None
        """Odometer reading when crater terrain was first seen."""
        self.max_pitch = -90.0
        self.crest_looks = 0
        self.backs = 0
        """Steps back out of the crater's bowl onto the crest."""
        self.on_spoke = False
        """At the foot of its crest station's spoke, or past it (``rim``)."""
        self.level = False
        """Taking a long step on level ground below its station (``level_step``): not yet at close quarters."""
        self.onwards = False
        """At its crest station by its own estimate, still below the crest by pitch: climbing on (``_on_up``)."""
        self.crest_after: float | None = None
        """Climbing along its spoke: metres to walk before the crest can be told by pitch (``rim.crest_after_m``)."""
        self.backing = False
        """Turned away from the bowl, to step out of it next."""
        self.bowl_looked_at: float | None = None
        """In a crater's bowl, walking out: odometer at the last look back."""
        self.photos_taken = 0
        self.photo_due = True

    def start(self) -> None:
        """A new goal: nothing climbed, nothing photographed."""
        self.seen_at, self.max_pitch, self.crest_looks, self.backs = None, -90.0, 0, 0
        self.on_spoke, self.crest_after, self.backing, self.bowl_looked_at = False, None, False, None
        self.level, self.onwards = False, False
        self.photos_taken, self.photo_due = 0, True

    def near_top(self, pitch_deg: float) -> bool:
        """Up the rim and levelling off: the crest is close."""
        return self.max_pitch >= CLIMB_PITCH and pitch_deg < NEAR_CREST_PITCH

    def level_step(self, view: View) -> float | None:
        """On its spoke, still on level ground (no climb felt yet): a step up to ``LEVEL_MARGIN_M`` and two of its
        estimate's errors short of its station, where short steps would only cost time; None where short steps
        are due (on the slope, or with no station to measure by). The crest is the station's, so such a step
        cannot carry the rover over it unless its estimate is off by more than the margin."""
        goal, pose = view.goal, view.pose
        self.level = False
        if not self.on_spoke or goal.station is None or max(self.max_pitch, view.pitch_deg) >= CLIMB_PITCH:
            return None
        gap = math.dist(goal.target, (pose.x, pose.z)) - LEVEL_MARGIN_M - 2 * view.position_std_m
        self.level = gap > self.params.behaviour.min_move_size
        return gap if self.level else None

    def observe(self, goal: Goal) -> Decision:
        """On the rim: a photo, a turn of ``photo_step_deg``, a photo... once round (report 10.5.3)."""
        step = self.params.behaviour.photo_step_deg
        if self.photos_taken >= max(1, round(360.0 / step)):
            return Finish("reached")
        if self.photo_due:
            self.photo_due = False
            self.photos_taken += 1
            # The label names the photo's file at the lander and its caption on the page: a person reads it, so
            # goals count from 1 there as in the terminal (goal_index, the wire's, stays 0-based beside it).
            return TakePhoto(f"goal{goal.index + 1}_{(self.photos_taken - 1) * step:05.1f}deg")
        self.photo_due = True
        return Rotate(step)

    def to_spoke(self, view: View, walking: Walking) -> Decision | None:
        """With a station on the crest: walk to the foot of its spoke first (``rim``); None from there on, from
        where it joins the spoke on the way, or where the way to the foot stops getting shorter (the climb then
        starts where the rover stands)."""
        goal, pose = view.goal, view.pose
        if goal.station is None or self.on_spoke:
            return None
        fx, fz = rim.foot(goal)
        gap = math.hypot(fx - pose.x, fz - pose.z)
        joined = rim.joins_spoke(goal, pose) if gap > STATION_CLOSE_M else None
        if joined is None and gap > STATION_CLOSE_M and not walking.pacing(gap, NO_PROGRESS_ROUTE_M):
            return walking.head_for(view.toward(fx, fz), gap, None)
        self.on_spoke, self.crest_after = True, rim.crest_after_m(goal, joined)
        walking.climbing(from_spoke=True)
        self.seen_at = walking.odometer
        return None

    def climb(self, view: View, walking: Walking, crowd: CrowdRules) -> Decision | None:
        if self.seen_at is None and any(h.kind == "crater_terrain" for h in view.hits):
            self.seen_at = walking.odometer
            walking.climbing(from_spoke=False)
        if self.seen_at is None:
            return self._out_of_bowl(view, walking)
        pose, goal = view.pose, view.goal
        to_crater = wrap_deg(bearing_deg(goal.x - pose.x, goal.z - pose.z) - pose.heading)
        facing = abs(to_crater) <= CREST_FACING
        if facing or (self.on_spoke and rim.facing_station(goal, pose)):
            self.max_pitch = max(self.max_pitch, view.pitch_deg)
        walked = walking.odometer - self.seen_at
        # At its crest station by its own estimate the rover has climbed, whichever way it came up the rim.
        at_station = self.on_spoke and math.dist(goal.target, (pose.x, pose.z)) <= STATION_CLOSE_M
        climbed = self.max_pitch >= CLIMB_PITCH or at_station
        if self.backing:
            self.backing = False
            step = self.params.behaviour.min_move_size / 2
            if walking.free_distance(0.0, view.hits) >= step:
                return MoveTo(0.0, step)
            self.backs = MAX_BACKS  # a rover right behind: stay, rather than squeeze into it
        if self.backs and abs(to_crater) >= 180.0 - CREST_FACING and (out := self._out_of_wall(view, walking)):
            return out
        if climbed and facing and view.pitch_deg <= -BOWL_PITCH and self.backs < MAX_BACKS:
            # Past the crest, on the bowl's wall: turn round and step back onto the crest (a move must be in
            # view), where the rover is at its goal and its radio sees over the rim (to a daisy chain's last relay).
            self.backs, self.backing = self.backs + 1, True
            return Rotate(180.0)
        near = self._near_station(view) or crowd.outlasted(view)
        if climbed and facing and crowd.squeezing and crowd.crowded(view, walking) and near:
            # Up the rim, facing the crater, long held up by rovers ahead that leave no step towards it: they
            # stand on the crest a body or two ahead (the crater's counterpart of a waypoint crowded in view).
            return Finish("reached")
        after = self.crest_after if self.on_spoke else self.params.perception.perception_radius
        if not (climbed and (self.backs or walked >= after or at_station)):
            return None
        if view.pitch_deg > CREST_PITCH and not self.backs:
            self.onwards = self.onwards or at_station
            return self._on_up(view, walking, facing, to_crater) if self.onwards else None
        if facing or self.crest_looks >= MAX_CREST_LOOKS:
            return Finish("reached")
        # Pitch tells the crest only when facing the crater; across or away from it, turn and look again
        # (a few times: on a crowded rim other rovers may keep turning it aside).
        self.crest_looks += 1
        return Rotate(round(to_crater, 3))

    def _out_of_wall(self, view: View, walking: Walking) -> Decision | None:
        """Stepped back off the bowl's wall, still facing out: level, it stands on the crest and observes from
        there (the photographs go once round from any heading); still rising outwards, it is on the wall yet and
        steps out again (up to ``MAX_BACKS`` steps in all). Turning to the crater only to read the pitch, and back
        again to step out, cost some four seconds a time. None: past the crest, down the outer slope (it turns to
        the crater), or no step left to take."""
        if abs(view.pitch_deg) <= CREST_PITCH:
            return Finish("reached")
        step = self.params.behaviour.min_move_size / 2
        if view.pitch_deg > CREST_PITCH and self.backs < MAX_BACKS and walking.free_distance(0.0, view.hits) >= step:
            self.backs += 1
            return MoveTo(0.0, step)
        return None

    def _on_up(self, view: View, walking: Walking, facing: bool, to_crater: float) -> Decision | None:
        """At its station by its own estimate, with pitch not level: facing the crater, pitch says the crest is
        still ahead (the estimate is a metre or two off), so up it goes, towards the crater, in half steps; not
        facing it, it turns to it to read the pitch. Heading back for where the estimate puts the station instead
        turned the rover round, and it turned to and fro between the crater (pitch up) and the station (behind it)
        until its looks ran out, and observed from below the crest. None once it has climbed on as far as its
        estimate's error allows (``STATION_CLOSE_M`` and three 1-sigma errors past the station), it observes from
        where it stands; with no step free ahead (rovers on the crest), the usual rules hold it (None)."""
        pose, goal = view.pose, view.goal
        if not facing and self.crest_looks < MAX_CREST_LOOKS:
            self.crest_looks += 1
            return Rotate(round(to_crater, 3))
        step = self.params.behaviour.min_move_size / 2
        beyond = math.dist(goal.target, (pose.x, pose.z)) > STATION_CLOSE_M + 3 * view.position_std_m
        if not facing or beyond:
            return Finish("reached")
        return MoveTo(0.0, step) if walking.free_distance(0.0, view.hits) >= step else None

    def _near_station(self, view: View) -> bool:
        """Within two bodies of its crest station by its own estimate, or with none (the report's rule: anywhere
        on the crest): where rovers that leave it no step towards the crater stand on the crest ahead. They may
        be climbing too: on development seed 139 two bound for neighbouring stations stopped each other on the
        steep outer flank, 3-4 m below the crest. Farther off, a rover holds on and the jam rules part them; held
        up until it would give up (``MAX_CROWD_WAIT_S``), it observes from there after all: its estimate may be
        what is off (high noise, development seed 11)."""
        goal = view.goal
        return goal.station is None or math.dist(goal.target, (view.pose.x, view.pose.z)) <= near_station_m(self.params)

    def _out_of_bowl(self, view: View, walking: Walking) -> Decision | None:
        """Near a crater goal without its terrain ever in view, the rover is in the bowl (it started there, or
        came in with no rim in its way): a crater's terrain shows where a ray enters it, so from inside no rim
        ever shows, and walking on for the goal it crossed it to and fro for ever. It walks out towards the
        lander instead, looking back at the goal after each long step; outside, the rim shows, and it climbs as
        from anywhere else. None: not in a bowl, or no way out to take (a station's spoke leads out anyway)."""
        goal, pose, radius = view.goal, view.pose, self.params.perception.perception_radius
        if self.bowl_looked_at is None:
            if goal.station is not None or math.hypot(goal.x - pose.x, goal.z - pose.z) > WAYPOINT_CLOSE * radius:
                return None
            self.bowl_looked_at = walking.odometer
        if walking.odometer - self.bowl_looked_at >= 0.9 * radius:
            self.bowl_looked_at = walking.odometer
            return Rotate(round(wrap_deg(bearing_deg(goal.x - pose.x, goal.z - pose.z) - pose.heading), 3))
        return walking.head_for(view.toward(0.0, 0.0), math.hypot(pose.x, pose.z), None)
