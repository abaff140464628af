"""Stations at a shared waypoint (need N7): the layout, and how the lander hands them out."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest

from lander_agent.lander import Lander
from lander_agent.mission import MissionPlan
from lander_agent.stations import WITHIN, fitted_offsets, pick_rim_station, pick_station, rim_offsets, station_offsets
from schemas import codec, radio
from schemas import keyspace as ks
from schemas import messages as m
from schemas.radio import GoalReport, StationRequest
from schemas.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"


@pytest.mark.parametrize("count", [2, 5, 20, 40])
def test_disc_stations_are_spacing_apart_and_compact(count):
    offsets = station_offsets(count, 3.2, 0.0)
    assert len(set(offsets)) == count
    gaps = [math.dist(a, b) for i, a in enumerate(offsets) for b in offsets[i + 1:]]
    assert min(gaps) == pytest.approx(3.2, abs=1e-2)
    # a disc: no station much farther out than a hexagonal packing needs
    assert max(math.hypot(*o) for o in offsets) <= 3.2 * (math.sqrt(count / 3) + 1)


def test_stations_are_listed_nearest_the_waypoint_first():
    radii = [math.hypot(*o) for o in station_offsets(20, 3.2, 245.0)]
    assert all(a <= b + 0.01 for a, b in itertools.pairwise(radii))  # offsets are rounded to mm


def test_the_formation_fills_from_the_inside_out_each_rover_on_its_own_side():
    offsets = station_offsets(19, 3.2, 0.0)
    assert pick_station(offsets, [], (0.0, 30.0), 3.2) == (0.0, 0.0)  # the first to ask: the centre
    assert pick_station(offsets, [(0.0, 0.0)], (30.0, 0.0), 3.2) == (3.2, 0.0)  # from the east: the east side
    assert pick_station(offsets, [(0.0, 0.0)], (-30.0, 0.0), 3.2) == (-3.2, 0.0)
    inner = [o for o in offsets if math.hypot(*o) < 3.3]
    outer = pick_station(offsets, inner, (0.0, -30.0), 3.2)
    assert 5.0 < math.hypot(*outer) < 5.6 and outer[1] < 0  # the ring is full: the next one out, on its side
    assert pick_station(offsets, offsets, (30.0, 0.0), 3.2) in offsets  # more rovers than stations: share one


def test_a_line_stands_abreast_across_the_direction_of_travel():
    offsets = station_offsets(5, 3.0, 90.0, "line")  # travelling east: the line runs north-south
    assert all(x == pytest.approx(0.0, abs=1e-9) for x, _ in offsets)
    assert sorted(z for _, z in offsets) == pytest.approx([-6.0, -3.0, 0.0, 3.0, 6.0])


def _twenty_rover_return():
    return load_scenario(SCENARIOS / "crater_and_return.yaml").with_overrides(rovers=20)


def _ask_all(plan: MissionPlan) -> None:
    """Every rover asks for its station at its current goal from 15 m north of it, in id order."""
    for rid in plan.rover_ids:
        index = plan.goal_of[rid]
        goal = plan.missions.goal(rid, index)
        x, z = goal.x - plan.scenario.lander.x, goal.z - plan.scenario.lander.z
        assert plan.request_station(rid, StationRequest(goal_index=index, x=x, z=z + 15.0))


def test_the_lander_gives_each_rover_of_a_team_its_own_station_at_a_shared_waypoint_when_it_asks():
    plan = MissionPlan(_twenty_rover_return())
    for rid in plan.rover_ids:  # the crater first
        plan.on_report(rid, GoalReport(goal_index=0, outcome="reached"))
    assert all(plan.direction_for(r).shared and plan.direction_for(r).station is None for r in plan.rover_ids)
    assert not plan.request_station(1, StationRequest(goal_index=0, x=0.0, z=0.0))  # a stale request
    _ask_all(plan)
    stations = [plan.direction_for(r).station for r in plan.rover_ids]
    assert None not in stations and len(set(stations)) == 20
    assert stations[0] == (0.0, 0.0)  # the first to ask stands in the middle, the others round it
    assert plan.request_station(1, StationRequest(goal_index=1, x=0.0, z=0.0))  # asked again: the same station
    assert plan.direction_for(1).station == (0.0, 0.0)


def test_the_lander_answers_a_station_request_over_the_radio():
    plan = MissionPlan(_twenty_rover_return())
    for rid in plan.rover_ids:
        plan.on_report(rid, GoalReport(goal_index=0, outcome="reached"))
    keys = ks.Keyspace("w")
    lander = Lander(plan, keys)
    request = radio.pack(StationRequest(goal_index=1, x=0.0, z=60.0))
    (key, out), = lander.on_comm_in(m.InboundComm(sender=7, payload=request))
    direction = codec.decode(m.MissionDirection, out.payload)
    assert key == keys.lander(ks.COMM_OUT) and out.targets == [7] and direction.station == (0.0, 0.0)
    stale = radio.pack(StationRequest(goal_index=0, x=0.0, z=60.0))
    assert lander.on_comm_in(m.InboundComm(sender=8, payload=stale)) == []


def test_formation_none_keeps_the_reports_shared_waypoint():
    scenario = _twenty_rover_return()
    scenario = scenario.model_copy(update={"formation": scenario.formation.model_copy(update={"shape": "none"})})
    plan = MissionPlan(scenario)
    for rid in plan.rover_ids:
        plan.on_report(rid, GoalReport(goal_index=0, outcome="reached"))
    assert not any(plan.direction_for(r).shared for r in plan.rover_ids)
    assert not plan.request_station(1, StationRequest(goal_index=1, x=0.0, z=0.0))


def test_a_rover_alone_at_a_waypoint_gets_no_station():
    scenario = load_scenario(SCENARIOS / "crater_and_return.yaml").with_overrides(rovers=1)
    plan = MissionPlan(scenario)
    plan.on_report(1, GoalReport(goal_index=0, outcome="reached"))
    assert not plan.direction_for(1).shared and plan.direction_for(1).station is None


def test_no_station_is_placed_on_the_lander_when_every_rover_returns():
    scenario = _twenty_rover_return()
    plan = MissionPlan(scenario)
    lander = scenario.lander
    plan.on_command(m.GroundCommand(command="set_target", x=lander.x, z=lander.z))
    _ask_all(plan)
    for rid in plan.rover_ids:
        direction = plan.direction_for(rid)
        assert direction.station is not None
        gap = math.hypot(*direction.station) - lander.radius_m - scenario.rover_params.behaviour.rover_radius
        assert gap > 0.9
    assert len({plan.direction_for(r).station for r in plan.rover_ids}) == 20


def test_a_large_team_is_drawn_closer_to_stand_well_within_the_waypoints_radius():
    """At 3.2 m apart the outer stations of 20 rovers stand 8.5 m out, at the edge of a 10 m radius: a metre of
    drift off the station leaves the rover short of the goal."""
    wide = station_offsets(20, 3.2, 0.0)
    assert max(math.hypot(*o) for o in wide) > 8.0
    offsets, spacing = fitted_offsets(20, 3.2, 0.0, "disc", 10.0, 2.0)
    assert max(math.hypot(*o) for o in offsets) <= WITHIN * 10.0 + 1e-3  # offsets are rounded to the mm
    assert len(offsets) == 20 and 2.0 <= spacing < 3.2
    assert min(math.dist(a, b) for a, b in itertools.combinations(offsets, 2)) >= spacing - 1e-3


def test_a_small_team_keeps_its_formation_and_the_least_spacing_holds():
    assert fitted_offsets(5, 3.2, 30.0, "disc", 10.0, 2.0) == (station_offsets(5, 3.2, 30.0), 3.2)
    offsets, spacing = fitted_offsets(60, 3.2, 0.0, "disc", 10.0, 2.0)  # too many to fit: no closer than 2 m
    assert spacing == 2.0 and min(math.dist(a, b) for a, b in itertools.combinations(offsets, 2)) >= 2.0 - 1e-3


def test_crest_stations_stand_all_round_the_crest_spacing_apart():
    offsets, spacing = rim_offsets(5, 12.0, 3.2, 1.6)
    assert spacing == 3.2 and len(offsets) == math.floor(2 * math.pi * 12.0 / 3.2)
    assert all(abs(math.hypot(*o) - 12.0) < 1e-3 for o in offsets)
    assert min(math.dist(a, b) for a, b in itertools.combinations(offsets, 2)) >= 3.2 - 1e-2
    crowded, closer = rim_offsets(40, 12.0, 3.2, 1.6)  # 40 do not fit 3.2 m apart round 75 m of crest
    assert 1.6 <= closer < 3.2 and len(crowded) >= 40
    assert len(rim_offsets(100, 12.0, 3.2, 1.6)[0]) < 100  # nor at the least spacing: some share


def test_rovers_arriving_from_one_side_fill_the_crest_outwards_from_where_they_come():
    offsets, _ = rim_offsets(8, 10.0, 3.0, 1.6)
    taken: list[tuple[float, float]] = []
    for _ in range(5):  # five rovers asking in turn from 20 m south of the crater
        taken.append(pick_rim_station(offsets, taken, (0.0, -20.0)))
    assert len(set(taken)) == 5
    bearings = sorted(abs(math.degrees(math.atan2(x, -z))) for x, z in taken)  # 0: due south
    assert bearings[0] < 1e-6 and bearings[-1] < 60.0  # the nearest stretch of crest, none across the crater


def test_the_lander_gives_each_rover_of_a_team_its_own_station_on_a_shared_craters_crest():
    scenario = _twenty_rover_return()
    plan = MissionPlan(scenario)
    assert all(plan.direction_for(r).shared and plan.direction_for(r).station is None for r in plan.rover_ids)
    goal = plan.missions.goal(1, 0)
    crater = scenario.crater_of(goal)
    lx, lz = scenario.lander.x, scenario.lander.z
    for rid in plan.rover_ids:  # each asks from where it stands, at its start
        start = plan.calibration[rid]
        assert plan.request_station(rid, StationRequest(goal_index=0, x=start.x, z=start.z))
    stations = [plan.direction_for(r).station for r in plan.rover_ids]
    assert None not in stations and len(set(stations)) == 20
    for sx, sz in stations:  # offsets from the goal, each on the crest
        assert abs(math.hypot(goal.x + sx - crater.x, goal.z + sz - crater.z) - crater.radius_m) < 0.01
    first = plan.calibration[1]
    nearest = min(((goal.x - lx + sx, goal.z - lz + sz) for sx, sz in stations),
                  key=lambda p: math.dist(p, (first.x, first.z)))
    assert nearest == (goal.x - lx + stations[0][0], goal.z - lz + stations[0][1])  # the first asks, the nearest


def test_the_team_at_a_goal_follows_ground_commands():
    """Who shares a goal is indexed as goals are added (``RoverMissions.sharing``): a command that sends one rover
    elsewhere and then the others after it must show in the next directions, not in a stale index."""
    scenario = load_scenario(SCENARIOS / "crater_and_return.yaml").with_overrides(rovers=3)
    plan = MissionPlan(scenario)
    last = len(scenario.mission)
    assert plan.direction_for(1).shared  # all three share goal 0
    plan.on_command(m.GroundCommand(command="set_target", rover_id=2, x=40.0, z=40.0))
    plan.on_command(m.GroundCommand(command="set_target", rover_id=3, x=-40.0, z=40.0))
    assert plan.missions.sharing(last, plan.missions.goal(2, last)) == [2]
    assert plan.missions.sharing(last, plan.missions.goal(3, last)) == [3]
    plan.on_command(m.GroundCommand(command="set_target", rover_id=1, x=40.0, z=40.0))
    assert plan.missions.sharing(last, plan.missions.goal(2, last)) == [1, 2]
