"""The rover behaviour with scripted views, and the whole rover agent fed encoded samples (no router)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest
from agent_kit import joined_agent

from rover_agent.agent import STATION_ASK_M, STATION_ASK_RETRY_S
from rover_agent.behaviour import DefaultBehaviour
from rover_agent.dead_reckoning import Pose
from rover_agent.decisions import Finish, Goal, Hit, Hold, MoveTo, Rotate, TakePhoto, View
from rover_agent.free_space import ray_angles
from rover_agent.occupancy import ray_point
from rover_agent.tuning import (
    BOWL_PITCH,
    CROWD_SQUEEZE_S,
    FOLLOW_WAITS,
    GIVE_WAY_HOLD_S,
    GIVE_WAY_S,
    KNOT_MEMORY_S,
    MAX_BACKS,
    MAX_BLOCKED_ROTATIONS,
    MAX_CROWD_WAIT_S,
    NO_PROGRESS_ROUTE_M,
    NO_PROGRESS_WALK_M,
    SPOT_HELD_M,
    STATION_CLOSE_M,
    WAYPOINT_CLOSE,
    WAYPOINT_IN_VIEW,
)
from schemas import codec, radio
from schemas import keyspace as ks
from schemas import messages as m
from schemas.params import RoverParams

PARAMS = RoverParams()
RADIUS = PARAMS.perception.perception_radius  # 10 m
ORIGIN = Pose(0.0, 0.0, 0.0)


def _behaviour(goal: Goal | None = None) -> DefaultBehaviour:
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(goal or _goal())
    return b


def _goal(x=0.0, z=50.0, kind="waypoint", index=0, total=1) -> Goal:
    return Goal(index, total, kind, x, z)


def _view(goal=None, pose=ORIGIN, hits=(), pitch=0.0, time=0.0) -> View:
    return View(time, pose, goal or _goal(), tuple(hits), pitch)


def _angle(move: MoveTo) -> float:
    return math.degrees(math.atan2(move.x, move.z))


# ---- migration ----


def test_goal_straight_ahead_in_open_ground_moves_ninety_percent_of_the_radius():
    goal = _goal(0.0, 50.0)
    assert _behaviour(goal).decide(_view(goal)) == MoveTo(0.0, 0.9 * RADIUS)


@pytest.mark.parametrize(("pose", "goal"), [
    (Pose(0.0, 0.0, 90.0), (60.0, 0.0)),
    (Pose(-510.0, 100.0, 180.0), (-510.0, 20.0)),
    (Pose(5.0, 5.0, 45.0), (45.0, 45.0)),
])
def test_goal_ahead_in_any_frame_moves_straight_ahead(pose, goal):
    g = _goal(*goal)
    move = _behaviour(g).decide(_view(g, pose=pose))
    assert isinstance(move, MoveTo)
    assert move.x == pytest.approx(0.0, abs=1e-3) and move.z == pytest.approx(0.9 * RADIUS)


def test_goal_ahead_and_to_the_right_within_the_window_moves_towards_it():
    goal = _goal(50.0, 50.0)  # 45 deg right
    move = _behaviour(goal).decide(_view(goal))
    assert isinstance(move, MoveTo)
    assert _angle(move) == pytest.approx(45.0, abs=0.01)
    assert math.hypot(move.x, move.z) == pytest.approx(9.0, abs=1e-3)


@pytest.mark.parametrize(("goal", "degrees"), [
    ((0.0, -50.0), -180.0),  # straight behind: wrap_deg gives [-180, 180)
    ((-30.0, -30.0), -135.0),  # behind, left
    ((30.0, -30.0), 135.0),  # behind, right
    ((50.0, 0.0), 90.0),  # right, outside the +-80 deg scanner window
    ((-50.0, 5.0), -84.289),
])
def test_goal_outside_the_window_rotates_towards_it(goal, degrees):
    g = _goal(*goal)
    decision = _behaviour(g).decide(_view(g))
    assert isinstance(decision, Rotate)
    assert decision.degrees == pytest.approx(degrees, abs=1e-3)


def test_a_waypoint_in_view_is_walked_on_to_close_range_not_past():
    z = round(0.7 * PARAMS.perception.perception_radius, 4)  # in view, but not yet close
    goal = _goal(0.0, z)
    decision = _behaviour(goal).decide(_view(goal))
    assert decision == MoveTo(0.0, z)


@pytest.mark.parametrize("fraction", [0.0, 0.3, WAYPOINT_CLOSE])
def test_a_close_waypoint_is_reached(fraction):
    goal = _goal(0.0, fraction * PARAMS.perception.perception_radius)
    assert _behaviour(goal).decide(_view(goal)) == Finish("reached")


def test_a_waypoint_in_view_but_crowded_by_rovers_is_reached():
    z = 0.8 * PARAMS.perception.perception_radius
    goal = _goal(0.0, z)
    crowd = (Hit(-4.0, 1.6, "rover"), Hit(0.0, 1.5, "rover"), Hit(4.0, 1.6, "rover"))
    assert _behaviour(goal).decide(_view(goal, hits=crowd)) == Finish("reached")
    rocks = tuple(Hit(h.angle_deg, h.distance_m, "obstacle") for h in crowd)
    assert _behaviour(goal).decide(_view(goal, hits=rocks)) != Finish("reached")  # rocks are no crowd
    far = _goal(0.0, (WAYPOINT_IN_VIEW + 0.05) * PARAMS.perception.perception_radius)
    assert _behaviour(far).decide(_view(far, hits=crowd)) != Finish("reached")  # out of view


def test_crater_goal_is_not_reached_by_distance_alone():
    goal = _goal(0.0, 1.0, kind="crater")
    assert not isinstance(_behaviour(goal).decide(_view(goal)), Finish)


def test_in_a_crater_bowl_the_rover_walks_out_and_looks_back_for_the_rim():
    """A crater's terrain shows where a ray enters it: from inside the bowl no rim shows, and walking on for the
    goal the rover crossed it to and fro for ever. Near the goal with no rim ever seen, it walks out towards the
    lander, looks back at the goal after a long step, and climbs as usual once the rim shows."""
    goal, radius = _goal(0.0, 50.0, kind="crater"), PARAMS.perception.perception_radius
    b = _behaviour(goal)
    turn = b.decide(_view(goal, pose=Pose(0.0, 48.0, 0.0)))
    assert isinstance(turn, Rotate) and abs(turn.degrees) == pytest.approx(180.0)  # the lander is behind it
    out = b.decide(_view(goal, pose=Pose(0.0, 48.0, 180.0)))
    assert isinstance(out, MoveTo) and _angle(out) == pytest.approx(0.0) and out.z == pytest.approx(0.9 * radius)
    b.moved(0.9 * radius)
    outside = Pose(0.0, 48.0 - 0.9 * radius, 180.0)
    look = b.decide(_view(goal, pose=outside))
    assert isinstance(look, Rotate) and abs(look.degrees) == pytest.approx(180.0)  # look back at the goal
    rim = [Hit(float(a), 6.0, "crater_terrain") for a in range(-30, 31, 5)]
    climb = b.decide(_view(goal, pose=Pose(0.0, outside.z, 0.0), hits=rim))
    assert b.state == "climbing" and isinstance(climb, MoveTo) and _angle(climb) == pytest.approx(0.0)


# ---- obstacles ----


def test_rock_straight_ahead_deviates_right_first():
    move = _behaviour().decide(_view(hits=[Hit(0.0, 3.0, "obstacle")]))
    assert isinstance(move, MoveTo)
    assert move.x > 0
    # +-10 and +-20 deg still pass within the rover's clearance of the hit (its body, a margin, and the rays'
    # spread at 3 m); +30 is the first direction clear for 2 m
    assert _angle(move) == pytest.approx(30.0, abs=1e-3)
    assert math.hypot(move.x, move.z) >= PARAMS.behaviour.min_move_size


def test_rock_ahead_with_the_right_blocked_deviates_left():
    hits = [Hit(0.0, 3.0, "obstacle")] + [Hit(float(a), 2.5, "obstacle") for a in range(10, 90, 5)]
    move = _behaviour().decide(_view(hits=hits))
    assert isinstance(move, MoveTo)
    assert move.x < 0
    assert _angle(move) == pytest.approx(-30.0, abs=1e-3)


def test_far_obstacle_shortens_the_move():
    move = _behaviour().decide(_view(hits=[Hit(0.0, 6.0, "obstacle")]))
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
    goal = _goal(50.0 * math.sin(math.radians(-14.0)), 50.0 * math.cos(math.radians(-14.0)))
    move = _behaviour(goal).decide(_view(goal, hits=_rock_hits(*centre, 1.0)))
    assert isinstance(move, MoveTo)
    length = math.hypot(move.x, move.z)
    ux, uz = move.x / length, move.z / length
    along = max(0.0, min(length, centre[0] * ux + centre[1] * uz))
    kept = math.dist(centre, (along * ux, along * uz)) - 1.0 - PARAMS.behaviour.rover_radius
    assert kept > 0.5


def test_crater_terrain_does_not_block():
    hits = [Hit(float(a), 1.0, "crater_terrain") for a in range(-100, 101, 5)]
    assert _behaviour().decide(_view(hits=hits)) == MoveTo(0.0, 9.0)


BOXED_IN = [Hit(float(a), 1.0, "obstacle") for a in range(-105, 106, 5)]


def _decisions_until_stuck(b, limit=60):
    decisions = []
    for _ in range(limit):
        decisions.append(b.decide(_view(hits=BOXED_IN)))
        if decisions[-1] == Finish("stuck"):
            break
    return decisions


def test_obstacles_everywhere_rotate_sixty_then_turn_to_the_route_and_give_up_in_time():
    decisions = _decisions_until_stuck(_behaviour())
    assert decisions[0] == Rotate(60.0)  # the report's rotation when blocked everywhere in view
    assert decisions[-1] == Finish("stuck") and "without finding a free way" in decisions[-1].why
    assert all(isinstance(d, Rotate) for d in decisions[:-1])  # never a move into the obstacles
    assert MAX_BLOCKED_ROTATIONS < len(decisions) <= 2 * MAX_BLOCKED_ROTATIONS + 2
    assert any(d.degrees != 60.0 for d in decisions[:-1])  # routing: it turns to face the planned way out


def test_a_move_resets_the_blocked_count():
    alone = len(_decisions_until_stuck(_behaviour()))
    b = _behaviour()
    for _ in range(alone - 3):
        b.decide(_view(hits=BOXED_IN))
    b.moved(2.0)
    assert len(_decisions_until_stuck(b)) > 3


def test_a_rejected_direction_is_not_tried_again():
    b = _behaviour()
    assert b.decide(_view()) == MoveTo(0.0, 9.0)
    b.rejected(0.0)
    move = b.decide(_view())
    assert isinstance(move, MoveTo) and _angle(move) == pytest.approx(10.0, abs=1e-3)


def test_after_a_cancel_the_rover_holds():
    b = _behaviour()
    b.cancelled(now=10.0)
    wait = PARAMS.behaviour.max_wait_time * (1 + 1 % 3)
    assert b.decide(_view(time=10.5)) == Hold(10.0 + wait)
    assert isinstance(b.decide(_view(time=10.0 + wait)), MoveTo)


def test_should_cancel_for_a_rover_close_ahead_only():
    b = _behaviour()
    assert b.should_cancel(_view(hits=[Hit(0.0, 2.0, "rover")]))
    assert b.should_cancel(_view(hits=[Hit(30.0, 3.0, "rover")]))
    assert not b.should_cancel(_view(hits=[Hit(90.0, 2.0, "rover")]))
    assert not b.should_cancel(_view(hits=[Hit(-90.0, 2.0, "rover")]))
    assert not b.should_cancel(_view(hits=[Hit(0.0, 2.0, "obstacle")]))
    assert not b.should_cancel(_view(hits=[Hit(0.0, 6.0, "rover")]))
    assert not b.should_cancel(_view())


def test_a_move_stops_short_of_a_rock_come_into_view_across_the_rest_of_its_way():
    """Planned clear of what was in view where it began; slip, or a rock just beyond view, can put one in the way."""
    b = _behaviour()

    def on_the_way(hit: Hit, remaining: float) -> bool:
        return b.should_cancel(replace(_view(hits=[hit]), remaining_m=remaining))

    assert on_the_way(Hit(0.0, 4.0, "obstacle"), 5.0)
    assert on_the_way(Hit(4.0, 5.0, "lander"), 5.0)  # 0.35 m off the line: inside the body's half-width
    assert not on_the_way(Hit(0.0, 6.0, "obstacle"), 5.0)  # beyond where the move ends (body's reach: 5.5 m)
    assert not on_the_way(Hit(10.0, 4.0, "obstacle"), 5.0)  # 0.7 m off the line: the body passes it
    assert not on_the_way(Hit(0.0, 4.0, "terrain"), 5.0)  # a rover on rough ground walks along steep slopes
    assert not on_the_way(Hit(0.0, 4.0, "obstacle"), 0.0)  # not under way yet: turning to face its goal
    b.cancelled(now=10.0)  # stopped for a rock: nothing to give way to
    assert not isinstance(b.decide(_view(time=10.2, hits=[Hit(0.0, 1.5, "obstacle")])), Hold)


def test_a_rover_closing_in_from_the_side_stops_the_move():
    """Crossing courses: a rover abeam is no danger until contact is close, whatever the right of way."""
    b = _behaviour()
    assert b.should_cancel(_view(hits=[Hit(70.0, 1.2, "rover")]))
    assert b.should_cancel(_view(hits=[Hit(-70.0, 1.2, "rover")]))
    assert not b.should_cancel(_view(hits=[Hit(70.0, 2.0, "rover")]))
    assert not b.should_cancel(_view(hits=[Hit(120.0, 1.2, "rover")]))  # behind: it is for that one to stop


def test_traffic_from_the_left_gives_way_to_this_rover_unless_contact_is_close():
    """Report 7.2.1: traffic to the right has right of way; a rover ahead-left stops for this one."""
    b = _behaviour()
    assert not b.should_cancel(_view(hits=[Hit(-30.0, 3.0, "rover")]))
    assert b.should_cancel(_view(hits=[Hit(-30.0, 1.2, "rover")]))


# A ring of rovers 3 m away all round: the way is blocked by rovers, not by anything that stays.
RINGED_BY_ROVERS = tuple(Hit(a, 3.0, "rover") for a in range(-105, 106, 5))
# Near the goal, where a knot is the team at it and no route goes round it (far from it one does: below).
AT_GOAL = _goal(0.0, 15.0)


def test_blocked_by_rovers_the_rover_waits_and_looks_about_rather_than_giving_up():
    b = _behaviour(AT_GOAL)
    decisions = [b.decide(_view(AT_GOAL, hits=RINGED_BY_ROVERS, time=t)) for t in range(60)]
    assert Finish("stuck") not in decisions
    assert any(isinstance(d, Hold) for d in decisions) and any(isinstance(d, Rotate) for d in decisions)
    stuck = b.decide(_view(AT_GOAL, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1))
    assert stuck == Finish("stuck") and stuck.why == "held up by other rovers for 90 s"


def test_held_up_by_rovers_within_the_perception_radius_of_a_waypoint_a_rover_is_at_it():
    """Kept out of its station by the team for the jam's whole time, but within the radius within which a rover
    is at a waypoint the team shares: reached, not stuck."""
    near = Goal(0, 1, "waypoint", 0.0, 0.95 * PARAMS.perception.perception_radius, shared=True)
    b = _behaviour(near)
    assert b.decide(_view(goal=near, hits=RINGED_BY_ROVERS, time=0.0)) != Finish("reached")
    assert b.decide(_view(goal=near, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1)) == Finish("reached")
    # on the way to a spot of its own (a spoke's foot, the lander), the same wait ends in giving up
    own = _goal(0.0, 0.95 * PARAMS.perception.perception_radius)
    b = _behaviour(own)
    b.decide(_view(goal=own, hits=RINGED_BY_ROVERS, time=0.0))
    assert b.decide(_view(goal=own, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1)) == Finish("stuck")


def test_held_up_by_rovers_a_rover_unsure_of_its_pose_counts_the_radius_as_far_as_it_can_tell():
    """Its estimate puts a shared waypoint just beyond the radius, but it may be off by more than that: for all
    the rover can tell it is at the waypoint, where the team keeps it out; sure of its pose, it is not."""
    beyond = Goal(0, 1, "waypoint", 0.0, 1.05 * PARAMS.perception.perception_radius, shared=True)
    ends = {}
    for std in (0.0, 2.0):
        b = _behaviour(beyond)
        b.decide(replace(_view(goal=beyond, hits=RINGED_BY_ROVERS, time=0.0), position_std_m=std))
        ends[std] = b.decide(replace(_view(goal=beyond, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1),
                                     position_std_m=std))
    assert ends == {0.0: Finish("stuck"), 2.0: Finish("reached")}


def test_getting_closer_to_the_goal_ends_the_wait_in_a_crowd():
    b = _behaviour()
    b.decide(_view(hits=RINGED_BY_ROVERS, time=0.0))
    b.moved(2.0)
    closer = Pose(0.0, 2.0, 0.0)
    assert b.decide(_view(pose=closer, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1)) != Finish("stuck")


def test_walking_to_and_fro_among_rovers_is_no_way_through_a_jam():
    """Moves that get the rover no closer (aside and back, across and back) leave the jam's clock running: a knot
    that never clears ends in a clear 'stuck', not in a rover pacing among the others for ever."""
    b = _behaviour(AT_GOAL)
    b.decide(_view(AT_GOAL, hits=RINGED_BY_ROVERS, time=0.0))
    for k in range(1, 9):
        b.moved(2.0)
        b.decide(_view(AT_GOAL, pose=Pose(2.0 * (k % 2), 0.0, 0.0), hits=RINGED_BY_ROVERS, time=10.0 * k))
    stuck = b.decide(_view(AT_GOAL, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1))
    assert stuck == Finish("stuck") and stuck.why == "held up by other rovers for 90 s"


def test_only_turning_among_rovers_does_not_outlast_a_jam_but_moving_now_and_then_does():
    """Turns to a goal or a route's corner behind the rover are not counted as blocked while rovers hold it up:
    packed among rovers whose bodies hid the ground, a rover's route corner flipped from side to side and it
    turned to and fro for the rest of the mission. Past the jam's time, turning alone ends it; a rover that
    still moves now and then is left to get through."""
    facing_away = Pose(0.0, 0.0, 180.0)
    b = _behaviour(AT_GOAL)
    b.decide(_view(AT_GOAL, hits=RINGED_BY_ROVERS, time=0.0))
    for k in range(MAX_BLOCKED_ROTATIONS):
        assert isinstance(b.decide(_view(AT_GOAL, pose=facing_away, time=MAX_CROWD_WAIT_S + k)), Rotate)
    stuck = b.decide(_view(AT_GOAL, pose=facing_away, time=MAX_CROWD_WAIT_S + MAX_BLOCKED_ROTATIONS))
    assert stuck == Finish("stuck") and stuck.why == "held up by other rovers for 90 s"
    moving = _behaviour(AT_GOAL)
    moving.decide(_view(AT_GOAL, hits=RINGED_BY_ROVERS, time=0.0))
    for k in range(2 * MAX_BLOCKED_ROTATIONS):
        if k % 4 == 3:
            moving.moved(PARAMS.behaviour.min_move_size)
        assert isinstance(moving.decide(_view(AT_GOAL, pose=facing_away, time=MAX_CROWD_WAIT_S + k)), Rotate)


def test_walking_away_from_where_a_jam_began_ends_it():
    """A way round the rovers may lead away from the goal (a maze's does): with the jam left behind, a later
    crowd is a new jam, not the old one timed out."""
    b = _behaviour()
    b.decide(_view(hits=RINGED_BY_ROVERS, time=0.0))
    away = Pose(8.0, 0.0, 0.0)
    assert isinstance(b.decide(_view(pose=away, time=20.0)), MoveTo)
    assert b.decide(_view(pose=away, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1)) != Finish("stuck")


def test_behind_a_rover_that_leaves_a_short_step_a_rover_with_heading_noise_waits_a_little_rather_than_creeps():
    """Every move turns the heading a little whatever its length, and the error swings the rest of the way: a rover
    creeping behind a queue in short steps ends metres off. With heading noise it waits for the rover ahead a few
    times, then takes the short step; without, creeping costs nothing and it steps at once."""
    ahead = (Hit(0.0, 6.0, "rover"),)  # a rover 6 m ahead: 3 m free of the 9 m the rover wants
    noisy = PARAMS.model_copy(update={"navigation": PARAMS.navigation.model_copy(
        update={"heading_noise_std_deg": 0.3})})
    b = DefaultBehaviour(1, noisy)
    b.start_goal(_goal())
    t = 0.0
    for _ in range(FOLLOW_WAITS):
        wait = b.decide(_view(hits=ahead, time=t))
        assert isinstance(wait, Hold)
        t = wait.until
    assert isinstance(b.decide(_view(hits=ahead, time=t)), MoveTo)  # waited enough: the short step
    assert isinstance(_behaviour().decide(_view(hits=ahead)), MoveTo)  # no heading noise: no wait
    rock = (Hit(0.0, 6.0, "obstacle"),)
    assert isinstance(DefaultBehaviour(1, noisy).decide(_view(hits=rock)), MoveTo)  # rocks do not move on


# Rovers packed across the way ahead (a knot in a corridor, or one rover head on in a gap): room only to the sides.
HEAD_ON = tuple(Hit(a, 1.8, "rover") for a in range(-50, 51, 5))


def test_long_held_up_by_rovers_a_rover_steps_aside_to_let_them_by_and_waits_for_them():
    """The mechanism of a knot: rovers that block each other each wait for the others to move, until all give
    up. Long held up, a rover turns round if it must, steps away from the knot, then waits there a while."""
    b, t, decision = _behaviour(AT_GOAL), 0.0, None
    while t <= GIVE_WAY_S:
        decision = b.decide(_view(AT_GOAL, hits=HEAD_ON, time=t))
        assert not isinstance(decision, MoveTo) and decision != Finish("stuck")
        t += 0.5
    while decision != Rotate(180.0) and t < GIVE_WAY_S + 10.0:
        decision = b.decide(_view(AT_GOAL, hits=HEAD_ON, time=t))
        t += 0.5
    assert decision == Rotate(180.0)  # no room to the sides in view: turn round, and step away from the knot
    behind = Pose(0.0, 0.0, 180.0)
    step = b.decide(_view(AT_GOAL, pose=behind, time=t))
    assert isinstance(step, MoveTo) and step.slow and abs(_angle(step)) < 1.0  # straight away from the knot
    assert math.hypot(step.x, step.z) == pytest.approx(PARAMS.behaviour.min_move_size, abs=1e-3)
    b.moved(PARAMS.behaviour.min_move_size)
    assert b.decide(_view(AT_GOAL, pose=behind, time=t + GIVE_WAY_HOLD_S - 1.0)) == Hold(t + GIVE_WAY_HOLD_S)
    assert isinstance(b.decide(_view(AT_GOAL, pose=behind, time=t + GIVE_WAY_HOLD_S)), Rotate)  # then back to the goal
    # A step aside is no progress: still held up, the rover gives up when the jam's time is out.
    stuck = b.decide(_view(AT_GOAL, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1))
    assert stuck == Finish("stuck") and "held up by other rovers" in stuck.why


def test_long_held_up_by_rovers_on_the_way_a_rover_plans_a_route_round_them():
    """Along a wall's long side a team splits, each rover's map tipping it to one end or the other, and rovers
    going either way met head on and waited for each other until they gave up. Long held up on the way, a rover
    plans round the rovers in view instead; near the goal, where they are the team at it, it does not."""
    b, t = _behaviour(), 0.0
    while t <= CROWD_SQUEEZE_S + 1.0:
        b.decide(_view(hits=HEAD_ON, time=t))
        t += 0.5
    view = _view(hits=HEAD_ON, time=t)
    corner = b._route_point(view)
    assert b._routing and corner is not None
    knot = [ray_point(ORIGIN, h.angle_deg, h.distance_m + PARAMS.behaviour.rover_radius) for h in HEAD_ON]
    assert min(math.dist(corner, rover) for rover in knot) > 2 * PARAMS.behaviour.rover_radius
    assert b._rovers_in_way(view, 1.0)
    # turned away, it still keeps clear of them for a while (which rovers are in view changes as it turns)
    assert b._rovers_in_way(_view(time=t + KNOT_MEMORY_S - 1.0), 1.0)
    assert not b._rovers_in_way(_view(time=t + KNOT_MEMORY_S + 1.0), 1.0)
    near = _behaviour(AT_GOAL)
    for k in range(int(CROWD_SQUEEZE_S * 2) + 2):
        near.decide(_view(AT_GOAL, hits=HEAD_ON, time=k * 0.5))
    assert not near._rovers_in_way(_view(AT_GOAL, hits=HEAD_ON, time=t), 1.0)


def _turned_to_give_way(b: DefaultBehaviour) -> float:
    """Hold up ``b`` in a knot until it turns round to step aside; the time of the turn."""
    t, decision = 0.0, None
    while decision != Rotate(180.0):
        assert t < GIVE_WAY_S + 10.0
        decision = b.decide(_view(AT_GOAL, hits=HEAD_ON, time=t))
        t += 0.5
    return t


def test_a_step_aside_the_world_refuses_is_not_tried_again_and_the_next_move_is_no_step_aside():
    b = _behaviour(AT_GOAL)
    t = _turned_to_give_way(b)
    behind = Pose(0.0, 0.0, 180.0)
    step = b.decide(_view(AT_GOAL, pose=behind, time=t))
    b.rejected(_angle(step))
    b.moved(0.0)
    assert b._hold_until < t + 1.0  # a refused step is no step aside: no long wait after it
    b._turned_aside = True  # as after the next try's turn
    again = b.decide(_view(AT_GOAL, pose=behind, time=t + 0.5))
    assert isinstance(again, MoveTo) and abs(_angle(again) - _angle(step)) > 5.0


def test_a_step_aside_cut_short_by_a_rover_still_waits_its_while():
    b = _behaviour(AT_GOAL)
    t = _turned_to_give_way(b)
    b.decide(_view(AT_GOAL, pose=Pose(0.0, 0.0, 180.0), time=t))
    b.moved(0.8)  # the world cancelled it part way (NavigationFeedback: moved, then cancelled)
    b.cancelled(t + 0.5)
    assert b._hold_until == pytest.approx(t + GIVE_WAY_HOLD_S)  # rover 1: the plain hold, from the step


def test_nearer_a_wall_than_a_move_keeps_the_rover_first_steps_straight_away_from_it():
    """A slip, or a wall just beyond view when a step began, can leave a rover nearer a wall than any move keeps
    from it. From there every direction along the wall was blocked, and turning to look for a way came back to
    the same three headings until the rover gave up, a few metres from the wall's end."""
    wall = tuple(Hit(a, round(0.7 / math.cos(math.radians(a)), 3), "obstacle") for a in range(-60, 61, 5))
    b = _behaviour()
    assert b.decide(_view(hits=wall)) == Rotate(-180.0)  # its back to the wall first, which then is out of view
    half = PARAMS.behaviour.min_move_size / 2
    assert b.decide(_view(pose=Pose(0.0, 0.0, 180.0))) == MoveTo(0.0, half, True)
    beside = (Hit(-100.0, 0.7, "obstacle"),)  # behind the left shoulder: straight away is in the window
    step = _behaviour().decide(_view(hits=beside))
    assert isinstance(step, MoveTo) and step.slow and _angle(step) == pytest.approx(80.0, abs=0.01)
    assert math.hypot(step.x, step.z) == pytest.approx(half, abs=1e-3)
    clear = (Hit(-100.0, 2.0, "obstacle"),)  # as far as a move keeps: nothing to step off
    assert _behaviour().decide(_view(hits=clear)) == MoveTo(0.0, 0.9 * RADIUS)


def test_a_rover_pacing_without_getting_closer_gives_up():
    b = _behaviour()
    assert isinstance(b.decide(_view()), MoveTo)  # 50 m from the goal
    walked = 0.0
    while walked <= NO_PROGRESS_WALK_M:
        b.moved(9.0)
        walked += 9.0
        pose = Pose(0.0, -5.0 if int(walked) % 2 else 0.0, 0.0)  # back and forth, never nearer
        decision = b.decide(_view(pose=pose))
        if walked <= NO_PROGRESS_WALK_M:
            assert decision != Finish("stuck")
    assert decision == Finish("stuck") and "without getting closer" in decision.why


def test_a_rover_pacing_along_a_wall_starts_routing_before_it_gives_up():
    b = _behaviour()
    b.decide(_view())
    walked = 0.0
    while not b._routing and walked < NO_PROGRESS_WALK_M:
        b.moved(9.0)
        walked += 9.0
        assert b.decide(_view(pose=Pose(0.0, -5.0 if int(walked) % 2 else 0.0, 0.0))) != Finish("stuck")
    assert NO_PROGRESS_ROUTE_M < walked <= NO_PROGRESS_ROUTE_M + 9.0


# ---- stations at a shared waypoint ----


def _station_goal(station=(4.0, 0.0)) -> Goal:
    return Goal(0, 1, "waypoint", 0.0, 20.0, station)


def test_a_rover_walks_to_its_station_not_to_the_waypoint():
    goal = _station_goal()
    move = _behaviour(goal).decide(_view(goal, pose=Pose(4.0, 12.0, 0.0)))
    assert move == MoveTo(0.0, 2.0)  # short steps when parking


def test_the_station_is_reached_close_to_it_not_merely_in_view_of_the_waypoint():
    goal = _station_goal()
    assert _behaviour(goal).decide(_view(goal, pose=Pose(4.0, 20.0 - STATION_CLOSE_M, 0.0))) == Finish("reached")
    assert isinstance(_behaviour(goal).decide(_view(goal, pose=Pose(4.0, 15.0, 0.0))), MoveTo)


def test_a_station_walled_in_by_rovers_for_a_while_counts_as_reached_with_the_waypoint_in_view():
    goal = _station_goal()
    wall = [Hit(a, 1.6, "rover") for a in range(-60, 61, 5)]
    behaviour, here = _behaviour(goal), Pose(4.0, 14.0, 0.0)
    assert behaviour.decide(_view(goal, pose=here, hits=wall)) != Finish("reached")  # they may be passing
    assert behaviour.decide(_view(goal, pose=here, hits=wall, time=CROWD_SQUEEZE_S)) == Finish("reached")
    far = _station_goal((4.0, -15.0))  # the waypoint itself out of view: keep trying
    behaviour = _behaviour(far)
    for t in (0.0, CROWD_SQUEEZE_S):
        assert behaviour.decide(_view(far, pose=Pose(4.0, -3.0, 180.0), hits=wall, time=t)) != Finish("reached")


def test_a_rover_crossing_the_way_to_a_station_does_not_end_the_walk_short_of_it():
    """The mechanism of a 20-rover jam: rovers that stopped at the first rover across their way to a station
    stood in a ring short of the formation and walled the later ones out. A crowd must stand in the way, on and
    off, for a while; stepping round it meanwhile does not start the wait afresh."""
    goal = _station_goal((0.0, 0.0))
    behaviour, here = _behaviour(goal), Pose(0.0, 12.0, 0.0)
    passing = (Hit(-5.0, 1.6, "rover"), Hit(0.0, 1.5, "rover"), Hit(5.0, 1.6, "rover"))
    assert behaviour.decide(_view(goal, pose=here, hits=passing)) != Finish("reached")
    assert isinstance(behaviour.decide(_view(goal, pose=here, time=1.0)), MoveTo)  # it has gone: on to the station
    behaviour.moved(2.0)
    later = Pose(0.0, 11.0, 0.0)
    assert behaviour.decide(_view(goal, pose=later, hits=passing, time=CROWD_SQUEEZE_S - 1.0)) != Finish("reached")
    assert behaviour.decide(_view(goal, pose=later, hits=passing, time=CROWD_SQUEEZE_S + 1.0)) == Finish("reached")
    plain = _goal(0.0, 20.0)  # no station (the report's rule): in view and crowded is reached at once
    assert _behaviour(plain).decide(_view(plain, pose=here, hits=passing)) == Finish("reached")


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
    b = _behaviour(goal)
    here = Pose(tx, tz - off_m, 0.0)
    decisions = []
    for step in range(8):  # round and round: 24 m walked, never nearer
        decisions.append(b.decide(_view(goal, pose=here, time=float(step))))
        b.moved(3.0)
    assert (Finish(outcome) in decisions) is holds
    assert Finish(outcome) not in decisions[:int(NO_PROGRESS_ROUTE_M // 3) + 1]  # not before it has tried


# ---- crater climb ----

CRATER_AHEAD = (Hit(0.0, 8.0, "crater_terrain"),)


def _crater_view(pitch, hits=CRATER_AHEAD, goal=None):
    return _view(goal or _goal(0.0, 60.0, kind="crater"), hits=hits, pitch=pitch)


RELAYED_CRATER = Goal(0, 1, "crater", 0.0, 60.0, relayed=True)  # a daisy chain stands for it


def _on_crest(b, decision) -> bool:
    """The rover judged itself on the crest: it starts observing with a first photo."""
    return isinstance(decision, TakePhoto) and b.state == "observing"


def test_crater_climb_finishes_on_the_crest_only_after_walking_the_perception_radius():
    b = _behaviour(_goal(0.0, 60.0, kind="crater"))
    first = b.decide(_crater_view(pitch=0.0))
    assert b.state == "climbing"
    assert first == MoveTo(0.0, PARAMS.behaviour.min_move_size)  # small steps while climbing
    b.moved(2.0)
    assert isinstance(b.decide(_crater_view(pitch=3.0, hits=())), MoveTo)  # up the rim
    b.moved(2.0)
    # flat again after only 4 m: a local optimum, not the crest (report 7.2.2)
    assert not _on_crest(b, b.decide(_crater_view(pitch=0.3, hits=())))
    b.moved(5.9)
    assert not _on_crest(b, b.decide(_crater_view(pitch=0.3, hits=())))  # 9.9 m < 10 m
    b.moved(0.1)
    assert not _on_crest(b, b.decide(_crater_view(pitch=1.0, hits=())))  # still climbing
    assert _on_crest(b, b.decide(_crater_view(pitch=0.5, hits=())))


def test_crater_climb_needs_a_real_climb():
    b = _behaviour(_goal(0.0, 60.0, kind="crater"))
    b.decide(_crater_view(pitch=0.0))
    b.moved(20.0)
    assert not _on_crest(b, b.decide(_crater_view(pitch=1.9, hits=())))  # never above 2 deg
    assert not _on_crest(b, b.decide(_crater_view(pitch=0.0, hits=())))


def test_distance_walked_before_seeing_the_crater_does_not_count():
    b = _behaviour(_goal(0.0, 60.0, kind="crater"))
    b.moved(50.0)
    assert not _on_crest(b, b.decide(_crater_view(pitch=3.0)))
    b.moved(5.0)
    assert not _on_crest(b, b.decide(_crater_view(pitch=0.0, hits=())))
    b.moved(5.0)
    assert _on_crest(b, b.decide(_crater_view(pitch=0.0, hits=())))


def test_a_new_goal_forgets_the_climb():
    b = _behaviour(_goal(0.0, 60.0, kind="crater"))
    b.decide(_crater_view(pitch=3.0))
    b.moved(12.0)
    b.start_goal(_goal(0.0, 60.0, kind="crater", index=1, total=2))
    assert b.state == "migration"
    assert not _on_crest(b, b.decide(_crater_view(pitch=0.0, hits=())))


def test_a_step_over_the_crest_turns_a_relayed_rover_round_and_back_onto_it():
    goal = RELAYED_CRATER
    b = _behaviour(goal)
    b.decide(_crater_view(pitch=0.0, goal=goal))
    b.moved(2.0)
    b.decide(_crater_view(pitch=9.0, hits=(), goal=goal))  # up the outer rim, a whole step
    b.moved(2.0)
    # 4 m from first seeing the crater and pitched down the bowl's wall: over the crest, out of the chain's sight
    assert b.decide(_crater_view(pitch=-BOWL_PITCH - 2, hits=(), goal=goal)) == Rotate(180.0)
    assert b.decide(_view(goal, pose=Pose(0.0, 0.0, 180.0), pitch=15.0)) == MoveTo(
        0.0, PARAMS.behaviour.min_move_size / 2)  # one short step out of the bowl, facing away
    b.moved(1.0)
    # facing the crater again the pitch is still down the wall but no longer steep: observe from here
    assert _on_crest(b, b.decide(_crater_view(pitch=-2.0, hits=(), goal=goal)))


def test_a_step_over_the_crest_is_taken_back_with_or_without_a_chain():
    """A narrow rim's crest is a step wide: a rover on the bowl's wall is not on it (the report's rover stayed)."""
    goal = _goal(0.0, 60.0, kind="crater")
    b = _behaviour(goal)
    b.decide(_crater_view(pitch=9.0))
    b.moved(2.0)  # not yet a perception radius past the first crater terrain: still over the crest
    assert b.decide(_crater_view(pitch=-BOWL_PITCH - 2, hits=())) == Rotate(180.0)
    assert b.decide(_view(goal, pose=Pose(0.0, 0.0, 180.0), pitch=15.0)) == MoveTo(
        0.0, PARAMS.behaviour.min_move_size / 2)
    b.moved(1.0)
    assert _on_crest(b, b.decide(_crater_view(pitch=-2.0, hits=())))


def test_a_rover_held_up_on_the_rim_by_rovers_on_the_crest_observes_from_there():
    """Rovers done on the crest stay there: one come later, up the rim and facing the crater, that they have
    long left no step towards it is a body or two from the crest, not stuck."""
    goal = _goal(0.0, 60.0, kind="crater")
    wall = (*CRATER_AHEAD, *(Hit(a, 1.4, "rover") for a in range(-100, 101, 4)))
    b = _behaviour(goal)
    b.decide(_crater_view(pitch=9.0))  # the rim: crater terrain ahead, climbing
    b.moved(2.0)
    held = [b.decide(_view(goal, hits=wall, pitch=9.0, time=t)) for t in (0.0, 5.0, 10.0)]
    assert Finish("reached") not in held  # a moment's jam is waited out, not taken for the crest
    assert _on_crest(b, b.decide(_view(goal, hits=wall, pitch=9.0, time=CROWD_SQUEEZE_S + 1)))


def test_a_rover_never_steps_back_out_of_the_bowl_more_than_a_few_times():
    b = _behaviour(RELAYED_CRATER)
    b.decide(_crater_view(pitch=9.0, goal=RELAYED_CRATER))
    steep = _crater_view(pitch=-BOWL_PITCH - 5, hits=(), goal=RELAYED_CRATER)  # every step back refused
    for _ in range(MAX_BACKS):
        assert b.decide(steep) == Rotate(180.0)
        assert isinstance(b.decide(steep), MoveTo)
    assert _on_crest(b, b.decide(steep))  # then it observes from there rather than turn for ever


def test_a_rover_right_behind_keeps_a_relayed_rover_on_the_wall():
    b = _behaviour(RELAYED_CRATER)
    b.decide(_crater_view(pitch=9.0, goal=RELAYED_CRATER))
    assert b.decide(_crater_view(pitch=-BOWL_PITCH - 2, hits=(), goal=RELAYED_CRATER)) == Rotate(180.0)
    behind = _view(RELAYED_CRATER, pose=Pose(0.0, 0.0, 180.0), hits=(Hit(0.0, 1.6, "rover"),), pitch=15.0)
    assert not isinstance(b.decide(behind), MoveTo)  # no squeezing into it
    assert _on_crest(b, b.decide(_crater_view(pitch=-BOWL_PITCH - 2, hits=(), goal=RELAYED_CRATER)))


# ---- the agent ----

KEYS = ks.Keyspace("w")


def _feed(agent, message):
    topic = next(t for t, model in m.TOPIC_MODELS.items() if model is type(message))
    return agent.handle(topic, codec.encode(message))


def _ready_agent(x=0.0, z=20.0, heading=180.0, bearing=180.0, distance=100.0, kind="waypoint"):
    """An agent told where it stands and where to go (the goal 100 m south of the lander by default)."""
    agent = joined_agent(1, KEYS, PARAMS)
    assert _feed(agent, m.Calibration(x=x, z=z, heading_deg=heading)) == []
    out = _feed(agent, m.MissionDirection(goal_index=0, goals_total=1, kind=kind, bearing_deg=bearing,
                                          distance_m=distance))
    assert [key for key, _ in out] == [KEYS.rover(1, ks.STATUS)]
    assert out[0][1].state == "migration" and out[0][1].goal_index == 0
    return agent


def test_agent_emits_a_move_action_after_calibration_direction_gyroscope_and_perception():
    agent = _ready_agent()
    assert agent.pose == Pose(0.0, 20.0, 180.0)
    assert _feed(agent, m.Perception(stamp=0.05, angles_deg=[], distances_m=[], kinds=[])) == []  # no pitch yet
    assert _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0)) == []
    out = _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert len(out) == 1
    key, move = out[0]
    assert key == "lunar/w/rover/1/move_action"
    assert isinstance(move, m.MoveAction)
    assert move.x == pytest.approx(0.0, abs=1e-3) and move.z == pytest.approx(9.0)
    # one action in flight: further perception does not start another
    assert _feed(agent, m.Perception(stamp=0.4, angles_deg=[], distances_m=[], kinds=[])) == []


def test_agent_does_nothing_without_calibration_or_goal():
    agent = joined_agent(1, KEYS, PARAMS)
    _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0))
    assert _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[])) == []
    _feed(agent, m.Calibration(x=0.0, z=0.0, heading_deg=0.0))
    assert _feed(agent, m.Perception(stamp=0.3, angles_deg=[], distances_m=[], kinds=[])) == []


def _moving_agent():
    agent = _ready_agent()
    _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0))
    (key, _), = _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert key == KEYS.rover(1, ks.MOVE_ACTION)
    return agent


def test_completed_move_updates_the_pose_by_dead_reckoning():
    agent = _moving_agent()
    out = _feed(agent, m.NavigationStatus(stamp=0.6, action="move", remaining=4.0))
    assert out == [] and agent.pose == Pose(0.0, 20.0, 180.0)  # running: nothing changes yet
    assert _feed(agent, m.NavigationStatus(stamp=3.0, action="move", remaining=0.0, outcome="completed")) == []
    assert agent.in_flight is None
    assert agent.pose.x == pytest.approx(0.0, abs=1e-6)
    assert agent.pose.z == pytest.approx(11.0)
    assert agent.pose.heading == pytest.approx(180.0, abs=1e-6)


def test_agent_decides_again_only_on_data_taken_after_the_move():
    agent = _moving_agent()
    _feed(agent, m.NavigationStatus(stamp=3.0, action="move", remaining=0.0, outcome="completed"))
    assert _feed(agent, m.Perception(stamp=2.9, angles_deg=[], distances_m=[], kinds=[])) == []  # stale scan
    assert _feed(agent, m.Perception(stamp=3.1, angles_deg=[], distances_m=[], kinds=[])) == []  # stale pitch
    _feed(agent, m.Gyroscope(stamp=3.05, pitch_deg=0.0))
    out = _feed(agent, m.Perception(stamp=3.2, angles_deg=[], distances_m=[], kinds=[]))
    assert [key for key, _ in out] == [KEYS.rover(1, ks.MOVE_ACTION)]


def test_completed_rotate_updates_the_heading():
    agent = _ready_agent(bearing=0.0)  # goal north of the lander, behind a rover facing south
    _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0))
    (key, rotate), = _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert key == KEYS.rover(1, ks.ROTATE_ACTION) and abs(rotate.degrees) == pytest.approx(180.0)
    _feed(agent, m.NavigationStatus(stamp=2.0, action="rotate", remaining=0.0, outcome="completed"))
    assert ((agent.pose.heading + 180.0) % 360.0 - 180.0) == pytest.approx(0.0, abs=1e-6)
    assert (agent.pose.x, agent.pose.z) == (0.0, 20.0)


def test_rover_close_ahead_during_a_move_sends_one_cancel_and_the_result_sets_the_pose():
    agent = _moving_agent()
    rover_ahead = m.Perception(stamp=0.4, angles_deg=[0.0], distances_m=[2.0], kinds=["rover"])
    flight = agent.in_flight.action_id
    assert _feed(agent, rover_ahead) == [(KEYS.rover(1, ks.CANCEL_ACTION), m.CancelAction(action_id=flight))]
    assert _feed(agent, rover_ahead) == []  # once
    _feed(agent, m.NavigationStatus(stamp=0.6, action="move", remaining=0.0, outcome="cancelled"))
    assert agent.pose == Pose(0.0, 20.0, 180.0)
    _feed(agent, m.CancelResult(x=0.0, z=3.0, angle_deg=0.0))
    assert agent.in_flight is None
    assert agent.pose.x == pytest.approx(0.0, abs=1e-9) and agent.pose.z == pytest.approx(17.0)


def test_rover_to_the_side_during_a_move_does_not_cancel():
    agent = _moving_agent()
    assert _feed(agent, m.Perception(stamp=0.4, angles_deg=[90.0], distances_m=[2.0], kinds=["rover"])) == []


def test_rejected_move_settles_and_tries_another_direction():
    agent = _moving_agent()
    _feed(agent, m.ActionRejected(action="move", reason="blocked"))
    assert agent.in_flight is None
    _feed(agent, m.Gyroscope(stamp=0.3, pitch_deg=0.0))
    (key, move), = _feed(agent, m.Perception(stamp=0.4, angles_deg=[], distances_m=[], kinds=[]))
    assert key == KEYS.rover(1, ks.MOVE_ACTION)
    assert math.degrees(math.atan2(move.x, move.z)) == pytest.approx(10.0, abs=1e-3)


def test_reaching_the_final_waypoint_reports_to_the_lander():
    agent = _ready_agent(z=5.0, bearing=0.0, distance=10.0, heading=0.0)  # goal 5 m ahead
    _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0))
    out = _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert [key for key, _ in out] == [KEYS.rover(1, ks.COMM_OUT), KEYS.rover(1, ks.STATUS)]
    comm = out[0][1]
    assert comm.targets == [ks.LANDER_ID] and comm.channel == "comm_in"
    assert radio.unpack(comm.payload) == radio.GoalReport(goal_index=0, outcome="reached")
    assert out[1][1].state == "done" and agent.state == "done"
    assert _feed(agent, m.Perception(stamp=0.4, angles_deg=[], distances_m=[], kinds=[])) == []


def test_garbage_payloads_are_counted_and_answered_with_nothing():
    agent = _ready_agent()
    assert agent.handle(ks.PERCEPTION, b"\x93garbage") == []
    assert agent.handle(ks.GYROSCOPE, codec.encode(m.MoveAction(x=1.0, z=1.0))) == []
    assert agent.handle("no_such_topic", b"") == []
    assert agent.rejected.total == 3
    assert agent.pose == Pose(0.0, 20.0, 180.0)


def test_crater_crest_is_not_judged_while_facing_away_from_the_crater():
    goal = _goal(0.0, 60.0, kind="crater")
    b = _behaviour(goal)
    b.decide(_crater_view(pitch=3.0))
    b.moved(12.0)
    facing_away = _view(goal, pose=Pose(0.0, 20.0, 180.0), pitch=-3.0)  # downhill on the outer slope, back to it
    assert not _on_crest(b, b.decide(facing_away))


def test_on_the_rim_a_photo_every_30_degrees_once_round_then_done():
    b = _behaviour(_goal(0.0, 60.0, kind="crater"))
    b.state = "observing"
    view = _crater_view(pitch=0.0, hits=())
    decisions = [b.decide(view) for _ in range(23)]
    photos = [d for d in decisions if isinstance(d, TakePhoto)]
    assert len(photos) == 12 and decisions[0] == photos[0]
    assert [d for d in decisions if isinstance(d, Rotate)] == [Rotate(30.0)] * 11
    assert len({p.label for p in photos}) == 12 and photos[1].label == "goal1_030.0deg"
    assert b.decide(view) == Finish("reached")


def _station_requests(out, rover: int = 1) -> list[radio.StationRequest]:
    messages = [radio.unpack(msg.payload) for key, msg in out if key == KEYS.rover(rover, ks.COMM_OUT)]
    return [msg for msg in messages if isinstance(msg, radio.StationRequest)]


def test_near_a_shared_waypoint_the_agent_asks_for_its_station_until_it_comes():
    agent = joined_agent(1, KEYS, PARAMS)
    _feed(agent, m.Calibration(x=0.0, z=0.0, heading_deg=0.0))
    shared = {"goal_index": 0, "goals_total": 1, "kind": "waypoint", "bearing_deg": 0.0, "distance_m": 40.0,
              "shared": True}
    _feed(agent, m.MissionDirection(**shared))

    def perceive(stamp):
        return _station_requests(_feed(agent, m.Perception(stamp=stamp, angles_deg=[], distances_m=[], kinds=[])))

    assert perceive(0.2) == []  # 40 m away: not yet
    agent.pose = Pose(0.0, 40.0 - STATION_ASK_M + 1.0, 0.0)
    assert perceive(0.4) == [radio.StationRequest(goal_index=0, x=0.0, z=26.0)]
    assert perceive(0.6) == []  # not again at once...
    assert len(perceive(0.4 + STATION_ASK_RETRY_S)) == 1  # ...but again when no answer came
    _feed(agent, m.MissionDirection(**shared, station=(3.2, 0.0)))
    assert agent.goal.target == (3.2, 40.0)
    assert perceive(10.0) == []


def test_a_stuck_rover_says_why_in_its_status():
    agent = _ready_agent()
    statuses = []
    for k in range(3 * MAX_BLOCKED_ROTATIONS):
        t = 1.0 + k
        _feed(agent, m.Gyroscope(stamp=t, pitch_deg=0.0))
        out = _feed(agent, m.Perception(stamp=t + 0.05, angles_deg=[h.angle_deg for h in BOXED_IN],
                                        distances_m=[h.distance_m for h in BOXED_IN], kinds=[h.kind for h in BOXED_IN]))
        statuses += [msg for key, msg in out if key == KEYS.rover(1, ks.STATUS)]
        if agent.state == "stuck":
            break
        assert agent.in_flight is not None  # a rotation: the world says it is done
        _feed(agent, m.NavigationStatus(stamp=t + 0.1, action="rotate", remaining=0.0, outcome="completed",
                                        action_id=agent.in_flight.action_id))
    assert statuses and statuses[-1].state == "stuck"
    assert statuses[-1].detail.endswith("without finding a free way")


def test_the_agent_asks_for_a_crest_station_once_crater_terrain_is_in_view_or_from_inside_the_bowl():
    """The rover does not know the crater's size: it asks once the crater's terrain is in view, however far from
    the goal. Inside the bowl it sees no rim ahead (a crater's terrain shows where a ray enters it), and without a
    station it would walk to and fro across the goal for ever: near the goal, it asks by the distance."""
    agent = joined_agent(1, KEYS, PARAMS)
    _feed(agent, m.Calibration(x=0.0, z=0.0, heading_deg=0.0))
    _feed(agent, m.MissionDirection(goal_index=0, goals_total=1, kind="crater", bearing_deg=0.0, distance_m=60.0,
                                    shared=True))
    nothing = m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[])
    agent.pose = Pose(0.0, 30.0, 0.0)  # 30 m out, nothing of the crater in view
    assert _station_requests(_feed(agent, nothing)) == []
    seen = m.Perception(stamp=0.4, angles_deg=[0.0], distances_m=[8.0], kinds=["crater_terrain"])
    assert _station_requests(_feed(agent, seen)) == [radio.StationRequest(goal_index=0, x=0.0, z=30.0)]
    inside = joined_agent(2, KEYS, PARAMS)
    _feed(inside, m.Calibration(x=0.0, z=0.0, heading_deg=0.0))
    _feed(inside, m.MissionDirection(goal_index=0, goals_total=1, kind="crater", bearing_deg=0.0, distance_m=60.0,
                                     shared=True))
    inside.pose = Pose(0.0, 55.0, 0.0)  # in the bowl, 5 m from the goal: no rim in view
    out = _feed(inside, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert _station_requests(out, rover=2) == [radio.StationRequest(goal_index=0, x=0.0, z=55.0)]
