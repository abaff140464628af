"""Among rovers (``rover_agent.rules.crowd``), through the default behaviour with scripted views: waiting for
rovers rather than giving up, what ends a jam, following, stepping aside, and routes round a knot."""

from __future__ import annotations

import math
from dataclasses import replace

import msgspec
import pytest
from agent_kit import ORIGIN, PARAMS, angle_of, fresh_behaviour, goal_at, view_of

from rover_agent.behaviour import DefaultBehaviour
from rover_agent.decisions import Finish, Goal, Hit, Hold, MoveTo, Rotate
from rover_agent.rules.occupancy import ray_point
from rover_agent.rules.tuning import (
    CROWD_SQUEEZE_S,
    FOLLOW_WAITS,
    GIVE_WAY_HOLD_S,
    GIVE_WAY_S,
    KNOT_MEMORY_S,
    MAX_BLOCKED_ROTATIONS,
    MAX_CROWD_WAIT_S,
)
from shared.pose import Pose

# A ring of rovers 3 m away all round: the way is blocked by rovers, not by anything that stays.
RINGED_BY_ROVERS = tuple(Hit(a, 3.0, "rover") for a in range(-105, 106, 5))


# Near the goal, where a knot is the team at it and no route goes round it (far from it one does: below).
AT_GOAL = goal_at(0.0, 15.0)


def test_blocked_by_rovers_the_rover_waits_and_looks_about_rather_than_giving_up():
    b = fresh_behaviour(AT_GOAL)
    decisions = [b.decide(view_of(AT_GOAL, hits=RINGED_BY_ROVERS, time=t)) for t in range(60)]
    assert Finish("stuck") not in decisions
    assert any(isinstance(d, Hold) for d in decisions) and any(isinstance(d, Rotate) for d in decisions)
    stuck = b.decide(view_of(AT_GOAL, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1))
    assert stuck == Finish("stuck") and stuck.why == "held up by other rovers for 90 s"


def test_held_up_by_rovers_within_the_perception_radius_of_a_waypoint_a_rover_is_at_it():
    """Kept out of its station by the team for the jam's whole time, but within the radius within which a rover
    is at a waypoint the team shares: reached, not stuck."""
    near = Goal(0, 1, "waypoint", 0.0, 0.95 * PARAMS.perception.perception_radius, shared=True)
    b = fresh_behaviour(near)
    assert b.decide(view_of(goal=near, hits=RINGED_BY_ROVERS, time=0.0)) != Finish("reached")
    assert b.decide(view_of(goal=near, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1)) == Finish("reached")
    # on the way to a spot of its own (a spoke's foot, the lander), the same wait ends in giving up
    own = goal_at(0.0, 0.95 * PARAMS.perception.perception_radius)
    b = fresh_behaviour(own)
    b.decide(view_of(goal=own, hits=RINGED_BY_ROVERS, time=0.0))
    assert b.decide(view_of(goal=own, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1)) == Finish("stuck")


def test_held_up_by_rovers_a_rover_unsure_of_its_pose_counts_the_radius_as_far_as_it_can_tell():
    """Its estimate puts a shared waypoint just beyond the radius, but it may be off by more than that: for all
    the rover can tell it is at the waypoint, where the team keeps it out; sure of its pose, it is not."""
    beyond = Goal(0, 1, "waypoint", 0.0, 1.05 * PARAMS.perception.perception_radius, shared=True)
    ends = {}
    for std in (0.0, 2.0):
        b = fresh_behaviour(beyond)
        b.decide(replace(view_of(goal=beyond, hits=RINGED_BY_ROVERS, time=0.0), position_std_m=std))
        ends[std] = b.decide(replace(view_of(goal=beyond, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1),
                                     position_std_m=std))
    assert ends == {0.0: Finish("stuck"), 2.0: Finish("reached")}


def test_getting_closer_to_the_goal_ends_the_wait_in_a_crowd():
    b = fresh_behaviour()
    b.decide(view_of(hits=RINGED_BY_ROVERS, time=0.0))
    b.moved(2.0)
    closer = Pose(0.0, 2.0, 0.0)
    assert b.decide(view_of(pose=closer, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1)) != Finish("stuck")


def test_walking_to_and_fro_among_rovers_is_no_way_through_a_jam():
    """Moves that get the rover no closer (aside and back, across and back) leave the jam's clock running: a knot
    that never clears ends in a clear 'stuck', not in a rover pacing among the others for ever."""
    b = fresh_behaviour(AT_GOAL)
    b.decide(view_of(AT_GOAL, hits=RINGED_BY_ROVERS, time=0.0))
    for k in range(1, 9):
        b.moved(2.0)
        b.decide(view_of(AT_GOAL, pose=Pose(2.0 * (k % 2), 0.0, 0.0), hits=RINGED_BY_ROVERS, time=10.0 * k))
    stuck = b.decide(view_of(AT_GOAL, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1))
    assert stuck == Finish("stuck") and stuck.why == "held up by other rovers for 90 s"


def test_only_turning_among_rovers_does_not_outlast_a_jam_but_moving_now_and_then_does():
    """Turns to a goal or a route's corner behind the rover are not counted as blocked while rovers hold it up:
    packed among rovers whose bodies hid the ground, a rover's route corner flipped from side to side and it
    turned to and fro for the rest of the mission. Past the jam's time, turning alone ends it; a rover that
    still moves now and then is left to get through."""
    facing_away = Pose(0.0, 0.0, 180.0)
    b = fresh_behaviour(AT_GOAL)
    b.decide(view_of(AT_GOAL, hits=RINGED_BY_ROVERS, time=0.0))
    for k in range(MAX_BLOCKED_ROTATIONS):
        assert isinstance(b.decide(view_of(AT_GOAL, pose=facing_away, time=MAX_CROWD_WAIT_S + k)), Rotate)
    stuck = b.decide(view_of(AT_GOAL, pose=facing_away, time=MAX_CROWD_WAIT_S + MAX_BLOCKED_ROTATIONS))
    assert stuck == Finish("stuck") and stuck.why == "held up by other rovers for 90 s"
    moving = fresh_behaviour(AT_GOAL)
    moving.decide(view_of(AT_GOAL, hits=RINGED_BY_ROVERS, time=0.0))
    for k in range(2 * MAX_BLOCKED_ROTATIONS):
        if k % 4 == 3:
            moving.moved(PARAMS.behaviour.min_move_size)
        assert isinstance(moving.decide(view_of(AT_GOAL, pose=facing_away, time=MAX_CROWD_WAIT_S + k)), Rotate)


def test_walking_away_from_where_a_jam_began_ends_it():
    """A way round the rovers may lead away from the goal (a maze's does): with the jam left behind, a later
    crowd is a new jam, not the old one timed out."""
    b = fresh_behaviour()
    b.decide(view_of(hits=RINGED_BY_ROVERS, time=0.0))
    away = Pose(8.0, 0.0, 0.0)
    assert isinstance(b.decide(view_of(pose=away, time=20.0)), MoveTo)
    assert b.decide(view_of(pose=away, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1)) != Finish("stuck")


def test_behind_a_rover_that_leaves_a_short_step_a_rover_with_heading_noise_waits_a_little_rather_than_creeps():
    """Every move turns the heading a little whatever its length, and the error swings the rest of the way: a rover
    creeping behind a queue in short steps ends metres off. With heading noise it waits for the rover ahead a few
    times, then takes the short step; without, creeping costs nothing and it steps at once."""
    ahead = (Hit(0.0, 6.0, "rover"),)  # a rover 6 m ahead: 3 m free of the 9 m the rover wants
    noisy = msgspec.structs.replace(PARAMS, navigation=msgspec.structs.replace(PARAMS.navigation,
                                                                               heading_noise_std_deg=0.3))
    b = DefaultBehaviour(1, noisy)
    b.start_goal(goal_at())
    t = 0.0
    for _ in range(FOLLOW_WAITS):
        wait = b.decide(view_of(hits=ahead, time=t))
        assert isinstance(wait, Hold)
        t = wait.until
    assert isinstance(b.decide(view_of(hits=ahead, time=t)), MoveTo)  # waited enough: the short step
    assert isinstance(fresh_behaviour().decide(view_of(hits=ahead)), MoveTo)  # no heading noise: no wait
    rock = (Hit(0.0, 6.0, "obstacle"),)
    assert isinstance(DefaultBehaviour(1, noisy).decide(view_of(hits=rock)), MoveTo)  # rocks do not move on


# Rovers packed across the way ahead (a knot in a corridor, or one rover head on in a gap): room only to the sides.
HEAD_ON = tuple(Hit(a, 1.8, "rover") for a in range(-50, 51, 5))


def test_long_held_up_by_rovers_a_rover_steps_aside_to_let_them_by_and_waits_for_them():
    """The mechanism of a knot: rovers that block each other each wait for the others to move, until all give
    up. Long held up, a rover turns round if it must, steps away from the knot, then waits there a while."""
    b, t, decision = fresh_behaviour(AT_GOAL), 0.0, None
    while t <= GIVE_WAY_S:
        decision = b.decide(view_of(AT_GOAL, hits=HEAD_ON, time=t))
        assert not isinstance(decision, MoveTo) and decision != Finish("stuck")
        t += 0.5
    while decision != Rotate(180.0) and t < GIVE_WAY_S + 10.0:
        decision = b.decide(view_of(AT_GOAL, hits=HEAD_ON, time=t))
        t += 0.5
    assert decision == Rotate(180.0)  # no room to the sides in view: turn round, and step away from the knot
    behind = Pose(0.0, 0.0, 180.0)
    step = b.decide(view_of(AT_GOAL, pose=behind, time=t))
    assert isinstance(step, MoveTo) and step.slow and abs(angle_of(step)) < 1.0  # straight away from the knot
    assert math.hypot(step.x, step.z) == pytest.approx(PARAMS.behaviour.min_move_size, abs=1e-3)
    b.moved(PARAMS.behaviour.min_move_size)
    assert b.decide(view_of(AT_GOAL, pose=behind, time=t + GIVE_WAY_HOLD_S - 1.0)) == Hold(t + GIVE_WAY_HOLD_S)
    assert isinstance(b.decide(view_of(AT_GOAL, pose=behind, time=t + GIVE_WAY_HOLD_S)), Rotate)  # then to the goal
    # A step aside is no progress: still held up, the rover gives up when the jam's time is out.
    stuck = b.decide(view_of(AT_GOAL, hits=RINGED_BY_ROVERS, time=MAX_CROWD_WAIT_S + 1))
    assert stuck == Finish("stuck") and "held up by other rovers" in stuck.why


def test_long_held_up_by_rovers_on_the_way_a_rover_plans_a_route_round_them():
    """Along a wall's long side a team splits, each rover's map tipping it to one end or the other, and rovers
    going either way met head on and waited for each other until they gave up. Long held up on the way, a rover
    plans round the rovers in view instead; near the goal, where they are the team at it, it does not."""
    b, t = fresh_behaviour(), 0.0
    while t <= CROWD_SQUEEZE_S + 1.0:
        b.decide(view_of(hits=HEAD_ON, time=t))
        t += 0.5
    view = view_of(hits=HEAD_ON, time=t)
    corner = b._route_point(view)
    assert b._routing and corner is not None
    knot = [ray_point(ORIGIN, h.angle_deg, h.distance_m + PARAMS.behaviour.rover_radius) for h in HEAD_ON]
    assert min(math.dist(corner, rover) for rover in knot) > 2 * PARAMS.behaviour.rover_radius
    assert b.crowd.rovers_in_way(view, 1.0, b._map)
    # turned away, it still keeps clear of them for a while (which rovers are in view changes as it turns)
    assert b.crowd.rovers_in_way(view_of(time=t + KNOT_MEMORY_S - 1.0), 1.0, b._map)
    assert not b.crowd.rovers_in_way(view_of(time=t + KNOT_MEMORY_S + 1.0), 1.0, b._map)
    near = fresh_behaviour(AT_GOAL)
    for k in range(int(CROWD_SQUEEZE_S * 2) + 2):
        near.decide(view_of(AT_GOAL, hits=HEAD_ON, time=k * 0.5))
    assert not near.crowd.rovers_in_way(view_of(AT_GOAL, hits=HEAD_ON, time=t), 1.0, near._map)


def _turned_to_give_way(b: DefaultBehaviour) -> float:
    """Hold up ``b`` in a knot until it turns round to step aside; the time of the turn."""
    t, decision = 0.0, None
    while decision != Rotate(180.0):
        assert t < GIVE_WAY_S + 10.0
        decision = b.decide(view_of(AT_GOAL, hits=HEAD_ON, time=t))
        t += 0.5
    return t


def test_a_step_aside_the_world_refuses_is_not_tried_again_and_the_next_move_is_no_step_aside():
    b = fresh_behaviour(AT_GOAL)
    t = _turned_to_give_way(b)
    behind = Pose(0.0, 0.0, 180.0)
    step = b.decide(view_of(AT_GOAL, pose=behind, time=t))
    b.rejected(angle_of(step))
    b.moved(0.0)
    assert b.crowd.hold_until < t + 1.0  # a refused step is no step aside: no long wait after it
    b.crowd.turned_aside = True  # as after the next try's turn
    again = b.decide(view_of(AT_GOAL, pose=behind, time=t + 0.5))
    assert isinstance(again, MoveTo) and abs(angle_of(again) - angle_of(step)) > 5.0


def test_a_step_aside_cut_short_by_a_rover_still_waits_its_while():
    b = fresh_behaviour(AT_GOAL)
    t = _turned_to_give_way(b)
    b.decide(view_of(AT_GOAL, pose=Pose(0.0, 0.0, 180.0), time=t))
    b.moved(0.8)  # the world cancelled it part way (the agent tells its behaviour: moved, then cancelled)
    b.cancelled(t + 0.5)
    assert b.crowd.hold_until == pytest.approx(t + GIVE_WAY_HOLD_S)  # rover 1: the plain hold, from the step
