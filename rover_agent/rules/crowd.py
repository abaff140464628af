"""Among rovers: when the way is blocked by rovers rather than rocks, and what the rover does about it.

Rovers move on; rocks do not. So a rover blocked only by rovers waits for them (each rover for its own time, so
two that met do not set off together again), turns now and then to look for another way, squeezes by with
close-quarters gaps once a jam has lasted ``CROWD_SQUEEZE_S`` and, far from its goal, plans its route round the
rovers that hold it up (``rovers_in_way``), steps aside to let the others by once it has lasted
``GIVE_WAY_S``, and gives up only after ``MAX_CROWD_WAIT_S`` without progress (``mind_jam`` says what progress
is). Behind a rover that leaves it only a short step it waits a little rather than creeping (``follow``).

At a shared waypoint the report stops a rover once the waypoint is in view and rovers leave it no step towards
it (6.6). A rover walking to its own station there stops so only if rovers crowd its way now and first did
``CROWD_SQUEEZE_S`` or more before: the rovers across its way may be walking to their own stations. With the report's
rule for stations too, a 20-rover team's later arrivals stopped at the first rover crossing their way, in a ring
5 to 8 m short of their stations, and walled the last ones out (held up for 90 s and given up, or stopped in
view of the waypoint but truly beyond the perception radius).

A part of the default behaviour (``rover_agent.behaviour``), which asks it on the way and hands it its footing
(``walking.Footing``). Pure logic, no I/O.
"""

from __future__ import annotations

import math

from rover_agent.decisions import Decision, Finish, Hold, MoveTo, Rotate, View
from rover_agent.rules.occupancy import Cell, OccupancyGrid, disc_offsets, ray_point
from rover_agent.rules.tuning import (
    CROWD_LOOKS,
    CROWD_SQUEEZE_S,
    FOLLOW_SHARE,
    FOLLOW_WAITS,
    GIVE_WAY_HOLD_S,
    GIVE_WAY_OFF_GOAL_DEG,
    GIVE_WAY_S,
    GIVE_WAY_TRIES,
    KNOT_MEMORY_S,
    KNOT_ROUTE_RADII,
    MAX_BLOCKED_ROTATIONS,
    MAX_CROWD_WAIT_S,
)
from rover_agent.rules.walking import Footing
from schemas.frames import bearing_deg, wrap_deg
from schemas.params import RoverParams


class CrowdRules:
    def __init__(self, rover_id: int, params: RoverParams) -> None:
        self.rover_id = rover_id
        self.params = params
        self.now = 0.0
        """Time of the latest view."""
        self.hold_until = 0.0
        """Waiting for rovers until then."""
        self.since: float | None = None
        """When the rover last stopped making progress among rovers: the jam's start."""
        self.jam_from: tuple[tuple[float, float], float, tuple[float, float]] | None = None
        """Where the jam began: the target, metres to it, and the place."""
        self.jam_turns = 0
        """Turns to a goal or route corner out of the window, held up by rovers, since a real move."""
        self.waits = 0
        self.crowded_since: float | None = None
        """When rovers first stood between it and its station, the goal in view."""
        self.give_way_tries = 0
        """Steps aside (or looks for room to) in this jam."""
        self.giving_way = False
        """The move under way is a step aside."""
        self.turned_aside = False
        """Turned round to step aside: step before turning back to the goal."""
        self.follow_waits = 0
        """Waits in a row for a rover ahead to walk on (``follow``)."""
        self.knot: dict[Cell, float] = {}
        """Rovers' cells round a knot: when last seen."""

    # ---- events ----

    def start(self) -> None:
        """A new goal: no jam yet."""
        self.since, self.jam_from, self.jam_turns, self.waits, self.crowded_since = None, None, 0, 0, None
        self.give_way_tries, self.giving_way, self.turned_aside, self.follow_waits = 0, False, False, 0

    def moved(self, distance: float) -> bool:
        """A move ended after ``distance`` metres; whether it was real progress (not a step aside, nor a move
        cancelled at once)."""
        self.turned_aside, self.follow_waits = False, 0
        if self.giving_way:  # a step aside: no progress
            self._stepped_aside()
            return False
        if distance >= self.params.behaviour.min_move_size / 2:
            self.jam_turns = 0
            return True
        return False

    def refused(self) -> None:
        """The world refused the move: if it was a step aside, it is not under way."""
        self.giving_way = False

    def cancelled(self, now: float) -> None:
        """A move was cancelled because another rover came close: give way for a moment."""
        self.hold_until = max(self.hold_until, now + self._wait_time())  # a step aside's longer wait stands
        if self.since is None:  # the jam begins where the move stopped: the next decision says how far
            self.since, self.jam_from = now, None

    # ---- questions ----

    def holding(self, time: float) -> Hold | None:
        """Still waiting for rovers."""
        return Hold(self.hold_until) if time < self.hold_until else None

    @property
    def jammed(self) -> bool:
        return self.since is not None

    @property
    def squeezing(self) -> bool:
        return self.since is not None and self.now - self.since > CROWD_SQUEEZE_S

    def outlasted(self, view: View) -> bool:
        """Held up by rovers longer than ``MAX_CROWD_WAIT_S``: past when a rover gives up."""
        return self.since is not None and view.time - self.since > MAX_CROWD_WAIT_S

    @property
    def _stagger(self) -> int:
        """Rovers wait for different times (1, 2 or 3 shares, by id), so two that met do not set off together."""
        return 1 + self.rover_id % 3

    def _wait_time(self) -> float:
        return self.params.behaviour.max_wait_time * self._stagger

    def mind_jam(self, view: View, distance: float) -> None:
        """A jam ends once the rover is closer to its goal (``distance`` metres away now) than where the jam began,
        or has left that place (two steps from it: its way round the rovers may lead away from the goal, as a
        maze's does, and a knot of rovers on the move lets it through bit by bit). A move to and fro among them
        is no way through: counted as progress, it reset the jam's clock and its tries, and a rover held up by a
        knot that would not clear (rovers standing at their stations round its way) stepped aside and back for
        ever instead of giving up. A new target (a station given on the way) starts the measure afresh."""
        b, target, here = self.params.behaviour, view.goal.target, (view.pose.x, view.pose.z)
        began = self.jam_from
        if self.since is not None and began is not None and began[0] == target:
            left = math.dist(here, began[2]) > 2 * b.min_move_size
            if not left and distance >= began[1] - b.min_move_size / 2:
                return
            self.since, self.waits, self.give_way_tries = None, 0, 0
        self.jam_from = (target, distance, here)

    def _stepped_aside(self) -> None:
        """A step aside done: wait for the others to pass (``GIVE_WAY_HOLD_S``, staggered) before going on."""
        self.giving_way, self.hold_until = False, self.now + GIVE_WAY_HOLD_S * self._stagger / 2

    def crowded(self, view: View, footing: Footing) -> bool:
        """Rovers in view leave no room for a step towards the goal."""
        pose, (tx, tz) = view.pose, view.goal.target
        to_goal = wrap_deg(bearing_deg(tx - pose.x, tz - pose.z) - pose.heading)
        rovers = tuple(h for h in view.hits if h.kind == "rover")
        return bool(rovers) and footing.free_distance(to_goal, rovers) < self.params.behaviour.min_move_size

    def crowd_stood(self, view: View, footing: Footing) -> bool:
        """Rovers crowd the way to this rover's station now, and first did so ``CROWD_SQUEEZE_S`` ago or more
        (walking round them meanwhile does not start the wait afresh: ``start`` does)."""
        if not self.crowded(view, footing):
            return False
        if self.crowded_since is None:
            self.crowded_since = view.time
        return view.time - self.crowded_since >= CROWD_SQUEEZE_S

    def blocked_by_rovers(self, view: View, to_goal: float, window: float, want: float, footing: Footing) -> bool:
        """Would the way be free if the rovers in view were not there?"""
        still = tuple(h for h in view.hits if h.kind != "rover")
        if len(still) == len(view.hits):
            return False
        need = min(want, self.params.behaviour.min_move_size)
        return any(footing.free_distance(a, still) >= need for a in footing.candidates(to_goal, window))

    def turned(self, view: View) -> bool:
        """A turn to a goal or a route's corner outside the window, held up by rovers. True when the rover has done
        only that past ``MAX_CROWD_WAIT_S``: more than ``MAX_BLOCKED_ROTATIONS`` turns without a real move between.
        Such turns are not counted as blocked while rovers hold the rover up, and the jam's time is minded where it
        waits; packed among rovers on a crater's crest, a rover's route corner flipped from side to side as their
        bodies hid the ground, and it turned to and fro and never waited, for the rest of the mission. A rover that
        still moves now and then is getting through, however slowly, and is left to."""
        self.jam_turns += 1
        return self.outlasted(view) and self.jam_turns > MAX_BLOCKED_ROTATIONS

    # ---- decisions ----

    def wait(self, view: View, to_goal: float, window: float, footing: Footing) -> Decision:
        """Rovers block the way: wait for them to move on, now and then turning to look for another way; once
        long held up, step aside (``_give_way``)."""
        if self.since is None:
            self.since = view.time
        if self._round_the_knot(view):  # long held up on the way: plan a way round the rovers (``rovers_in_way``)
            footing.route()
        if self.outlasted(view):
            return self.held_up(view)
        if view.time - self.since > GIVE_WAY_S and self.give_way_tries < GIVE_WAY_TRIES:
            return self._give_way(view, to_goal, window, footing)
        self.waits += 1
        if self.waits % CROWD_LOOKS == 0:
            footing.forget_refused()
            return Rotate(self.params.behaviour.rotate_action)
        self.hold_until = view.time + self._wait_time()
        return Hold(self.hold_until)

    def _round_the_knot(self, view: View) -> bool:
        """Long held up by rovers on the way, not at the goal: there the rovers in the way are the team standing
        at it, and a route round them only led the rover to and fro among their stations."""
        goal, pose = view.goal, view.pose
        far = math.hypot(goal.x - pose.x, goal.z - pose.z) > KNOT_ROUTE_RADII * self.params.perception.perception_radius
        return far and self.squeezing

    def rovers_in_way(self, view: View, clearance_m: float, grid: OccupancyGrid) -> frozenset[Cell]:
        """Long held up by rovers (``CROWD_SQUEEZE_S``): the cells of ``grid`` round the rovers seen in the last
        ``KNOT_MEMORY_S``, for the route to keep clear of. Walking round a wall's long side, a team splits: the two
        ends are as near each other, and each rover's map tips it one way or the other, so rovers going either way
        met head on along the wall and waited for each other until they gave up (the 20-rover maze's first
        baffle). The route round the knot itself, or the other way along the wall, lets it drain from outside in.
        Remembered, not only those in view: which rovers are in view changes as the rover turns, and with them
        the route, and a rover beside a relay turned from one side to the other for the rest of the mission."""
        if not self._round_the_knot(view):
            self.knot.clear()
            return frozenset()
        cell, radius = grid.cell_m, self.params.behaviour.rover_radius
        for h in view.hits:
            if h.kind == "rover":
                self.knot[grid.cell_of(*ray_point(view.pose, h.angle_deg, h.distance_m + radius))] = view.time
        for centre in [c for c, seen in self.knot.items() if view.time - seen > KNOT_MEMORY_S]:
            del self.knot[centre]
        offsets = disc_offsets((radius + clearance_m) / cell)
        return frozenset((i + di, j + dj) for i, j in self.knot for di, dj in offsets)

    def follow(self, view: View, angle: float, length: float, want: float, footing: Footing) -> Hold | None:
        """A rover ahead leaves only a short step (under ``FOLLOW_SHARE`` of the step wanted, where the ground
        itself is free farther): wait for it to walk on, up to ``FOLLOW_WAITS`` times, rather than creep after
        it. Every move turns the heading a little whatever its length (``NavigationParams.heading_noise_std_deg``)
        and a heading error swings all the rest of the way, so a rover creeping behind a queue in short steps
        arrived metres farther off than one that had waited; with no heading noise, creeping costs nothing."""
        if (self.params.navigation.heading_noise_std_deg <= 0 or footing.close_quarters
                or length >= FOLLOW_SHARE * want or self.follow_waits >= FOLLOW_WAITS):
            return None
        still = tuple(h for h in view.hits if h.kind != "rover")
        if footing.free_distance(angle, still) < FOLLOW_SHARE * want:  # the ground cuts the step short, not rovers
            return None
        self.follow_waits += 1
        self.hold_until = view.time + self._wait_time()
        return Hold(self.hold_until)

    def held_up(self, view: View) -> Finish:
        """The jam's time is out. Within the perception radius of a waypoint the team shares, the radius within
        which a rover is at it, the rover is there, if not at its own station: the team keeps it out (the report's
        rule, 6.6, with the whole radius rather than ``WAYPOINT_IN_VIEW`` of it, since the rovers kept it there for
        so long), within what it can tell: its estimate may be off by its 1-sigma error. In the middle of a team
        that drifted through a maze, a rover 6.7 m from the waypoint believed it 10.4 m away (4.7 m sigma) and
        gave up. Not so on the way to a spot of its own (``View.toward``: a spoke's foot, out of a bowl,
        sunlight), nor elsewhere: it gives up, and says why."""
        goal, pose = view.goal, view.pose
        radius = self.params.perception.perception_radius + view.position_std_m
        if goal.kind == "waypoint" and goal.shared and math.hypot(goal.x - pose.x, goal.z - pose.z) <= radius:
            return Finish("reached")
        return Finish("stuck", f"held up by other rovers for {MAX_CROWD_WAIT_S:.0f} s")

    def _give_way(self, view: View, to_goal: float, window: float, footing: Footing) -> Decision:
        """Step aside, away from the goal, into the freest direction in view: rovers that block each other (two
        head on in a gap, four in a knot in a corridor) otherwise each wait for the others until all give up.
        With no room in view, turn round first and step away from the knot (``step_aside``, when the rover next
        heads for its goal). The rover then waits a while where it stands (``_stepped_aside``; rovers for
        different times, so a pair that stepped aside together do not come back together) before heading for the
        goal again, and the jam's clock runs on: a step aside is no progress."""
        self.give_way_tries += 1
        step = self.step_aside(view, to_goal, window, footing)
        if step is not None:
            return step
        self.turned_aside = True
        return Rotate(180.0)

    def step_aside(self, view: View, to_goal: float, window: float, footing: Footing) -> MoveTo | None:
        """A slow step of ``min_move_size`` into the freest direction in view at least ``GIVE_WAY_OFF_GOAL_DEG``
        off the way to the goal; None if none is free that far."""
        self.turned_aside = False
        b = self.params.behaviour
        aside = [a for a in footing.candidates(0.0, window) if abs(wrap_deg(a - to_goal)) >= GIVE_WAY_OFF_GOAL_DEG]
        best = max(aside, key=lambda a: (round(footing.free_distance(a, view.hits), 3), -abs(a)), default=None)
        if best is None or footing.free_distance(best, view.hits) < b.min_move_size:
            return None
        self.giving_way = True
        rad = math.radians(best)
        return MoveTo(round(b.min_move_size * math.sin(rad), 4), round(b.min_move_size * math.cos(rad), 4), True)
