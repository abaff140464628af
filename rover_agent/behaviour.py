"""Rover behaviour: a pure state machine from what the rover senses to the next action.

It follows report section 6: head for the goal, scan the perception hits for a free direction (nearest
the goal first, right before left as the report turns right), walk to the edge of what is known to be
free, and rotate 60 degrees when everything in view is blocked; from the first such block on, aim along a
route planned on its own map of the obstacles seen (``rules.planner``), which leads out of dead ends. For a
crater goal it climbs the rim with the gyroscope and stops on the crest only after having climbed and
walked at least the perception radius since first seeing crater terrain (the report's 7.2.2 fix for a
local optimum; a step over the crest is taken back off the bowl's wall), or along the spoke of its station
on the crest (``rules.rim``), then photographs the crater once round (``rules.crater``). A waypoint is reached
once close, or in view with rovers crowding it (6.6); a relay spot once stood on; a station (the rover's own spot
at a goal the team shares, from the lander) once on it, in short, slow steps with close-quarters gaps.

Among rovers it follows the report's traffic rule (7.2.1: traffic to the right has right of way), waits
when only rovers block the way (they move on; rocks do not), stops for rovers on a collision course,
squeezes by, slowly and with small gaps, when a jam lasts, steps aside when it lasts longer, and gives up only
after a long time (``rules.crowd``). A rover walking on without getting closer to its goal (pacing along a wall)
switches to routing, then gives up.

``DefaultBehaviour`` walks; its crater rules and crowd rules are parts with their own state, which it asks on the
way and hands itself to as their view of the walking (``rules.walking``). No I/O here: the agent feeds a ``View``
and sends what ``decide`` returns, so this is tested with scripted sensor data and no router. The interface every
behaviour shares is in ``rover_agent.decisions``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import ClassVar

from rover_agent.decisions import BaseBehaviour, Decision, Finish, Goal, Hit, Hold, MoveTo, Rotate, TakePhoto, View
from rover_agent.rules import free_space
from rover_agent.rules.crater import CraterRules
from rover_agent.rules.crossing import CrossingWatch
from rover_agent.rules.crowd import CrowdRules
from rover_agent.rules.free_space import OBSTACLE_MARGIN, ROVER_GAP_CLOSE
from rover_agent.rules.occupancy import STATIC_KINDS, OccupancyGrid
from rover_agent.rules.planner import next_waypoint
from rover_agent.rules.sunlight import CHARGE, SunSeeker
from rover_agent.rules.tuning import (
    CHARGE_CHECK_S,
    MAX_BLOCKED_ROTATIONS,
    NO_PROGRESS_ROUTE_M,
    NO_PROGRESS_WALK_M,
    RELAY_CLOSE_M,
    RIGHT_OF_WAY_DEG,
    SPOT_HELD_M,
    STATION_CLOSE_M,
    WAYPOINT_CLOSE,
    WAYPOINT_IN_VIEW,
)
from schemas.frames import bearing_deg, wrap_deg
from schemas.params import RoverParams

__all__ = ["BaseBehaviour", "Decision", "DefaultBehaviour", "Finish", "Goal", "Hit", "Hold", "MoveTo", "Rotate",
           "TakePhoto", "View"]
"""The default behaviour, and the interface every behaviour shares (``rover_agent.decisions``), importable from
here too."""

STILL_KINDS = STATIC_KINDS - {"terrain"}
"""What a rover steps off when nearer than a move keeps (``_step_off``): rocks, walls, the lander. Not steep
terrain, which a rover on rough ground is often near and walks along."""
BLOCKED_WHY = f"turned {MAX_BLOCKED_ROTATIONS} times in a row without finding a free way"


class DefaultBehaviour(BaseBehaviour):
    """The report's single- and multi-rover behaviour with crater climbing."""

    name = "default"
    uses_sunlight: ClassVar[bool] = True
    """With power sensors (a world with a sun): keep out of shadow when low and charge in sunlight."""

    def __init__(self, rover_id: int, params: RoverParams) -> None:
        super().__init__(rover_id, params)
        self.crater = CraterRules(params)
        self.crowd = CrowdRules(rover_id, params)
        self.odometer = 0.0
        self._closest = (math.inf, 0.0)  # (nearest the goal has been, odometer then)
        self._blocked_rotations = 0
        self._parking = False  # walking the last metres to this rover's station at a shared waypoint
        self._refused: list[float] = []  # directions the world refused a move in, from where the rover stands
        self._map = OccupancyGrid()
        self._routing = False
        self._stepping_off = False  # turned its back to a wall it stood too near: step away next (``_step_off``)
        self._sun: SunSeeker | None = None
        self._state_before_charging = "migration"
        self._crossing: CrossingWatch | None = None  # rovers on a collision course, scan to scan during a move
        self._blocked_ahead = False  # the move under way was cancelled short of a rock, wall or the lander

    # ---- events from the agent ----

    def start_goal(self, goal: Goal) -> None:
        self.state = "migration"
        self.crater.start()
        self.crowd.start()
        self._blocked_rotations, self._parking = 0, False
        self._closest = (math.inf, self.odometer)
        self._refused.clear()

    def moved(self, distance: float) -> None:
        self.odometer += distance
        if self._crossing is not None:
            self._crossing.reset()
        self._stepping_off = False
        if self.crowd.moved(distance):  # real progress, not a step aside nor a move cancelled at once
            self._blocked_rotations = 0
            self._refused.clear()

    def rejected(self, relative_angle: float) -> None:
        """The world refused a move in this direction: do not try it again from here."""
        self._refused.append(relative_angle)
        self.crowd.refused()

    def cancelled(self, now: float) -> None:
        """A move was cancelled because another rover came close: give way for a moment."""
        if self._sun is not None and self._sun.turned_back:  # cancelled on entering shadow: no rover to wait for
            self._sun.turned_back = False
            return
        if self._blocked_ahead:  # stopped short of a thing that does not move: no rover to wait for
            self._blocked_ahead = False
            return
        self.crowd.cancelled(now)

    # ---- decisions ----

    def should_cancel(self, view: View) -> bool:
        """During a move: stop for a rover close ahead that has right of way (report 6.2.2 and 7.2.1), or short
        of a rock, a wall or the lander come into view across the rest of the way (``View.remaining_m``).

        Traffic ahead or to the right has right of way; a rover ahead-left gives way to this one, which stops
        for it only when a collision is close, or when its motion since the last scan says so (``crossing``).
        """
        self.crowd.now = view.time
        b = self.params.behaviour
        if free_space.in_the_way(view.hits, STILL_KINDS, b.rover_radius, view.remaining_m):
            self._blocked_ahead = True
            return True
        self._crossing = self._crossing or CrossingWatch.of(self.params)
        if self._crossing.danger(view.time, view.hits):
            return True
        imminent = 2 * b.rover_radius + ROVER_GAP_CLOSE
        danger = imminent if self.close_quarters else b.collision_danger_dist
        if self._sun is not None and self.uses_sunlight and self._sun.should_turn_back(view):
            return True
        return any(h.kind == "rover" and (
            (abs(h.angle_deg) < 45 and h.distance_m < (danger if h.angle_deg >= -RIGHT_OF_WAY_DEG else imminent))
            or (abs(h.angle_deg) < 90 and h.distance_m < imminent))  # closing in from the side: a crossing course
            for h in view.hits)

    def decide(self, view: View) -> Decision:
        self.crowd.now = view.time
        self._blocked_ahead = False  # a cancel sent too late for a move that ended anyway
        if (hold := self.crowd.holding(view.time)) is not None:
            return hold
        power = self._mind_power(view)
        if power is not None:
            return power
        if self.state == "observing":
            return self.crater.observe(view.goal)
        goal, pose = view.goal, view.pose
        distance = math.hypot(goal.target[0] - pose.x, goal.target[1] - pose.z)
        self.crowd.mind_jam(view, distance)
        if goal.kind == "waypoint" and self._waypoint_reached(view, distance):
            return Finish("reached")
        if goal.kind == "relay" and (distance <= RELAY_CLOSE_M or self._spot_taken(distance)):
            return Finish("relay")
        if goal.kind == "crater":
            decision = self.crater.to_spoke(view, self) or self.crater.climb(view, self, self.crowd)
            if decision == Finish("reached"):
                self.state = "observing"
                return self.crater.observe(goal)
            if decision:
                return decision
        self._parking = goal.station is not None and distance <= self.params.perception.perception_radius
        if self.pacing(distance, NO_PROGRESS_WALK_M):
            return Finish("stuck", f"walked {NO_PROGRESS_WALK_M:.0f} m without getting closer to the goal")
        if not self._routing and self.pacing(distance, NO_PROGRESS_ROUTE_M):
            self._routing = True
        return self.head_for(view, distance, self._short_step(view))

    def _mind_power(self, view: View) -> Decision | None:
        """Charge in sunlight, or walk back to it, when the charge is low (``rules.sunlight``); None: carry on."""
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
        return self.head_for(view.toward(lx, lz), math.hypot(lx - view.pose.x, lz - view.pose.z), None)

    def pacing(self, distance: float, limit_m: float) -> bool:
        """Walked ``limit_m`` without getting closer (climbing a rim is judged by the climb rules instead)."""
        if distance < self._closest[0] - 0.5:
            self._closest = (distance, self.odometer)
        return self.state != "climbing" and self.odometer - self._closest[1] > limit_m

    def climbing(self, from_spoke: bool) -> None:
        """Up a crater's rim from here (``rules.crater``)."""
        if from_spoke:
            self._routing, self._closest = False, (math.inf, self.odometer)
        self.state = "climbing"

    @property
    def close_quarters(self) -> bool:
        """On the rim (not on the level ground below a crest station, ``CraterRules.level_step``), parking at a
        station or long stuck in a jam of rovers: short steps, small gaps, stop only for imminent contact."""
        return (self.state == "climbing" and not self.crater.level) or self._parking or self.crowd.squeezing

    def _short_step(self, view: View) -> float | None:
        """Short steps on the rim, shorter still near the top, so the rover stops on the crest, not past it (but long
        ones on the level ground below a crest station, ``CraterRules.level_step``); short steps too when parking
        among rovers standing at their stations."""
        step = self.params.behaviour.min_move_size
        if self.state == "climbing" and (level := self.crater.level_step(view)) is not None:
            return step if self.crowd.squeezing else level
        if self._parking or self.crowd.squeezing:
            return step
        if self.state != "climbing":
            return None
        return step / 2 if self.crater.near_top(view.pitch_deg) else step

    def _waypoint_reached(self, view: View, distance: float) -> bool:
        """``distance`` is to the rover's station if it has one, else to the waypoint."""
        radius = self.params.perception.perception_radius
        pose, goal = view.pose, view.goal
        in_view = math.hypot(goal.x - pose.x, goal.z - pose.z) <= WAYPOINT_IN_VIEW * radius
        if goal.station is None:
            return distance <= WAYPOINT_CLOSE * radius or (in_view and self.crowd.crowded(view, self))
        return (distance <= STATION_CLOSE_M or (in_view and self.crowd.crowd_stood(view, self))
                or self._spot_taken(distance))

    def _spot_taken(self, distance: float) -> bool:
        """Near its spot (a relay's, a station) and circling it without getting nearer: hold here (``SPOT_HELD_M``)."""
        return distance <= SPOT_HELD_M and self.pacing(distance, NO_PROGRESS_ROUTE_M)

    def _route_point(self, view: View) -> tuple[float, float] | None:
        """Once routing: the next corner of the shortest route to the goal round every obstacle seen so far, so
        dead ends it has seen (a maze's) are left behind rather than walked into again (report 6.1.2 steers
        only until the rover is first blocked everywhere in view)."""
        if not self._routing:
            return None
        p = self.params
        clearance = p.behaviour.rover_radius + OBSTACLE_MARGIN + self._map.cell_m / 2
        return next_waypoint(self._map, view.pose, view.goal.target, clearance,
                             0.9 * p.perception.perception_radius,
                             avoid=self.crowd.rovers_in_way(view, clearance, self._map))

    def head_for(self, view: View, distance: float, step: float | None) -> Decision:
        p = self.params
        pose, goal = view.pose, view.goal
        free = free_space.free_rays(view.hits, p.perception)  # map what is in view: obstacles hit, ground free
        self._map.observe(pose, view.hits, p.perception.perception_radius, free)
        window = min(p.perception.field_of_view_degrees / 2 - 5, p.behaviour.scanner_field_of_view / 2)
        if (off := self._step_off(view, window)) is not None:
            return off
        tx, tz = self._route_point(view) or goal.target
        to_goal = wrap_deg(bearing_deg(tx - pose.x, tz - pose.z) - pose.heading)
        if self.crowd.turned_aside and (step := self.crowd.step_aside(view, to_goal, window, self)) is not None:
            return step
        if abs(to_goal) > window:
            if not self.crowd.jammed:  # turning without getting anywhere counts toward giving up...
                self._blocked_rotations += 1  # ...except when waiting for rovers, which has its own limit...
            elif self.crowd.turned(view):  # ...unless the rover only turns, past the jam's time
                return self.crowd.held_up(view)
            if self._blocked_rotations > MAX_BLOCKED_ROTATIONS:
                return Finish("stuck", BLOCKED_WHY)
            return Rotate(round(to_goal, 3))
        on_route = (tx, tz) != goal.target  # a corner of the route: walk to it, not past it
        want = min(0.9 * p.perception.perception_radius, step or math.inf,
                   math.hypot(tx - pose.x, tz - pose.z) if on_route or goal.kind != "crater" else math.inf)
        for angle in self.candidates(to_goal, window):
            free = self.free_distance(angle, view.hits)
            if free >= min(want, p.behaviour.min_move_size):
                length = min(free, want)
                if (wait := self.crowd.follow(view, angle, length, want, self)) is not None:
                    return wait
                rad = math.radians(angle)
                # close-quarters stops come at a body's gap: too late at full speed (``free_space.rover_near``)
                slow = self.close_quarters and free_space.rover_near(view.hits, p.behaviour, length)
                return MoveTo(round(length * math.sin(rad), 4), round(length * math.cos(rad), 4), slow)
        if self.crowd.blocked_by_rovers(view, to_goal, window, want, self):
            return self.crowd.wait(view, to_goal, window, self)
        self._blocked_rotations += 1
        if self._blocked_rotations > MAX_BLOCKED_ROTATIONS:
            return Finish("stuck", BLOCKED_WHY)
        self._refused.clear()
        self._routing = True
        return Rotate(p.behaviour.rotate_action)

    def _step_off(self, view: View, window: float) -> Decision | None:
        """Nearer a rock, a wall or the lander than the gap a move keeps from it (a slip, or a wall just beyond view
        when the step began, left it there): step straight away from it first, turning its back to it if need be.
        From there every direction along a wall was blocked, and turning to look for a way only came back to the
        same three headings until the rover gave up, a few metres from the wall's end."""
        b = self.params.behaviour
        step = b.min_move_size / 2
        if self._stepping_off:  # turned its back to it: the wall is out of view now, so step straight on
            self._stepping_off = False
            return MoveTo(0.0, step, True) if self.free_distance(0.0, view.hits) >= step else None
        near = [h for h in view.hits if h.kind in STILL_KINDS and h.distance_m < b.rover_radius + OBSTACLE_MARGIN]
        if not near:
            return None
        away = wrap_deg(min(near, key=lambda h: h.distance_m).angle_deg + 180.0)
        if abs(away) > window:
            self._stepping_off = True
            return Rotate(round(away, 3))
        rad = math.radians(away)
        if self.free_distance(away, view.hits) < step:
            return None
        return MoveTo(round(step * math.sin(rad), 4), round(step * math.cos(rad), 4), True)

    # ---- the footing the rules ask of (``rules.walking``) ----

    def candidates(self, to_goal: float, window: float) -> Iterator[float]:
        return free_space.candidates(to_goal, window, self.params.behaviour.scan_angle, self._refused)

    def free_distance(self, angle: float, hits: tuple[Hit, ...]) -> float:
        gap = ROVER_GAP_CLOSE if self.close_quarters else self.params.behaviour.extra_distance_between_rovers
        return free_space.free_distance(angle, hits, self.params, gap)

    def forget_refused(self) -> None:
        self._refused.clear()

    def route(self) -> None:
        self._routing = True
