"""The default behaviour (``rover_agent.behaviour``) with scripted views: heading for a goal, round rocks and walls,
when to stop a move, reaching a waypoint or a station, and giving up where it gets no closer."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from agent_kit import BOXED_IN, PARAMS, RADIUS, angle_of, fresh_behaviour, goal_at, view_of

from rover_agent.decisions import Finish, Goal, Hit, Hold, MoveTo, Rotate
from rover_agent.rules.free_space import ray_angles
from rover_agent.rules.tuning import (
    CROWD_SQUEEZE_S,
    MAX_BLOCKED_ROTATIONS,
    NO_PROGRESS_ROUTE_M,
    NO_PROGRESS_WALK_M,
    SPOT_HELD_M,
    STATION_CLOSE_M,
    WAYPOINT_CLOSE,
    WAYPOINT_IN_VIEW,
)
from shared.pose import Pose

# ---- heading for a goal ----


def test_goal_straight_ahead_in_open_ground_moves_ninety_percent_of_the_radius():
    goal = goal_at(0.0, 50.0)
    assert fresh_behaviour(goal).decide(view_of(goal)) == MoveTo(0.0, 0.9 * RADIUS)


@pytest.mark.parametrize(("pose", "goal"), [
    (Pose(0.0, 0.0, 90.0), (60.0, 0.0)),
    (Pose(-510.0, 100.0, 180.0), (-510.0, 20.0)),
    (Pose(5.0, 5.0, 45.0), (45.0, 45.0)),
])
def test_goal_ahead_in_any_frame_moves_straight_ahead(pose, goal):
    g = goal_at(*goal)
    move = fresh_behaviour(g).decide(view_of(g, pose=pose))
    assert isinstance(move, MoveTo)
    assert move.x == pytest.approx(0.0, abs=1e-3) and move.z == pytest.approx(0.9 * RADIUS)


def test_goal_ahead_and_to_the_right_within_the_window_moves_towards_it():
    goal = goal_at(50.0, 50.0)  # 45 deg right
    move = fresh_behaviour(goal).decide(view_of(goal))
    assert isinstance(move, MoveTo)
    assert angle_of(move) == pytest.approx(45.0, abs=0.01)
    assert math.hypot(move.x, move.z) == pytest.approx(9.0, abs=1e-3)


@pytest.mark.parametrize(("goal", "degrees"), [
    ((0.0, -50.0), -180.0),  # straight behind: wrap_deg gives [-180, 180)
    ((-30.0, -30.0), -135.0),  # behind, left
    ((30.0, -30.0), 135.0),  # behind, right
    ((50.0, 0.0), 90.0),  # right, outside the +-80 deg scanner window
    ((-50.0, 5.0), -84.289),
])
def test_goal_outside_the_window_rotates_towards_it(goal, degrees):
    g = goal_at(*goal)
    decision = fresh_behaviour(g).decide(view_of(g))
    assert isinstance(decision, Rotate)
    assert decision.degrees == pytest.approx(degrees, abs=1e-3)


def test_a_waypoint_in_view_is_walked_on_to_close_range_not_past():
    z = round(0.7 * PARAMS.perception.perception_radius, 4)  # in view, but not yet close
    goal = goal_at(0.0, z)
    decision = fresh_behaviour(goal).decide(view_of(goal))
    assert decision == MoveTo(0.0, z)


@pytest.mark.parametrize("fraction", [0.0, 0.3, WAYPOINT_CLOSE])
def test_a_close_waypoint_is_reached(fraction):
    goal = goal_at(0.0, fraction * PARAMS.perception.perception_radius)
    assert fresh_behaviour(goal).decide(view_of(goal)) == Finish("reached")


def test_a_waypoint_in_view_but_crowded_by_rovers_is_reached():
    z = 0.8 * PARAMS.perception.perception_radius
    goal = goal_at(0.0, z)
    crowd = (Hit(-4.0, 1.6, "rover"), Hit(0.0, 1.5, "rover"), Hit(4.0, 1.6, "rover"))
    assert fresh_behaviour(goal).decide(view_of(goal, hits=crowd)) == Finish("reached")
    rocks = tuple(Hit(h.angle_deg, h.distance_m, "obstacle") for h in crowd)
    assert fresh_behaviour(goal).decide(view_of(goal, hits=rocks)) != Finish("reached")  # rocks are no crowd
    far = goal_at(0.0, (WAYPOINT_IN_VIEW + 0.05) * PARAMS.perception.perception_radius)
    assert fresh_behaviour(far).decide(view_of(far, hits=crowd)) != Finish("reached")  # out of view


# ---- obstacles ----


def test_rock_straight_ahead_deviates_right_first():
    move = fresh_behaviour().decide(view_of(hits=[Hit(0.0, 3.0, "obstacle")]))
    assert isinstance(move, MoveTo)
    assert move.x > 0
    # +-10 and +-20 deg still pass within the rover's clearance of the hit (its body, a margin, and the rays'
    # spread at 3 m); +30 is the first direction clear for 2 m
    assert angle_of(move) == pytest.approx(30.0, abs=1e-3)
    assert math.hypot(move.x, move.z) >= PARAMS.behaviour.min_move_size


def test_rock_ahead_with_the_right_blocked_deviates_left():
    hits = [Hit(0.0, 3.0, "obstacle")] + [Hit(float(a), 2.5, "obstacle") for a in range(10, 90, 5)]
    move = fresh_behaviour().decide(view_of(hits=hits))
    assert isinstance(move, MoveTo)
    assert move.x < 0
    assert angle_of(move) == pytest.approx(-30.0, abs=1e-3)


def test_far_obstacle_shortens_the_move():
    move = fresh_behaviour().decide(view_of(hits=[Hit(0.0, 6.0, "obstacle")]))
    # the rover stops its body, a margin and the rays' spread at 6 m short of the hit: a rock may reach almost to
    # the next ray, which missed it
    spread = 6.0 * math.radians(PARAMS.perception.ray_step_deg)
    assert move == MoveTo(0.0, pytest.approx(6.0 - (0.5 + 0.6 + spread)))


def _rock_hits(cx: float, cz: float, radius: float) -> tuple[Hit, ...]:
    """What the world's rays show of a round rock: the entry points of those that meet it."""
    hits = []
    for a in ray_angles(PARAMS.perception.field_of_view_degrees, PARAMS.perception.perception_granularity):
        dx, dz = math.sin(math.radians(a)), math.cos(math.radians(a))
        b, c = cx * dx + cz * dz, cx * cx + cz * cz - radius * radius
        if b * b - c >= 0 and 0 <= (t := b - math.sqrt(b * b - c)) <= PARAMS.perception.perception_radius:
            hits.append(Hit(round(a, 3), round(t, 3), "obstacle"))
    return tuple(hits)


def test_a_rock_seen_at_range_is_passed_with_a_margin_from_what_the_rays_missed():
    """The mechanism of a collision with a rock 9 m off: two rays met its near face, its flank lay between them
    and the next, and a move keeping the body and a fixed margin from the hits passed the flank by 9 cm, which a
    slip of 2% closed. The margin grows with the rays' spread, so the real surface keeps most of it."""
    centre = (9.4 * math.sin(math.radians(-4.4)), 9.4 * math.cos(math.radians(-4.4)))
    goal = goal_at(50.0 * math.sin(math.radians(-14.0)), 50.0 * math.cos(math.radians(-14.0)))
    move = fresh_behaviour(goal).decide(view_of(goal, hits=_rock_hits(*centre, 1.0)))
    assert isinstance(move, MoveTo)
    length = math.hypot(move.x, move.z)
    ux, uz = move.x / length, move.z / length
    along = max(0.0, min(length, centre[0] * ux + centre[1] * uz))
    kept = math.dist(centre, (along * ux, along * uz)) - 1.0 - PARAMS.behaviour.rover_radius
    assert kept > 0.5


def test_crater_terrain_does_not_block():
    hits = [Hit(float(a), 1.0, "crater_terrain") for a in range(-100, 101, 5)]
    assert fresh_behaviour().decide(view_of(hits=hits)) == MoveTo(0.0, 9.0)


def _decisions_until_stuck(b, limit=60):
    decisions = []
    for _ in range(limit):
        decisions.append(b.decide(view_of(hits=BOXED_IN)))
        if decisions[-1] == Finish("stuck"):
            break
    return decisions


def test_obstacles_everywhere_rotate_sixty_then_turn_to_the_route_and_give_up_in_time():
    decisions = _decisions_until_stuck(fresh_behaviour())
    assert decisions[0] == Rotate(60.0)  # the report's rotation when blocked everywhere in view
    assert decisions[-1] == Finish("stuck") and "without finding a free way" in decisions[-1].why
    assert all(isinstance(d, Rotate) for d in decisions[:-1])  # never a move into the obstacles
    assert MAX_BLOCKED_ROTATIONS < len(decisions) <= 2 * MAX_BLOCKED_ROTATIONS + 2
    assert any(d.degrees != 60.0 for d in decisions[:-1])  # routing: it turns to face the planned way out


def test_a_move_resets_the_blocked_count():
    alone = len(_decisions_until_stuck(fresh_behaviour()))
    b = fresh_behaviour()
    for _ in range(alone - 3):
        b.decide(view_of(hits=BOXED_IN))
    b.moved(2.0)
    assert len(_decisions_until_stuck(b)) > 3


def test_a_rejected_direction_is_not_tried_again():
    b = fresh_behaviour()
    assert b.decide(view_of()) == MoveTo(0.0, 9.0)
    b.rejected(0.0)
    move = b.decide(view_of())
    assert isinstance(move, MoveTo) and angle_of(move) == pytest.approx(10.0, abs=1e-3)


def test_after_a_cancel_the_rover_holds():
    b = fresh_behaviour()
    b.cancelled(now=10.0)
    wait = PARAMS.behaviour.max_wait_time * (1 + 1 % 3)
    assert b.decide(view_of(time=10.5)) == Hold(10.0 + wait)
    assert isinstance(b.decide(view_of(time=10.0 + wait)), MoveTo)


def test_should_cancel_for_a_rover_close_ahead_only():
    b = fresh_behaviour()
    assert b.should_cancel(view_of(hits=[Hit(0.0, 2.0, "rover")]))
    assert b.should_cancel(view_of(hits=[Hit(30.0, 3.0, "rover")]))
    assert not b.should_cancel(view_of(hits=[Hit(90.0, 2.0, "rover")]))
    assert not b.should_cancel(view_of(hits=[Hit(-90.0, 2.0, "rover")]))
    assert not b.should_cancel(view_of(hits=[Hit(0.0, 2.0, "obstacle")]))
    assert not b.should_cancel(view_of(hits=[Hit(0.0, 6.0, "rover")]))
    assert not b.should_cancel(view_of())


def test_a_move_stops_short_of_a_rock_come_into_view_across_the_rest_of_its_way():
    """Planned clear of what was in view where it began; slip, or a rock just beyond view, can put one in the way."""
    b = fresh_behaviour()

    def on_the_way(hit: Hit, remaining: float) -> bool:
        return b.should_cancel(replace(view_of(hits=[hit]), remaining_m=remaining))

    assert on_the_way(Hit(0.0, 4.0, "obstacle"), 5.0)
    assert on_the_way(Hit(4.0, 5.0, "lander"), 5.0)  # 0.35 m off the line: inside the body's half-width
    assert not on_the_way(Hit(0.0, 6.0, "obstacle"), 5.0)  # beyond where the move ends (body's reach: 5.5 m)
    assert not on_the_way(Hit(10.0, 4.0, "obstacle"), 5.0)  # 0.7 m off the line: the body passes it
    assert not on_the_way(Hit(0.0, 4.0, "terrain"), 5.0)  # a rover on rough ground walks along steep slopes
    assert not on_the_way(Hit(0.0, 4.0, "obstacle"), 0.0)  # not under way yet: turning to face its goal
    b.cancelled(now=10.0)  # stopped for a rock: nothing to give way to
    assert not isinstance(b.decide(view_of(time=10.2, hits=[Hit(0.0, 1.5, "obstacle")])), Hold)


def test_a_rover_closing_in_from_the_side_stops_the_move():
    """Crossing courses: a rover abeam is no danger until contact is close, whatever the right of way."""
    b = fresh_behaviour()
    assert b.should_cancel(view_of(hits=[Hit(70.0, 1.2, "rover")]))
    assert b.should_cancel(view_of(hits=[Hit(-70.0, 1.2, "rover")]))
    assert not b.should_cancel(view_of(hits=[Hit(70.0, 2.0, "rover")]))
    assert not b.should_cancel(view_of(hits=[Hit(120.0, 1.2, "rover")]))  # behind: it is for that one to stop


def test_traffic_from_the_left_gives_way_to_this_rover_unless_contact_is_close():
    """Report 7.2.1: traffic to the right has right of way; a rover ahead-left stops for this one."""
    b = fresh_behaviour()
    assert not b.should_cancel(view_of(hits=[Hit(-30.0, 3.0, "rover")]))
    assert b.should_cancel(view_of(hits=[Hit(-30.0, 1.2, "rover")]))


# ---- walls and pacing ----


def test_nearer_a_wall_than_a_move_keeps_the_rover_first_steps_straight_away_from_it():
    """A slip, or a wall just beyond view when a step began, can leave a rover nearer a wall than any move keeps
    from it. From there every direction along the wall was blocked, and turning to look for a way came back to
    the same three headings until the rover gave up, a few metres from the wall's end."""
    wall = tuple(Hit(a, round(0.7 / math.cos(math.radians(a)), 3), "obstacle") for a in range(-60, 61, 5))
    b = fresh_behaviour()
    assert b.decide(view_of(hits=wall)) == Rotate(-180.0)  # its back to the wall first, which then is out of view
    half = PARAMS.behaviour.min_move_size / 2
    assert b.decide(view_of(pose=Pose(0.0, 0.0, 180.0))) == MoveTo(0.0, half, True)
    beside = (Hit(-100.0, 0.7, "obstacle"),)  # behind the left shoulder: straight away is in the window
    step = fresh_behaviour().decide(view_of(hits=beside))
    assert isinstance(step, MoveTo) and step.slow and angle_of(step) == pytest.approx(80.0, abs=0.01)
    assert math.hypot(step.x, step.z) == pytest.approx(half, abs=1e-3)
    clear = (Hit(-100.0, 2.0, "obstacle"),)  # as far as a move keeps: nothing to step off
    assert fresh_behaviour().decide(view_of(hits=clear)) == MoveTo(0.0, 0.9 * RADIUS)


def test_a_rover_pacing_without_getting_closer_gives_up():
    b = fresh_behaviour()
    assert isinstance(b.decide(view_of()), MoveTo)  # 50 m from the goal
    walked = 0.0
    while walked <= NO_PROGRESS_WALK_M:
        b.moved(9.0)
        walked += 9.0
        pose = Pose(0.0, -5.0 if int(walked) % 2 else 0.0, 0.0)  # back and forth, never nearer
        decision = b.decide(view_of(pose=pose))
        if walked <= NO_PROGRESS_WALK_M:
            assert decision != Finish("stuck")
    assert decision == Finish("stuck") and "without getting closer" in decision.why


def test_a_rover_pacing_along_a_wall_starts_routing_before_it_gives_up():
    b = fresh_behaviour()
    b.decide(view_of())
    walked = 0.0
    while not b._routing and walked < NO_PROGRESS_WALK_M:
        b.moved(9.0)
        walked += 9.0
        assert b.decide(view_of(pose=Pose(0.0, -5.0 if int(walked) % 2 else 0.0, 0.0))) != Finish("stuck")
    assert NO_PROGRESS_ROUTE_M < walked <= NO_PROGRESS_ROUTE_M + 9.0


# ---- stations at a shared waypoint ----


def _station_goal(station=(4.0, 0.0)) -> Goal:
    return Goal(0, 1, "waypoint", 0.0, 20.0, station)


def test_a_rover_walks_to_its_station_not_to_the_waypoint():
    goal = _station_goal()
    move = fresh_behaviour(goal).decide(view_of(goal, pose=Pose(4.0, 12.0, 0.0)))
    assert move == MoveTo(0.0, 2.0)  # short steps when parking


def test_the_station_is_reached_close_to_it_not_merely_in_view_of_the_waypoint():
    goal = _station_goal()
    assert fresh_behaviour(goal).decide(view_of(goal, pose=Pose(4.0, 20.0 - STATION_CLOSE_M, 0.0))) == Finish("reached")
    assert isinstance(fresh_behaviour(goal).decide(view_of(goal, pose=Pose(4.0, 15.0, 0.0))), MoveTo)


def test_a_station_walled_in_by_rovers_for_a_while_counts_as_reached_with_the_waypoint_in_view():
    goal = _station_goal()
    wall = [Hit(a, 1.6, "rover") for a in range(-60, 61, 5)]
    behaviour, here = fresh_behaviour(goal), Pose(4.0, 14.0, 0.0)
    assert behaviour.decide(view_of(goal, pose=here, hits=wall)) != Finish("reached")  # they may be passing
    assert behaviour.decide(view_of(goal, pose=here, hits=wall, time=CROWD_SQUEEZE_S)) == Finish("reached")
    far = _station_goal((4.0, -15.0))  # the waypoint itself out of view: keep trying
    behaviour = fresh_behaviour(far)
    for t in (0.0, CROWD_SQUEEZE_S):
        assert behaviour.decide(view_of(far, pose=Pose(4.0, -3.0, 180.0), hits=wall, time=t)) != Finish("reached")


def test_a_rover_crossing_the_way_to_a_station_does_not_end_the_walk_short_of_it():
    """The mechanism of a 20-rover jam: rovers that stopped at the first rover across their way to a station
    stood in a ring short of the formation and walled the later ones out. A crowd must stand in the way, on and
    off, for a while; stepping round it meanwhile does not start the wait afresh."""
    goal = _station_goal((0.0, 0.0))
    behaviour, here = fresh_behaviour(goal), Pose(0.0, 12.0, 0.0)
    passing = (Hit(-5.0, 1.6, "rover"), Hit(0.0, 1.5, "rover"), Hit(5.0, 1.6, "rover"))
    assert behaviour.decide(view_of(goal, pose=here, hits=passing)) != Finish("reached")
    assert isinstance(behaviour.decide(view_of(goal, pose=here, time=1.0)), MoveTo)  # it has gone: on to the station
    behaviour.moved(2.0)
    later = Pose(0.0, 11.0, 0.0)
    assert behaviour.decide(view_of(goal, pose=later, hits=passing, time=CROWD_SQUEEZE_S - 1.0)) != Finish("reached")
    assert behaviour.decide(view_of(goal, pose=later, hits=passing, time=CROWD_SQUEEZE_S + 1.0)) == Finish("reached")
    plain = goal_at(0.0, 20.0)  # no station (the report's rule): in view and crowded is reached at once
    assert fresh_behaviour(plain).decide(view_of(plain, pose=here, hits=passing)) == Finish("reached")


@pytest.mark.parametrize(("kind", "station", "outcome"), [
    ("relay", None, "relay"), ("waypoint", (4.0, 0.0), "reached")])
@pytest.mark.parametrize(("off_m", "holds"), [(SPOT_HELD_M - 0.5, True), (SPOT_HELD_M + 1.0, False)])
def test_a_spot_the_rover_circles_without_getting_nearer_is_held_from_where_it_stands(kind, station, outcome, off_m,
                                                                                       holds):
    """A rock or a wall on a relay spot or a station: the rover walks round it and gets no nearer. Near it, it
    holds where it is rather than circle until the world's watchdog counts it stuck; farther off it keeps looking
    for a way (a route, in the end a stuck report of its own)."""
    goal = Goal(0, 1, kind, 0.0, 20.0, station)
    tx, tz = goal.target
    b = fresh_behaviour(goal)
    here = Pose(tx, tz - off_m, 0.0)
    decisions = []
    for step in range(8):  # round and round: 24 m walked, never nearer
        decisions.append(b.decide(view_of(goal, pose=here, time=float(step))))
        b.moved(3.0)
    assert (Finish(outcome) in decisions) is holds
    assert Finish(outcome) not in decisions[:int(NO_PROGRESS_ROUTE_M // 3) + 1]  # not before it has tried
