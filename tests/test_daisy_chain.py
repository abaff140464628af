"""The daisy chain (report 6.5): relays placed by the lander keep every rover in touch with it."""

from __future__ import annotations

import math

import pytest
from procs import SCENARIOS

from deploy.loopback import run_mission
from lander_agent.daisy_chain import SPACING, plan_chain, relays_needed
from lander_agent.mission import MissionPlan
from lander_agent.runtime import PhotoArchive
from schemas.radio import GoalReport
from schemas.scenario import load_scenario


@pytest.mark.parametrize(("reach", "lander_range", "comm_range", "needed"), [
    (20.0, 30.0, 30.0, 0), (25.5, 30.0, 30.0, 0), (50.0, 30.0, 30.0, 1), (130.0, 30.0, 30.0, 5),
    (130.0, 1000.0, 10.0, 0),
])
def test_the_fewest_relays_that_bridge_the_distance(reach, lander_range, comm_range, needed):
    assert relays_needed(reach, lander_range, comm_range) == needed
    assert needed <= math.ceil(reach / comm_range)  # at most one more than distance / range requires


def test_relay_spots_are_evenly_spaced_on_the_line_within_range():
    chain = plan_chain((0.0, 150.0), 130.0, list(range(1, 9)), 30.0, 30.0)
    assert chain.relays == [8, 7, 6, 5, 4]  # the highest ids relay, the highest nearest the lander
    spots = [chain.spots[rid] for rid in chain.relays]
    assert all(x == 0.0 for x, _ in spots)
    gaps = [b[1] - a[1] for a, b in zip([(0.0, 0.0), *spots], [*spots, (0.0, 130.0)], strict=True)]
    assert max(gaps) <= SPACING * 30.0 and max(gaps) - min(gaps) < 1e-2


def test_a_team_too_small_still_sends_one_rover_to_the_goal():
    assert list(plan_chain((0.0, 150.0), 130.0, [1, 2], 30.0, 30.0).spots) == [2]


def test_the_lander_holds_finished_rovers_until_the_chain_is_released():
    scenario = load_scenario(SCENARIOS / "daisy_chain.yaml")
    plan = MissionPlan(scenario)
    assert plan.direction_for(8).kind == "relay" and plan.direction_for(1).kind == "crater"
    assert plan.relay_chain == [8, 7, 6, 5, 4]
    assert plan.on_report(8, GoalReport(goal_index=0, outcome="relay")) == []
    assert plan.on_report(1, GoalReport(goal_index=0, outcome="reached")) == []
    assert plan.on_report(2, GoalReport(goal_index=0, outcome="reached")) == []
    assert plan.on_report(3, GoalReport(goal_index=0, outcome="reached")) == []  # last goal: released
    assert plan.outcome == {1: "reached", 2: "reached", 3: "reached", 4: "relay", 5: "relay", 6: "relay",
                            7: "relay", 8: "relay"}


def test_the_daisy_chain_scenario_keeps_rovers_connected_and_photos_reach_the_lander():
    scenario = load_scenario(SCENARIOS / "daisy_chain.yaml")
    archive = PhotoArchive(None)
    world = run_mission(scenario, 400, archive)
    report = world.report()
    assert report.complete and report.rover_collisions == 0 and report.obstacle_collisions == 0
    assert report.max_rovers_in_daisy_chain >= 4
    assert report.rovers_reached_final_goal == 3  # the three that are not relays stand on the rim
    assert len(archive.received) == 3 * 12  # every crater photo reached the lander through the chain
    assert report.worst_rover_connected_fraction >= 0.8
