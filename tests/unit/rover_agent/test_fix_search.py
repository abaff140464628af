"""A rover at its goal by an estimate it knows to be unsure (``rover_agent.estimation.fix_search``, the station drawn
in by ``rover_agent.mission.stations.drawn_in``): pure logic with scripted estimates, no world, no router."""

from __future__ import annotations

import math

import pytest
from agent_kit import joined_agent

from rover_agent.decisions import Goal
from rover_agent.estimation.fix_search import (
    BACK_LEG_RADII,
    DONE_STD_SHARE,
    MAX_LEGS,
    MAX_SEARCH_S,
    SEARCH_STD_SHARE,
    FixSearch,
)
from rover_agent.estimation.pose_filter import Localisation, NoiseModel
from rover_agent.estimation.sightings import Teammate
from rover_agent.mission.stations import DRAW_IN_LEAST, DRAW_IN_SIGMAS, drawn_in
from schemas import messages as m
from schemas import radio
from schemas.keyspace import Keyspace
from schemas.params import NavigationParams, RoverParams
from shared.pose import Pose

RADIUS = 10.0
NOISY = NoiseModel(slip_std=0.05, heading_std_rad=math.radians(1.0))
GOAL = Goal(index=0, total=1, kind="waypoint", x=0.0, z=200.0)


def estimate(x: float, z: float, std: float) -> Localisation:
    """An estimate at (x, z) whose 1-sigma position error is ``std`` (alike on both axes)."""
    var = std ** 2 / 2
    return Localisation(Pose(x, z, 0.0), NOISY, [[var, 0.0, 0.0], [0.0, var, 0.0], [0.0, 0.0, 1e-4]])


def mate(rid: int, x: float, z: float, std: float, stamp: float = 100.0, moving: bool = False) -> Teammate:
    var = std ** 2 / 2
    return Teammate(rid, radio.PoseEstimate(stamp=stamp, x=x, z=z, cov_xx=var, cov_xz=0.0, cov_zz=var,
                                            moving=moving))


def test_a_sure_rover_does_not_search_and_an_unsure_one_does_once_a_goal():
    search = FixSearch()
    assert not search.wanted(GOAL, estimate(0.0, 200.0, SEARCH_STD_SHARE * RADIUS - 0.1), RADIUS)
    unsure = estimate(0.0, 200.0, SEARCH_STD_SHARE * RADIUS + 0.5)
    assert search.wanted(GOAL, unsure, RADIUS)
    assert not search.wanted(Goal(0, 1, "crater", 0.0, 200.0), unsure, RADIUS)  # the rim is found by pitch
    search.begin(GOAL, unsure, 100.0, {}, (0.0, 0.0), RADIUS)
    assert not search.wanted(GOAL, unsure, RADIUS)


def test_it_walks_to_the_surest_teammate_standing_still_and_heard_lately():
    loc = estimate(0.0, 200.0, 6.0)
    teammates = {2: mate(2, 5.0, 205.0, 2.5), 3: mate(3, -5.0, 195.0, 1.0, moving=True),  # walking: no use
                 4: mate(4, 8.0, 190.0, 1.5), 5: mate(5, 0.0, 210.0, 0.5, stamp=50.0),  # heard too long ago
                 6: mate(6, 3.0, 202.0, 4.0)}  # no surer than half the rover's error
    search = FixSearch()
    assert search.begin(GOAL, loc, 100.0, teammates, (0.0, 0.0), RADIUS)
    assert search.goal.target == (8.0, 190.0) and "rover 4" in search.detail
    assert search.goal.index == GOAL.index and search.goal.kind == "waypoint"


def test_with_no_teammate_it_walks_to_the_lander_when_near_else_back_to_its_last_sure_place_when_near():
    near = FixSearch()
    assert near.begin(GOAL, estimate(10.0, 25.0, 6.0), 0.0, {}, None, RADIUS)
    assert near.goal.target == (0.0, 0.0) and "lander" in near.detail
    back = FixSearch()
    sure_at = (0.0, 200.0 - BACK_LEG_RADII * RADIUS)
    assert back.begin(GOAL, estimate(0.0, 200.0, 6.0), 0.0, {}, sure_at, RADIUS)
    assert back.goal.target == sure_at and "back" in back.detail
    far = FixSearch()  # sure last near the lander, 180 m back: it would come back as unsure as it left
    assert not far.begin(GOAL, estimate(0.0, 200.0, 6.0), 0.0, {}, (0.0, 20.0), RADIUS)
    lost = FixSearch()
    assert not lost.begin(GOAL, estimate(0.0, 200.0, 6.0), 0.0, {}, None, RADIUS)  # nothing to search with
    assert not lost.active


def test_the_search_is_bounded_in_legs_and_time_and_ends_once_sure():
    search, loc, sure_at = FixSearch(), estimate(0.0, 200.0, 6.0), (0.0, 180.0)
    assert search.begin(GOAL, loc, 0.0, {}, sure_at, RADIUS)
    for _ in range(MAX_LEGS - 1):
        assert search.next_leg(GOAL, loc, 10.0, {}, sure_at, RADIUS)
    assert not search.next_leg(GOAL, loc, 20.0, {}, sure_at, RADIUS) and not search.active
    timed = FixSearch()
    timed.begin(GOAL, loc, 0.0, {}, sure_at, RADIUS)
    assert not timed.over(loc, MAX_SEARCH_S - 1.0, RADIUS) and timed.over(loc, MAX_SEARCH_S, RADIUS)
    fixed = estimate(0.0, 200.0, DONE_STD_SHARE * RADIUS)
    assert timed.over(fixed, 1.0, RADIUS)


def test_a_station_is_drawn_in_toward_its_waypoint_as_far_as_the_error_needs():
    goal = Goal(0, 1, "waypoint", 0.0, 100.0, station=(8.0, 0.0), shared=True)
    assert drawn_in(goal, 0.5, RADIUS) == goal  # sure enough: 8 m + 2 sigmas is within the radius
    drawn = drawn_in(goal, 2.5, RADIUS)
    assert math.hypot(*drawn.station) == pytest.approx(RADIUS - DRAW_IN_SIGMAS * 2.5)
    assert drawn.station[1] == 0.0 and drawn.x == goal.x and drawn.z == goal.z  # along its own spoke
    assert math.hypot(*drawn_in(goal, 20.0, RADIUS).station) == pytest.approx(DRAW_IN_LEAST * 8.0)
    crater = Goal(0, 1, "crater", 0.0, 100.0, station=(8.0, 0.0), shared=True)
    assert drawn_in(crater, 5.0, RADIUS) == crater  # a crest station is found by pitch, not drawn in
    assert drawn_in(None, 5.0, RADIUS) is None


def test_an_agent_at_its_waypoint_unsure_searches_and_says_why_then_stops_at_its_goal():
    """The agent's side: "done but unsure" is a search, shown in its status; once the search is over (here, out of
    time) it walks back to its goal and stops there."""
    params = RoverParams(navigation=NavigationParams(slip_std=0.05, heading_noise_std_deg=1.0))
    agent = joined_agent(1, Keyspace("w"), params)
    agent.estimator.place(Pose(0.0, 180.0, 0.0))  # sure there, 20 m back
    agent.mission.direction(m.MissionDirection(goal_index=0, goals_total=1, kind="waypoint", bearing_deg=0.0,
                                               distance_m=200.0), 0.0)
    agent.estimator.localisation = estimate(0.0, 200.0, 6.0)
    agent.finish("reached")
    assert agent.state != "done" and agent.estimator.search.active
    status = agent.status()[1]
    assert status.detail.startswith("unsure of its position at the goal (6 m, 1 sigma): walking back")
    assert agent.view(1.0, agent.pose, ()).goal == agent.estimator.search.goal
    agent.now = MAX_SEARCH_S + 1.0
    agent.detours.before_decision(agent.now)
    assert not agent.estimator.search.active and agent.view(2.0, agent.pose, ()).goal == agent.mission.goal
    agent.finish("reached")
    assert agent.state == "done"


def test_at_the_end_of_a_leg_to_a_teammate_still_unsure_it_turns_round_once_before_the_next_leg():
    """The leg ends where the rover's estimate puts the teammate, so the teammate stands within the rover's error of
    it in any direction, and may be in the sector behind that its field of view leaves unseen: one turn round,
    then the next leg. A leg back to the last sure place walks to no one: no turn there."""
    params = RoverParams(navigation=NavigationParams(slip_std=0.05, heading_noise_std_deg=1.0))
    agent = joined_agent(1, Keyspace("w"), params)
    agent.mission.direction(m.MissionDirection(goal_index=0, goals_total=1, kind="waypoint", bearing_deg=0.0,
                                               distance_m=200.0), 0.0)
    agent.estimator.localisation = estimate(0.0, 200.0, 6.0)
    agent.now = 100.0
    agent.estimator.teammates = {4: mate(4, 8.0, 190.0, 1.5)}
    agent.finish("reached")
    assert agent.estimator.search.goal.target == (8.0, 190.0)
    agent.estimator.localisation = estimate(8.0, 190.0, 6.0)  # at the teammate's place by its estimate, unsure
    turned = [msg for _, msg in agent.finish("reached") if isinstance(msg, m.RotateAction)]
    assert [t.degrees for t in turned] == [180.0] and agent.estimator.search.active
    assert not [msg for _, msg in agent.finish("reached") if isinstance(msg, m.RotateAction)]  # once a leg


def test_a_leg_back_to_the_last_sure_place_ends_without_a_turn():
    search, loc = FixSearch(), estimate(0.0, 200.0, 6.0)
    assert search.begin(GOAL, loc, 0.0, {}, (0.0, 180.0), RADIUS) and not search.look_round()
    assert search.next_leg(GOAL, loc, 10.0, {2: mate(2, 5.0, 205.0, 2.5, stamp=10.0)}, (0.0, 180.0), RADIUS)
    assert search.look_round() and not search.look_round()
