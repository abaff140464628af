"""Stations at a shared waypoint (need N7): the layout, and how the lander hands them out."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest

from lander_agent.mission import MissionPlan
from lander_agent.stations import station_offsets
from schemas import messages as m
from schemas.radio import GoalReport
from schemas.scenario import load_scenario

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"


@pytest.mark.parametrize("count", [2, 5, 20, 40])
def test_disc_stations_are_spacing_apart_and_compact(count):
    offsets = station_offsets(count, 3.2, 0.0)
    assert len(set(offsets)) == count
    gaps = [math.dist(a, b) for i, a in enumerate(offsets) for b in offsets[i + 1:]]
    assert min(gaps) == pytest.approx(3.2, abs=1e-2)
    # a disc: no station much farther out than a hexagonal packing needs
    assert max(math.hypot(*o) for o in offsets) <= 3.2 * (math.sqrt(count / 3) + 1)


@pytest.mark.parametrize("bearing", [0.0, 90.0, 180.0, 245.0])
def test_stations_are_handed_out_far_side_first_along_the_direction_of_travel(bearing):
    offsets = station_offsets(20, 3.2, bearing)
    fx, fz = math.sin(math.radians(bearing)), math.cos(math.radians(bearing))
    along = [x * fx + z * fz for x, z in offsets]
    assert all(a >= b - 0.01 for a, b in itertools.pairwise(along))  # offsets are rounded to mm


def test_a_line_stands_abreast_across_the_direction_of_travel():
    offsets = station_offsets(5, 3.0, 90.0, "line")  # travelling east: the line runs north-south
    assert all(x == pytest.approx(0.0, abs=1e-9) for x, _ in offsets)
    assert sorted(z for _, z in offsets) == pytest.approx([-6.0, -3.0, 0.0, 3.0, 6.0])


def _twenty_rover_return():
    return load_scenario(SCENARIOS / "crater_and_return.yaml").with_overrides(rovers=20)


def test_the_lander_gives_each_rover_of_a_team_its_own_station_at_a_shared_waypoint():
    plan = MissionPlan(_twenty_rover_return())
    assert all(plan.direction_for(r).station is None for r in plan.rover_ids)  # a crater goal first
    for rid in plan.rover_ids:
        plan.on_report(rid, GoalReport(goal_index=0, outcome="reached"))
    stations = [plan.direction_for(r).station for r in plan.rover_ids]
    assert None not in stations and len(set(stations)) == 20
    assert stations[0] == station_offsets(20, 3.2, plan._travel_bearing(1, 1))[0]  # first told, far side


def test_formation_none_keeps_the_reports_shared_waypoint():
    scenario = _twenty_rover_return()
    scenario = scenario.model_copy(update={"formation": scenario.formation.model_copy(update={"shape": "none"})})
    plan = MissionPlan(scenario)
    for rid in plan.rover_ids:
        plan.on_report(rid, GoalReport(goal_index=0, outcome="reached"))
    assert all(plan.direction_for(r).station is None for r in plan.rover_ids)


def test_a_rover_alone_at_a_waypoint_gets_no_station():
    scenario = load_scenario(SCENARIOS / "crater_and_return.yaml").with_overrides(rovers=1)
    plan = MissionPlan(scenario)
    plan.on_report(1, GoalReport(goal_index=0, outcome="reached"))
    assert plan.direction_for(1).station is None


def test_no_station_is_placed_on_the_lander_when_every_rover_returns():
    scenario = _twenty_rover_return()
    plan = MissionPlan(scenario)
    lander = scenario.lander
    plan.on_command(m.GroundCommand(command="set_target", x=lander.x, z=lander.z))
    for rid in plan.rover_ids:
        direction = plan.direction_for(rid)
        assert direction.station is not None
        gap = math.hypot(*direction.station) - lander.radius_m - scenario.rover_params.behaviour.rover_radius
        assert gap > 0.9
    assert len({plan.direction_for(r).station for r in plan.rover_ids}) == 20
