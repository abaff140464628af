"""The daisy chain (report 6.5): relays placed by the lander keep every rover in touch with it."""

from __future__ import annotations

import math

import pytest
from procs import SCENARIOS

from harness.loopback import run_mission
from lander_agent.daisy_chain import SPACING, in_radio_reach, plan_chain, relays_needed
from lander_agent.mission import MissionPlan
from lander_agent.runtime import PhotoArchive
from schemas.radio import GoalReport
from schemas.scenario import load_scenario


@pytest.mark.parametrize(("reach", "lander_range", "comm_range", "needed"), [
    (20.0, 30.0, 30.0, 0), (25.5, 30.0, 30.0, 0), (50.0, 30.0, 30.0, 1), (130.0, 30.0, 30.0, 4),
    (130.0, 1000.0, 10.0, 0),
])
def test_the_fewest_relays_that_bridge_the_distance(reach, lander_range, comm_range, needed):
    assert relays_needed(reach, lander_range, comm_range) == needed
    assert needed <= math.ceil(reach / comm_range)  # at most one more than distance / range requires


def test_relay_spots_are_evenly_spaced_on_the_line_within_range():
    chain = plan_chain((0.0, 150.0), 130.0, [3, 1, 4, 2, 5, 6], 30.0, 30.0)
    assert chain.relays == [2, 4, 1, 3]  # the rovers nearest the goal relay, the nearest farthest out
    spots = [chain.spots[rid] for rid in chain.relays]
    assert all(x == 0.0 for x, _ in spots)
    gaps = [b[1] - a[1] for a, b in zip([(0.0, 0.0), *spots], [*spots, (0.0, 130.0)], strict=True)]
    assert max(gaps) <= SPACING * 30.0 and max(gaps) - min(gaps) < 1e-2


def test_a_team_too_small_still_sends_one_rover_to_the_goal():
    assert list(plan_chain((0.0, 150.0), 130.0, [1, 2], 30.0, 30.0).spots) == [1]


def test_the_lander_holds_finished_rovers_until_the_chain_is_released():
    scenario = load_scenario(SCENARIOS / "daisy_chain.yaml")
    plan = MissionPlan(scenario)
    # The front row (1-4) starts nearest the crater and forms the chain, the centre pair farthest out; the
    # back row goes on to the rim behind it, so nobody outruns the last relay.
    assert plan.relay_chain == [4, 1, 3, 2]
    assert plan.direction_for(2).kind == "relay" and plan.direction_for(5).kind == "crater"
    assert plan.direction_for(5).relayed and not plan.direction_for(2).relayed  # observers know of the chain
    assert plan.on_report(2, GoalReport(goal_index=0, outcome="relay")) == []
    assert plan.on_report(5, GoalReport(goal_index=0, outcome="reached")) == []
    assert plan.on_report(6, GoalReport(goal_index=0, outcome="reached")) == []
    assert plan.on_report(7, GoalReport(goal_index=0, outcome="reached")) == []
    assert plan.on_report(8, GoalReport(goal_index=0, outcome="reached")) == []  # last goal: released
    assert plan.outcome == {1: "relay", 2: "relay", 3: "relay", 4: "relay", 5: "reached", 6: "reached",
                            7: "reached", 8: "reached"}


def test_radio_reach_hops_from_the_lander_through_rovers_in_range():
    places = {1: (0.0, 25.0), 2: (0.0, 50.0), 3: (0.0, 75.0), 4: (0.0, 140.0), 5: (40.0, 0.0)}
    assert in_radio_reach(places, 30.0, 30.0) == {1, 2, 3}  # 4 is 65 m past the last hop; 5 is 40 m out
    assert in_radio_reach(places, 45.0, 30.0) == {1, 2, 3, 5}


def test_a_rover_set_down_out_of_radio_reach_is_not_made_a_relay_while_others_can_be():
    """It cannot be told to hold a spot until it finds the radio, and the spot would stand empty meanwhile;
    rovers the lander can reach take the spots, and it walks on to the goal once it hears the team."""
    scenario = load_scenario(SCENARIOS / "daisy_chain.yaml")
    rovers = list(scenario.rovers)
    rovers[1] = rovers[1].model_copy(update={"z": 110.0})  # nearest the crater, but 80 m beyond any radio
    plan = MissionPlan(scenario.model_copy(update={"rovers": rovers}))
    assert 2 not in plan.relay_chain and len(plan.relay_chain) == 4
    assert plan.direction_for(2).kind == "crater"


def test_the_daisy_chain_scenario_keeps_rovers_connected_and_photos_reach_the_lander():
    scenario = load_scenario(SCENARIOS / "daisy_chain.yaml")
    archive = PhotoArchive(None)
    world = run_mission(scenario, 400, archive)
    report = world.report()
    assert report.complete and report.rover_collisions == 0 and report.obstacle_collisions == 0
    # 130 m from the lander to the rim at 30 m range takes 4 relays; the issue allows one more, counted by
    # the world as every rover that carries another's traffic (an observer over the crest included).
    assert 4 <= report.max_rovers_in_daisy_chain <= math.ceil(130 / 30)
    assert report.rovers_reached_final_goal == 4  # the four that are not relays stand on the rim
    assert len(archive.received) == 4 * 12  # every crater photo reached the lander through the chain
    assert report.worst_rover_connected_fraction >= 0.95
