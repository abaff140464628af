"""The time-to-contact rule of a move, on scripted scans: rovers placed as perception would show them."""

from __future__ import annotations

import math

from rover_agent.behaviour import DefaultBehaviour, Goal, Hit, View
from rover_agent.rules.crossing import STOP_WITHIN_S, CrossingWatch, contact_time
from schemas.params import RoverParams
from shared.pose import Pose

PARAMS = RoverParams()
RADIUS = PARAMS.behaviour.rover_radius
STEP = PARAMS.perception.field_of_view_degrees / (PARAMS.perception.perception_granularity - 1)
SCAN_S = 0.2


def seen(x: float, z: float) -> tuple[Hit, ...]:
    """The rays of a scan that hit a rover whose centre is (x right, z ahead) of this one."""
    fov = PARAMS.perception.field_of_view_degrees
    hits = []
    for k in range(PARAMS.perception.perception_granularity):
        a = -fov / 2 + k * STEP
        d = (math.sin(math.radians(a)), math.cos(math.radians(a)))
        along = x * d[0] + z * d[1]
        off = (x - along * d[0]) ** 2 + (z - along * d[1]) ** 2
        if along > 0 and off <= RADIUS ** 2:
            hits.append(Hit(round(a, 3), round(along - math.sqrt(RADIUS ** 2 - off), 3), "rover"))
    return tuple(hits)


def scans(start: tuple[float, float], velocity: tuple[float, float], count: int = 2):
    """A rover seen ``count`` scans in a row, moving at ``velocity`` relative to this one."""
    return [(i * SCAN_S, seen(start[0] + velocity[0] * i * SCAN_S, start[1] + velocity[1] * i * SCAN_S))
            for i in range(count)]


def dangers(watch: CrossingWatch, stream) -> list[bool]:
    return [watch.danger(t, hits) for t, hits in stream]


def test_a_rover_crossing_from_the_right_is_stopped_for_before_contact():
    # walking at 3.5 m/s, a rover 2.4 m to the right and ahead coming at us at 3.5 m/s from the side
    assert dangers(CrossingWatch(RADIUS, STEP), scans((3.0, 3.0), (-3.5, -3.5))) == [False, True]


def test_a_rover_standing_to_the_side_is_passed():
    assert dangers(CrossingWatch(RADIUS, STEP), scans((2.0, 0.5), (0.0, -3.5), 3)) == [False, False, False]


def test_a_rover_walking_alongside_is_no_danger():
    assert dangers(CrossingWatch(RADIUS, STEP), scans((2.5, 0.0), (0.0, 0.0), 4)) == [False] * 4


def test_a_rover_crossing_is_stopped_for_only_when_contact_is_near():
    assert dangers(CrossingWatch(RADIUS, STEP), scans((6.0, 6.0), (-3.5, -3.5))) == [False, False]  # in 1.3 s


def test_a_rover_standing_ahead_is_left_to_the_position_rules():
    """Walking at it, contact time alone would stop a move that ends at its gap from the rover."""
    assert dangers(CrossingWatch(RADIUS, STEP), scans((0.0, 3.2), (0.0, -3.5))) == [False, False]


def test_a_new_move_or_a_late_scan_forgets_the_last_scan():
    watch = CrossingWatch(RADIUS, STEP)
    watch.danger(0.0, seen(3.0, 3.0))
    watch.reset()
    assert not watch.danger(SCAN_S, seen(2.3, 2.3))
    assert not watch.danger(SCAN_S + 1.0, seen(1.6, 1.6))  # a second later: no motion to judge


def test_contact_time():
    assert contact_time((0.0, 5.0), (0.0, -2.0), 1.0) == 2.0
    assert contact_time((0.0, 5.0), (0.0, 2.0), 1.0) is None  # moving away
    assert contact_time((3.0, 5.0), (0.0, -2.0), 1.0) is None  # passes 3 m off
    assert contact_time((0.0, 0.5), (0.0, -1.0), 1.0) == 0.0  # in contact and closing


def test_the_behaviour_cancels_a_move_for_a_crossing_rover_that_the_position_rules_let_by():
    b = DefaultBehaviour(1, PARAMS)
    goal = Goal(0, 1, "waypoint", 0.0, 50.0)
    b.start_goal(goal)
    # walking ahead at 3.5 m/s, a rover coming from the right at 3.5 m/s: seen at 63 then 70 degrees right,
    # 2.7 m off, beyond the 1.5 m the position rules stop for at the side
    first, second = scans((3.2, 1.6), (-3.5, -3.5))
    assert not b.should_cancel(View(first[0], Pose(0.0, 0.0, 0.0), goal, first[1], 0.0))
    assert b.should_cancel(View(second[0], Pose(0.0, 0.0, 0.0), goal, second[1], 0.0))
    when = contact_time((2.5, 0.9), (-3.5, -3.5), 2 * RADIUS + 0.3)
    assert when is not None and when < STOP_WITHIN_S
