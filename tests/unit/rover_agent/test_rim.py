"""Crest stations at a crater goal the team shares: the rover walks to its spoke's foot, then climbs along it
(``rover_agent.rules.rim``)."""

from __future__ import annotations

import math

import pytest

from rover_agent.behaviour import DefaultBehaviour
from rover_agent.decisions import Finish, Goal, Hit, MoveTo, Rotate, TakePhoto, View
from rover_agent.rules import rim
from rover_agent.rules.crater import near_station_m
from rover_agent.rules.tuning import CROWD_SQUEEZE_S, MAX_CROWD_WAIT_S
from schemas.params import RoverParams
from shared.pose import Pose

PARAMS = RoverParams()
# a crater goal 60 m north; this rover's station is on the crest 10 m east of the goal
CRATER = Goal(0, 1, "crater", 0.0, 60.0, station=(10.0, 0.0), shared=True)
CRATER_AHEAD = (Hit(0.0, 8.0, "crater_terrain"),)


def _bearing(pose: Pose, move: MoveTo) -> float:
    """The compass bearing of a move (the rover's frame: z ahead, x to the right)."""
    return (pose.heading + math.degrees(math.atan2(move.x, move.z))) % 360


@pytest.mark.parametrize("station", [(10.0, 0.0), (-3.0, 4.0), (0.0, -25.0)])
def test_the_foot_stands_outside_the_station_on_the_line_from_the_goal(station):
    goal = Goal(0, 1, "crater", 5.0, -7.0, station=station)
    fx, fz = rim.foot(goal)
    reach = math.hypot(*station)
    out = math.hypot(fx - goal.x, fz - goal.z) - reach
    assert out == pytest.approx(max(rim.FOOT_LEAST_M, rim.FOOT_OUT * reach))
    cross = (fx - goal.x) * station[1] - (fz - goal.z) * station[0]  # on the spoke: no sideways part
    assert cross == pytest.approx(0.0, abs=1e-9)


def test_a_rover_with_a_crest_station_walks_to_the_foot_first_not_at_the_crater():
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(CRATER)
    pose = Pose(0.0, 0.0, 0.0)
    move = b.decide(View(0.0, pose, CRATER, CRATER_AHEAD, 0.0))
    fx, fz = rim.foot(CRATER)
    assert isinstance(move, MoveTo)
    assert _bearing(pose, move) == pytest.approx(math.degrees(math.atan2(fx, fz)), abs=6.0)
    assert b.state != "climbing"  # crater terrain in view, but the climb starts at the foot


def test_from_the_foot_the_rover_climbs_along_the_spoke_and_tells_the_crest_sooner():
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(CRATER)
    fx, fz = rim.foot(CRATER)
    facing_in = Pose(fx, fz, 270.0)  # at the foot, facing west: up the spoke to the crest and the goal
    up = b.decide(View(0.0, facing_in, CRATER, CRATER_AHEAD, 0.0))
    assert b.state == "climbing" and isinstance(up, MoveTo)
    assert _bearing(facing_in, up) == pytest.approx(270.0, abs=6.0)
    b.moved(2.0)
    b.decide(View(1.0, facing_in, CRATER, (), 6.0))  # up the outer slope
    b.moved(rim.crest_after_m(CRATER) - 2.0)
    assert rim.crest_after_m(CRATER) < PARAMS.perception.perception_radius
    first = b.decide(View(2.0, facing_in, CRATER, (), 0.5))  # level: the crest
    assert isinstance(first, TakePhoto) and b.state == "observing"


def test_a_rover_that_cannot_get_nearer_the_foot_climbs_from_where_it_stands():
    """A foot behind rocks or other rovers does not hold the rover off the crater for ever."""
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(CRATER)
    pose = Pose(0.0, 40.0, 0.0)
    decisions = []
    for step in range(40):
        decisions.append(b.decide(View(float(step), pose, CRATER, CRATER_AHEAD, 0.0)))
        if b.state == "climbing":
            break
        b.moved(1.0)  # walking, but standing where it was: no nearer the foot
    assert b.state == "climbing"
    assert Finish("stuck") not in decisions


def _on_the_spoke(b: DefaultBehaviour) -> None:
    """Past the foot of its spoke, climbing (``_to_spoke`` leaves a rover that gives up on the foot the same)."""
    b.decide(View(0.0, Pose(*rim.foot(CRATER), 270.0), CRATER, CRATER_AHEAD, 0.0))
    assert b.state == "climbing"


def test_a_rover_come_slantwise_up_the_rim_to_its_station_settles_there_facing_the_crater():
    """One that gave up on the foot (a detour round rocks) climbs towards its station, not the crater's centre:
    the climb still counts, and at the station it turns to the crater and observes instead of pacing over the
    crest for ever."""
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(CRATER)
    _on_the_spoke(b)
    station = CRATER.target  # (10, 60)
    slantwise = Pose(station[0] + 3.0, station[1] - 3.0, 315.0)  # 45 degrees off the crater's centre, at the station
    assert not rim.facing_station(CRATER, Pose(slantwise.x, slantwise.z, 270.0))
    assert rim.facing_station(CRATER, slantwise)
    b.decide(View(0.0, slantwise, CRATER, (), 8.0))  # up the outer slope, towards the station
    at = Pose(station[0] + 0.5, station[1], 20.0)  # at the station, but turned away from the crater
    decisions = [b.decide(View(1.0 + k, at if k == 0 else Pose(at.x, at.z, 270.0), CRATER, (), 0.2)) for k in range(2)]
    assert isinstance(decisions[0], Rotate)  # turns to the crater...
    assert isinstance(decisions[1], TakePhoto) and b.state == "observing"  # ...and, level there, observes


def test_at_its_station_a_rover_that_never_felt_the_climb_still_observes():
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(CRATER)
    _on_the_spoke(b)
    station = CRATER.target
    first = b.decide(View(0.0, Pose(station[0] + 0.5, station[1], 270.0), CRATER, (), 0.0))
    assert isinstance(first, TakePhoto) and b.state == "observing"


TWO_BODIES = near_station_m(PARAMS)
WALL_OF_ROVERS = (*CRATER_AHEAD, *(Hit(a, 1.4, "rover") for a in range(-100, 101, 4)))


@pytest.mark.parametrize(("off_m", "finishes"), [(TWO_BODIES - 0.5, True), (TWO_BODIES + 1.0, False)])
def test_a_rover_held_up_on_the_rim_observes_from_there_only_near_its_station(off_m, finishes):
    """The rovers that leave it no step towards the crater may be climbing too, bound for stations beside its
    own: farther below its station than two bodies by its own estimate, it holds on."""
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(CRATER)
    _on_the_spoke(b)
    station = CRATER.target
    here = Pose(station[0] + off_m, station[1], 270.0)  # up the outer slope, facing the crater
    b.moved(2.0)
    held = [b.decide(View(t, here, CRATER, WALL_OF_ROVERS, 9.0)) for t in (1.0, 5.0, CROWD_SQUEEZE_S + 2.0)]
    assert (isinstance(held[-1], TakePhoto) and b.state == "observing") is finishes
    assert not any(isinstance(d, TakePhoto) for d in held[:-1])


def test_a_rover_held_up_on_the_rim_far_from_its_station_observes_there_rather_than_give_up():
    """Its estimate may be what puts it far from its station: held up until it would give up, it observes."""
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(CRATER)
    _on_the_spoke(b)
    station = CRATER.target
    here = Pose(station[0] + TWO_BODIES + 1.0, station[1], 270.0)
    b.moved(2.0)
    decisions = [b.decide(View(float(t), here, CRATER, WALL_OF_ROVERS, 9.0))
                 for t in range(0, int(MAX_CROWD_WAIT_S) + 3)]
    photos = [t for t, d in enumerate(decisions) if isinstance(d, TakePhoto)]
    assert photos and photos[0] > MAX_CROWD_WAIT_S and b.state == "observing"
    assert not any(isinstance(d, Finish) for d in decisions)


def _spoke_point(out_m: float, across_m: float = 0.0) -> tuple[float, float]:
    """A point ``out_m`` outside the station along its spoke (east here), ``across_m`` to the side of it."""
    sx, sz = CRATER.target
    return sx + out_m, sz + across_m


def test_a_rover_given_its_station_past_the_foot_climbs_from_where_it_stands_not_back_at_the_foot():
    """The station comes once crater terrain is in view, often with the rover past the foot already: walking back
    out to the foot to climb the same slope again cost the crater mission's last rover 43 m and 22 s."""
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(CRATER)
    x, z = _spoke_point(3.0, 2.0)  # 3 m out, beside the spoke, facing the crater
    pose = Pose(x, z, 270.0)
    up = b.decide(View(0.0, pose, CRATER, CRATER_AHEAD, 0.0))
    assert b.state == "climbing" and isinstance(up, MoveTo)
    assert _bearing(pose, up) == pytest.approx(math.degrees(math.atan2(CRATER.target[0] - x, CRATER.target[1] - z))
                                               % 360, abs=6.0)
    assert rim.joins_spoke(CRATER, pose) == pytest.approx(3.0)


@pytest.mark.parametrize(("out_m", "across_m"), [(3.0, 4.0), (-2.0, 0.0), (rim.FOOT_LEAST_M + 7.0, 0.0)])
def test_off_the_spoke_in_the_bowl_or_beyond_the_foot_the_rover_goes_by_the_foot(out_m, across_m):
    """Far to the side of its spoke, inside the crest or farther out than the foot, the foot is the way."""
    x, z = _spoke_point(out_m, across_m)
    assert rim.joins_spoke(CRATER, Pose(x, z, 270.0)) is None


def test_on_level_ground_below_its_station_the_rover_takes_long_steps_at_full_speed():
    """Short steps and slow moves are for the slope: on level ground a climb from the foot took 2 m steps, and
    slow ones with a teammate near, for ten metres and more."""
    wide = Goal(0, 1, "crater", 0.0, 60.0, station=(30.0, 0.0), shared=True)  # its foot 18 m out
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(wide)
    x, z = rim.foot(wide)
    mate = (Hit(60.0, 3.0, "rover"),)  # beside it, out of its way
    step = b.decide(View(0.0, Pose(x, z, 270.0), wide, (*CRATER_AHEAD, *mate), 0.0, position_std_m=1.0))
    assert isinstance(step, MoveTo) and not step.slow
    assert math.hypot(step.x, step.z) == pytest.approx(0.9 * PARAMS.perception.perception_radius, abs=0.05)
    b.moved(math.hypot(step.x, step.z))
    near = b.decide(View(1.0, Pose(wide.target[0] + 7.0, wide.target[1], 270.0), wide, (), 0.0, position_std_m=1.0))
    assert isinstance(near, MoveTo) and math.hypot(near.x, near.z) == pytest.approx(7.0 - 2.0 - 2 * 1.0, abs=0.05)
    b.moved(3.0)
    on_slope = b.decide(View(2.0, Pose(wide.target[0] + 4.0, wide.target[1], 270.0), wide, (), 8.0))
    assert isinstance(on_slope, MoveTo) and math.hypot(on_slope.x, on_slope.z) <= PARAMS.behaviour.min_move_size


def test_at_its_station_by_its_estimate_but_still_below_the_crest_the_rover_climbs_on_towards_the_crater():
    """Its estimate is a metre or two off: facing the crater, pitch says the crest is ahead. Heading back for the
    station turned it round, and it turned to and fro between crater and station until its looks ran out, then
    observed from below the crest."""
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(CRATER)
    _on_the_spoke(b)
    b.moved(6.0)
    sx, sz = CRATER.target
    facing_crater = Pose(sx - 0.5, sz, 270.0)  # just past its station by the estimate, facing the crater
    decisions = [b.decide(View(float(t), facing_crater, CRATER, (), 3.0, position_std_m=1.5)) for t in range(3)]
    assert all(isinstance(d, MoveTo) and _bearing(facing_crater, d) == pytest.approx(270.0, abs=1.0)
               for d in decisions)
    assert isinstance(b.decide(View(4.0, facing_crater, CRATER, (), 0.2, position_std_m=1.5)), TakePhoto)


def test_climbing_on_past_its_station_ends_where_its_estimate_allows():
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(CRATER)
    _on_the_spoke(b)
    b.moved(6.0)
    sx, sz = CRATER.target
    b.decide(View(0.0, Pose(sx, sz, 270.0), CRATER, (), 3.0, position_std_m=0.5))
    far_past = Pose(sx - 1.5 - 3 * 0.5 - 0.1, sz, 270.0)
    assert isinstance(b.decide(View(1.0, far_past, CRATER, (), 3.0, position_std_m=0.5)), TakePhoto)
