"""Rover behaviour: a pure state machine from what the rover senses to the next action.

It follows report section 6: head for the goal, scan the perception hits for a free direction (nearest
the goal first, right before left as the report turns right), walk to the edge of what is known to be
free, and rotate 60 degrees when everything in view is blocked; from the first such block on, aim along a
route planned on its own map of the obstacles seen (``planner``), which leads out of dead ends. For a
crater goal it climbs the rim with the gyroscope and stops on the crest only after having climbed and
walked at least the perception radius since first seeing crater terrain (the report's 7.2.2 fix for a
local optimum; a step over the crest is taken back off the bowl's wall), or along the spoke of its station
on the crest (``rim``), then photographs the crater once round. A waypoint is reached once close, or in
view with rovers crowding it (6.6); a relay spot once stood on; a station (the rover's own spot at a goal
the team shares, from the lander) once on it, in short, slow steps with close-quarters gaps.

Among rovers it follows the report's traffic rule (7.2.1: traffic to the right has right of way), waits
when only rovers block the way (they move on; rocks do not), stops for rovers on a collision course,
squeezes by, slowly and with small gaps, when a jam lasts, steps aside when it lasts longer, and gives up only
after a long time (``crowd``). A rover
walking on without getting closer to its goal (pacing along a wall) switches to routing, then gives up.

No I/O here: the runtime feeds a ``View`` and sends what ``decide`` returns, so this is tested with scripted
sensor data and no router. The interface every behaviour shares is in ``rover_agent.decisions``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import ClassVar

from rover_agent import free_space, rim
from rover_agent.crossing import CrossingWatch
from rover_agent.crowd import CrowdRules
from rover_agent.decisions import (
    BaseBehaviour,
    Decision,
    Finish,
    Goal,
    Hit,
    Hold,
    MoveTo,
    Rotate,
    TakePhoto,
    View,
)
from rover_agent.free_space import OBSTACLE_MARGIN, ROVER_GAP_CLOSE
from rover_agent.planner import OccupancyGrid, next_waypoint
from rover_agent.sunlight import CHARGE, SunSeeker
from rover_agent.tuning import (
    BOWL_PITCH,
    CHARGE_CHECK_S,
    CLIMB_PITCH,
    CREST_FACING,
    CREST_PITCH,
    MAX_BACKS,
    MAX_BLOCKED_ROTATIONS,
    MAX_CREST_LOOKS,
    NEAR_CREST_PITCH,
    NO_PROGRESS_ROUTE_M,
    NO_PROGRESS_WALK_M,
    RELAY_CLOSE_M,
    RIGHT_OF_WAY_DEG,
    STATION_CLOSE_M,
    WAYPOINT_CLOSE,
    WAYPOINT_IN_VIEW,
)
from schemas.frames import bearing_deg, wrap_deg
from schemas.params import RoverParams

BLOCKED_WHY = f"turned {MAX_BLOCKED_ROTATIONS} times in a row without finding a free way"

@dataclass
class DefaultBehaviour(CrowdRules, BaseBehaviour):
    """The report's single- and multi-rover behaviour with crater climbing."""

    rover_id: int
    params: RoverParams
    state: str = "waiting"
    _crater_seen_at: float | None = None  # odometer reading when crater terrain was first seen
    _odometer: float = 0.0
    _max_pitch: float = -90.0
    _blocked_rotations: int = 0
    _crowd_since: float | None = None  # when the rover last stopped making progress among rovers
    _crowd_waits: int = 0
    _parking: bool = False  # walking the last metres to this rover's station at a shared waypoint
    _crowded_since: float | None = None  # when rovers first stood between it and its station, the goal in view
    _give_way_tries: int = 0  # steps aside (or looks for room to) in this jam
    _giving_way: bool = False  # the move under way is a step aside
    _jam_from: tuple[tuple[float, float], float, tuple[float, float]] | None = None  # target, metres to it, place
    _turned_aside: bool = False  # turned round to step aside: step before turning back to the goal
    _follow_waits: int = 0  # waits in a row for a rover ahead to walk on (``_follow``)
    _now: float = 0.0  # time of the latest view
    _closest: tuple[float, float] = (math.inf, 0.0)  # (nearest the goal has been, odometer then)
    _crest_looks: int = 0
    _backs: int = 0  # steps back out of the crater's bowl onto the crest
    _on_spoke: bool = False  # at the foot of its crest station's spoke, or past it (``rim``)
    _backing: bool = False  # turned away from the bowl, to step out of it next
    _bowl_looked_at: float | None = None  # in a crater's bowl, walking out: odometer at the last look back
    _rejected: list[float] = field(default_factory=list)
    _hold_until: float = 0.0
    _photos_taken: int = 0
    _photo_due: bool = True
    _map: OccupancyGrid = field(default_factory=OccupancyGrid)
    _routing: bool = False
    _sun: SunSeeker | None = None
    _state_before_charging: str = "migration"
    _crossing: CrossingWatch | None = None  # rovers on a collision course, scan to scan during a move

    name = "default"
    uses_sunlight: ClassVar[bool] = True
    """With power sensors (a world with a sun): keep out of shadow when low and charge in sunlight."""

    # ---- events from the runtime ----

    def start_goal(self, goal: Goal) -> None:
        self.state = "migration"
        self._photos_taken, self._photo_due = 0, True
        self._crater_seen_at, self._max_pitch, self._blocked_rotations = None, -90.0, 0
        self._crowd_since, self._crowd_waits, self._parking, self._crowded_since = None, 0, False, None
        self._give_way_tries, self._giving_way, self._turned_aside, self._follow_waits = 0, False, False, 0
        self._jam_from = None
        self._closest = (math.inf, self._odometer)
        self._crest_looks, self._backs, self._backing, self._on_spoke = 0, 0, False, False
        self._bowl_looked_at = None
        self._rejected.clear()

    def moved(self, distance: float) -> None:
        self._odometer += distance
        if self._crossing is not None:
            self._crossing.reset()
        self._turned_aside, self._follow_waits = False, 0
        if self._giving_way:  # a step aside: no progress
            self._stepped_aside()
        elif distance >= self.params.behaviour.min_move_size / 2:  # real progress, not a move cancelled at once
            self._blocked_rotations = 0
            self._rejected.clear()

    def rejected(self, relative_angle: float) -> None:
        """The world refused a move in this direction: do not try it again from here."""
        self._rejected.append(relative_angle)
        self._giving_way = False

    def cancelled(self, now: float) -> None:
        """A move was cancelled because another rover came close: give way for a moment."""
        if self._sun is not None and self._sun.turned_back:  # cancelled on entering shadow: no rover to wait for
            self._sun.turned_back = False
            return
        self._hold_until = max(self._hold_until, now + self._wait_time())  # a step aside's longer wait stands
        if self._crowd_since is None:  # the jam begins where the move stopped: the next decision says how far
            self._crowd_since, self._jam_from = now, None

    # ---- decisions ----

    def should_cancel(self, view: View) -> bool:
        """During a move: stop for a rover close ahead that has right of way (report 6.2.2 and 7.2.1).

        Traffic ahead or to the right has right of way; a rover ahead-left gives way to this one, which stops
        for it only when a collision is close, or when its motion since the last scan says so (``crossing``).
        """
        self._now = view.time
        b = self.params.behaviour
        self._crossing = self._crossing or CrossingWatch.of(self.params)
        if self._crossing.danger(view.time, view.hits):
            return True
        imminent = 2 * b.rover_radius + ROVER_GAP_CLOSE
        danger = imminent if self._close_quarters else b.collision_danger_dist
        if self._sun is not None and self.uses_sunlight and self._sun.should_turn_back(view):
            return True
        return any(h.kind == "rover" and (
            (abs(h.angle_deg) < 45 and h.distance_m < (danger if h.angle_deg >= -RIGHT_OF_WAY_DEG else imminent))
            or (abs(h.angle_deg) < 90 and h.distance_m < imminent))  # closing in from the side: a crossing course
            for h in view.hits)

    def decide(self, view: View) -> Decision:
        self._now = view.time
        if view.time < self._hold_until:
            return Hold(self._hold_until)
        power = self._mind_power(view)
        if power is not None:
            return power
        if self.state == "observing":
            return self._observe(view.goal)
        goal, pose = view.goal, view.pose
        distance = math.hypot(goal.target[0] - pose.x, goal.target[1] - pose.z)
        self._mind_jam(view, distance)
        if goal.kind == "waypoint" and self._waypoint_reached(view, distance):
            return Finish("reached")
        if goal.kind == "relay" and distance <= RELAY_CLOSE_M:
            return Finish("relay")
        if goal.kind == "crater":
            decision = self._to_spoke(view) or self._climb(view)
            if decision == Finish("reached"):
                self.state = "observing"
                return self._observe(goal)
            if decision:
                return decision
        self._parking = goal.station is not None and distance <= self.params.perception.perception_radius
        if self._pacing(distance, NO_PROGRESS_WALK_M):
            return Finish("stuck", f"walked {NO_PROGRESS_WALK_M:.0f} m without getting closer to the goal")
        if not self._routing and self._pacing(distance, NO_PROGRESS_ROUTE_M):
            self._routing = True
        return self._head_for(view, distance, self._short_step(view))

    def _mind_power(self, view: View) -> Decision | None:
        """Charge in sunlight, or walk back to it, when the charge is low (``sunlight``); None: carry on."""
        if not self.uses_sunlight or view.battery is None:
            return None
        if self._sun is None:
            p = self.params.power
            self._sun = SunSeeker(p.low_charge_fraction, p.recharge_to_fraction)
        advice = self._sun.advise(view)
        if advice is None:
            if self.state == "charging":
                self.state = self._state_before_charging
            return None
        if advice == CHARGE:
            if self.state != "charging":
                self._state_before_charging, self.state = self.state, "charging"
            return Hold(view.time + CHARGE_CHECK_S)
        lx, lz = advice
        return self._head_for(view.toward(lx, lz), math.hypot(lx - view.pose.x, lz - view.pose.z), None)

    def _pacing(self, distance: float, limit_m: float) -> bool:
        """Walked ``limit_m`` without getting closer (climbing a rim is judged by the climb rules instead)."""
        if distance < self._closest[0] - 0.5:
            self._closest = (distance, self._odometer)
        return self.state != "climbing" and self._odometer - self._closest[1] > limit_m

    @property
    def _close_quarters(self) -> bool:
        """On the rim, parking at a station or long stuck in a jam of rovers: short steps, small gaps, stop
        only for imminent contact."""
        return self.state == "climbing" or self._parking or self._squeezing

    def _short_step(self, view: View) -> float | None:
        """Short steps on the rim, shorter still near the top, so the rover stops on the crest, not past it;
        short steps too when parking among rovers standing at their stations."""
        step = self.params.behaviour.min_move_size
        if self._parking or self._squeezing:
            return step
        if self.state != "climbing":
            return None
        near_top = self._max_pitch >= CLIMB_PITCH and view.pitch_deg < NEAR_CREST_PITCH
        return step / 2 if near_top else step

    def _waypoint_reached(self, view: View, distance: float) -> bool:
        """``distance`` is to the rover's station if it has one, else to the waypoint."""
        radius = self.params.perception.perception_radius
        pose, goal = view.pose, view.goal
        in_view = math.hypot(goal.x - pose.x, goal.z - pose.z) <= WAYPOINT_IN_VIEW * radius
        if goal.station is None:
            return distance <= WAYPOINT_CLOSE * radius or (in_view and self._crowded(view))
        return distance <= STATION_CLOSE_M or (in_view and self._crowd_stood(view))

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
        if climbed and facing and self._squeezing and self._crowded(view):
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

    def _route_point(self, view: View) -> tuple[float, float] | None:
        """Once routing: the next corner of the shortest route to the goal round every obstacle seen so far, so
        dead ends it has seen (a maze's) are left behind rather than walked into again (report 6.1.2 steers
        only until the rover is first blocked everywhere in view)."""
        if not self._routing:
            return None
        p = self.params
        clearance = p.behaviour.rover_radius + OBSTACLE_MARGIN + self._map.cell_m / 2
        return next_waypoint(self._map, view.pose, view.goal.target, clearance,
                             0.9 * p.perception.perception_radius)

    def _head_for(self, view: View, distance: float, step: float | None) -> Decision:
        p = self.params
        pose, goal = view.pose, view.goal
        free = free_space.free_rays(view.hits, p.perception)  # map what is in view: obstacles hit, ground free
        self._map.observe(pose, view.hits, p.perception.perception_radius, free)
        tx, tz = self._route_point(view) or goal.target
        to_goal = wrap_deg(bearing_deg(tx - pose.x, tz - pose.z) - pose.heading)
        window = min(p.perception.field_of_view_degrees / 2 - 5, p.behaviour.scanner_field_of_view / 2)
        if self._turned_aside and (step := self._step_aside(view, to_goal, window)) is not None:
            return step
        if abs(to_goal) > window:
            if self._crowd_since is None:  # turning without getting anywhere counts toward giving up...
                self._blocked_rotations += 1  # ...except when waiting for rovers, which has its own limit
            if self._blocked_rotations > MAX_BLOCKED_ROTATIONS:
                return Finish("stuck", BLOCKED_WHY)
            return Rotate(round(to_goal, 3))
        on_route = (tx, tz) != goal.target  # a corner of the route: walk to it, not past it
        want = min(0.9 * p.perception.perception_radius, step or math.inf,
                   math.hypot(tx - pose.x, tz - pose.z) if on_route or goal.kind != "crater" else math.inf)
        for angle in self._candidates(to_goal, window):
            free = self._free_distance(angle, view.hits)
            if free >= min(want, p.behaviour.min_move_size):
                length = min(free, want)
                if (wait := self._follow(view, angle, length, want)) is not None:
                    return wait
                rad = math.radians(angle)
                # close-quarters stops come at a body's gap: too late at full speed (``free_space.rover_near``)
                slow = self._close_quarters and free_space.rover_near(view.hits, p.behaviour, length)
                return MoveTo(round(length * math.sin(rad), 4), round(length * math.cos(rad), 4), slow)
        if self._blocked_by_rovers(view, to_goal, window, want):
            return self._wait_in_crowd(view, to_goal, window)
        self._blocked_rotations += 1
        if self._blocked_rotations > MAX_BLOCKED_ROTATIONS:
            return Finish("stuck", BLOCKED_WHY)
        self._rejected.clear()
        self._routing = True
        return Rotate(p.behaviour.rotate_action)

    def _candidates(self, to_goal: float, window: float) -> list[float]:
        return free_space.candidates(to_goal, window, self.params.behaviour.scan_angle, self._rejected)

    def _free_distance(self, angle: float, hits: tuple[Hit, ...]) -> float:
        gap = ROVER_GAP_CLOSE if self._close_quarters else self.params.behaviour.extra_distance_between_rovers
        return free_space.free_distance(angle, hits, self.params, gap)
