"""Slow moves among rovers at close quarters: the behaviour asks for them (``MoveTo.slow``), the agent sends the
speed level with them (``rover_agent.actions.pace``)."""

from __future__ import annotations

import math

from rover_agent.actions.pace import FULL_AGAIN_S, FULL_LEVEL, SLOW_LEVEL, Pace
from rover_agent.behaviour import DefaultBehaviour, Goal, Hit, MoveTo, View
from rover_agent.outgoing import Sender
from schemas import keyspace as ks
from schemas import messages as m
from schemas.params import RoverParams
from shared.pose import Pose

PARAMS = RoverParams()
KEYS = ks.Keyspace("w")
SEND = Sender(KEYS, 1)
STATION = Goal(0, 1, "waypoint", 0.0, 9.5, station=(0.0, -1.0), shared=True)  # 8.5 m ahead: parking
ROVER_NEAR = (Hit(-60.0, 3.0, "rover"),)  # ahead-left, clear of the way ahead
ROVER_FAR = (Hit(-60.0, 6.0, "rover"),)
ROVER_BEHIND = (Hit(100.0, 3.0, "rover"),)


def _move(goal: Goal, hits: tuple[Hit, ...]) -> MoveTo:
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(goal)
    move = b.decide(View(0.0, Pose(0.0, 0.0, 0.0), goal, hits, 0.0))
    assert isinstance(move, MoveTo)
    return move


def test_parking_near_another_rover_the_step_is_slow():
    assert _move(STATION, ROVER_NEAR).slow
    assert _move(STATION, ROVER_BEHIND).slow  # turning before it steps, one behind may step into the same gap


def test_a_rover_near_enough_to_meet_during_the_step_makes_it_slow():
    """Two rovers 4.5 m apart, each stepping 2 m towards the other at full speed, met on a crater's rim: the
    danger distance counts from anywhere along the step."""
    step = _move(STATION, ())
    near_its_end = (Hit(0.0, PARAMS.behaviour.collision_danger_dist + math.hypot(step.x, step.z) - 0.5, "rover"),)
    assert _move(STATION, near_its_end).slow


def test_parking_with_no_rover_near_or_walking_in_the_open_the_step_is_not():
    assert not _move(STATION, ()).slow
    assert not _move(STATION, ROVER_FAR).slow  # beyond the danger distance
    open_ground = Goal(0, 1, "waypoint", 0.0, 60.0)  # no station, far from the goal: not close quarters
    assert not _move(open_ground, ROVER_NEAR).slow


def _speeds(out) -> list[int]:
    return [msg.level for key, msg in out if key == KEYS.rover(1, ks.SPEED_ACTION) and isinstance(msg, m.SpeedAction)]


def test_the_agent_sends_the_slow_level_with_every_slow_move_and_the_full_one_for_a_while_after():
    pace = Pace()
    fast, slow = MoveTo(0.0, 2.0), MoveTo(0.0, 2.0, slow=True)
    assert _speeds(pace.speed(fast, 0.0, SEND)) == []  # the world starts at full speed: nothing to say
    assert _speeds(pace.speed(slow, 1.0, SEND)) == [SLOW_LEVEL]
    assert _speeds(pace.speed(slow, 2.0, SEND)) == [SLOW_LEVEL]  # again: a lost one costs one move
    assert _speeds(pace.speed(fast, 3.0, SEND)) == [FULL_LEVEL]
    assert _speeds(pace.speed(fast, 3.0 + FULL_AGAIN_S, SEND)) == [FULL_LEVEL]  # one lost is not the last
    assert _speeds(pace.speed(fast, 3.1 + FULL_AGAIN_S, SEND)) == []
    assert pace.speed(m.RotateAction(degrees=10.0), 3.0, SEND) == []  # only moves have a speed


def test_back_to_full_speed_long_after_the_last_slow_move_is_still_said():
    """A rover held long in a jam after its last slow step: its next move, at full speed, must say so."""
    pace = Pace()
    assert _speeds(pace.speed(MoveTo(0.0, 2.0, slow=True), 0.0, SEND)) == [SLOW_LEVEL]
    assert _speeds(pace.speed(MoveTo(0.0, 9.0), 10 * FULL_AGAIN_S, SEND)) == [FULL_LEVEL]
