"""The daisy chain (report 6.5): relays placed by the lander keep every rover in touch with it."""

from __future__ import annotations

import math

import msgspec
import pytest
from procs import SCENARIOS

from harness.loopback import run_mission
from lander_agent.archive import PhotoArchive
from lander_agent.daisy_chain import SPACING, in_radio_reach, plan_chain, relays_needed
from lander_agent.lander import Lander
from lander_agent.mission import MissionPlan
from rover_agent.agent import RoverAgent
from schemas import codec, radio
from schemas import keyspace as ks
from schemas import messages as m
from schemas.params import RoverParams
from schemas.radio import GoalReport
from schemas.scenario import load_scenario
from schemas.truth import MissionReport

KEYS = ks.Keyspace("w")


def _feed(agent: RoverAgent, message: m.Message) -> list:
    topic = next(t for t, model in m.TOPIC_MODELS.items() if model is type(message))
    return agent.handle(topic, codec.encode(message))


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
    # The last observer is done, but a photo of its is still on the way: the chain must stand until it is in.
    assert plan.on_report(8, GoalReport(goal_index=0, outcome="reached", photos_pending=1)) == []
    assert plan.relay_chain == [4, 1, 3, 2]
    # Its photos in, nobody needs the route any more: the relays walk on to the crater they held it for.
    assert sorted(plan.on_report(8, GoalReport(goal_index=0, outcome="reached"))) == [1, 2, 3, 4]
    assert plan.relay_chain == [] and plan.outcome == {5: "reached", 6: "reached", 7: "reached", 8: "reached"}
    released = [plan.direction_for(rid) for rid in (1, 2, 3, 4)]
    assert all(d.kind == "crater" and d.goal_index == 0 for d in released)
    stations = [d.station for d in released]
    assert None not in stations and len(set(stations)) == 4  # each its own spot on the crest, free of the others'
    assert not set(stations) & {plan.direction_for(rid).station for rid in (5, 6, 7, 8)}
    plan.on_report(2, GoalReport(goal_index=0, outcome="reached"))
    assert plan.outcome[2] == "reached"


def test_a_chain_whose_far_end_has_gone_quiet_lets_its_relays_go():
    """A wall cuts the chain: rovers 7 and 8 beyond it never get a word through. The relays on the lander's side
    still hear it, so they would never cut off by themselves; the lander releases them once the far end has been
    quiet for ``relay_cut_off_s``, and takes the quiet rovers' reports whenever they come."""
    scenario = load_scenario(SCENARIOS / "daisy_chain.yaml")
    plan = MissionPlan(scenario)
    quiet_s = scenario.rover_params.communication.relay_cut_off_s
    for rid in (5, 6):
        plan.heard(rid, 10.0)
        plan.on_report(rid, GoalReport(goal_index=0, outcome="reached"))
    plan.heard(7, 20.0)  # heard once on its way, then lost behind the wall
    assert plan.release_quiet(20.0 + quiet_s - 1.0) == []
    assert plan.relay_chain == [4, 1, 3, 2]
    assert sorted(plan.release_quiet(20.0 + quiet_s)) == [1, 2, 3, 4]
    assert plan.relay_chain == [] and plan.outcome == {5: "reached", 6: "reached"}
    assert all(plan.direction_for(rid).kind == "crater" for rid in (1, 2, 3, 4))
    plan.on_report(7, GoalReport(goal_index=0, outcome="reached"))
    assert plan.outcome[7] == "reached" and 8 not in plan.outcome


def test_the_lander_notes_when_it_last_heard_each_rover_of_its_plan():
    lander = Lander(MissionPlan(load_scenario(SCENARIOS / "daisy_chain.yaml")), KEYS)
    lander.now = 30.0
    report = radio.pack(GoalReport(goal_index=0, outcome="reached"))
    lander.on_comm_in(m.InboundComm(sender=5, payload=report))
    lander.on_comm_in(m.InboundComm(sender=40, payload=report))  # no rover of the plan: nothing to note
    assert lander.plan.heard_at == {5: 30.0}


def test_a_rover_heard_again_keeps_the_chain_standing():
    scenario = load_scenario(SCENARIOS / "daisy_chain.yaml")
    plan = MissionPlan(scenario)
    quiet_s = scenario.rover_params.communication.relay_cut_off_s
    for rid in (5, 6, 7):
        plan.on_report(rid, GoalReport(goal_index=0, outcome="reached"))
    plan.heard(8, quiet_s)  # still walking, its map reports coming in
    assert plan.release_quiet(quiet_s + 1.0) == [] and plan.relay_chain == [4, 1, 3, 2]


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


RELAY_DIRECTION = m.MissionDirection(goal_index=0, goals_total=1, kind="relay", bearing_deg=0.0, distance_m=26.0,
                                     relay_for=m.GoalPlace(kind="crater", bearing_deg=0.0, distance_m=130.0))


def _relay_on_its_spot(params: RoverParams | None = None) -> RoverAgent:
    agent = RoverAgent(1, KEYS, params or RoverParams())
    agent.on_clock(m.Clock(tick=0, sim_time=0.0, time_scale=1.0, run="r1"))
    _feed(agent, m.Calibration(x=0.0, z=5.0, heading_deg=0.0))
    _feed(agent, RELAY_DIRECTION)
    agent.finish("relay")
    return agent


def _sense(agent: RoverAgent, t: float) -> list:
    agent.on_clock(m.Clock(tick=int(t * 20), sim_time=t, time_scale=1.0, run="r1"))
    _feed(agent, m.Gyroscope(stamp=t, pitch_deg=0.0))
    return _feed(agent, m.Perception(stamp=t + 0.01, angles_deg=[], distances_m=[], kinds=[]))


def _quiet_until(agent: RoverAgent, end_s: float, heard_every_s: float | None = None) -> None:
    for t in range(1, int(end_s) + 1):
        if heard_every_s is not None and t % heard_every_s == 0:
            _feed(agent, RELAY_DIRECTION)
        _sense(agent, float(t))


def test_the_lander_tells_a_relay_the_goal_it_holds_the_route_for():
    plan = MissionPlan(load_scenario(SCENARIOS / "daisy_chain.yaml"))
    relay, observer = plan.direction_for(2), plan.direction_for(5)
    assert relay.relay_for == m.GoalPlace(kind="crater", bearing_deg=observer.bearing_deg,
                                          distance_m=observer.distance_m)
    assert observer.relay_for is None


def test_a_relay_cut_off_from_the_lander_at_the_last_goal_walks_on_to_it_and_not_back():
    params = RoverParams()
    agent = _relay_on_its_spot(params)
    cut_off = params.communication.relay_cut_off_s
    _quiet_until(agent, cut_off - 5)
    assert agent.state == "relay"  # a quiet spell is not yet a cut chain
    _quiet_until(agent, cut_off + 2)
    assert agent.state == "migration" and agent.mission.goal.kind == "crater"
    assert agent.mission.goal.z == pytest.approx(130.0)
    _feed(agent, RELAY_DIRECTION)  # the chain's word again, say a link came back: it does not walk back
    assert agent.mission.goal.kind == "crater" and agent.mission.finished_goal is None


@pytest.mark.parametrize("release", [True, False])
def test_a_relay_that_hears_the_lander_or_is_told_to_hold_stays(release):
    params = RoverParams()
    comm = msgspec.structs.replace(params.communication, release_relays=release)
    params = msgspec.structs.replace(params, communication=comm)
    agent = _relay_on_its_spot(params)
    _quiet_until(agent, params.communication.relay_cut_off_s * 2, heard_every_s=1 if release else None)
    assert agent.state == "relay"


def test_a_relay_goes_on_to_the_last_goal_once_the_lander_releases_it_and_not_before():
    agent = _relay_on_its_spot()
    assert agent.state == "relay" and agent.mission.finished_goal == (0, "relay")
    _feed(agent, m.MissionDirection(goal_index=0, goals_total=1, kind="relay", bearing_deg=0.0, distance_m=26.0))
    assert agent.state == "relay"  # the chain's direction again, resent every second: it holds
    _feed(agent, m.MissionDirection(goal_index=0, goals_total=1, kind="crater", bearing_deg=0.0, distance_m=130.0,
                                    station=(0.0, -20.0), shared=True))
    assert agent.state == "migration" and agent.mission.finished_goal is None
    assert agent.mission.goal.station == (0.0, -20.0)


def test_a_rover_tells_the_lander_how_many_photos_it_still_holds_with_its_goal_report():
    agent = _relay_on_its_spot()
    agent.photos.reports["crest-1"] = radio.PhotoReport(goal_index=0, label="crest-1", stamp=1.0, png=b"x")
    sent = [radio.unpack(msg.payload) for _, msg in agent._report_goal()]
    assert sent == [radio.GoalReport(goal_index=0, outcome="relay", photos_pending=1)]


def _daisy_chain_mission(release: bool) -> tuple[MissionReport, PhotoArchive]:
    scenario = load_scenario(SCENARIOS / "daisy_chain.yaml")
    comm = msgspec.structs.replace(scenario.rover_params.communication, release_relays=release)
    scenario = scenario.with_overrides(rover_params=msgspec.structs.replace(scenario.rover_params, communication=comm))
    archive = PhotoArchive(None)
    report = run_mission(scenario, 400, archive).report()
    assert report.complete and report.rover_collisions == 0 and report.obstacle_collisions == 0
    # 130 m from the lander to the rim at 30 m range takes 4 relays; the issue allows one more, counted by
    # the world as every rover that carries another's traffic (an observer over the crest included).
    assert 4 <= report.max_rovers_in_daisy_chain <= math.ceil(130 / 30)
    assert len(archive.received) >= 4 * 12  # every photo of the four observers reached the lander through the chain
    return report, archive


def test_the_daisy_chain_keeps_rovers_connected_while_photos_reach_the_lander_then_its_relays_walk_on():
    report, archive = _daisy_chain_mission(release=True)
    # All four relays walk on; one may stop short of the crest by its estimate after 80-100 m of the shipped slip.
    assert report.rovers_holding_relay_spots == 0 and report.rovers_reached_final_goal >= 7
    # The relays' own photos wait on board: nobody is left between them and the lander.
    assert len(archive.received) == 4 * 12 and report.worst_rover_connected_fraction < 0.95


def test_a_daisy_chain_told_to_hold_keeps_every_rover_in_touch_to_the_end():
    report, archive = _daisy_chain_mission(release=False)
    assert report.rovers_reached_final_goal == 4 and report.rovers_holding_relay_spots == 4
    assert len(archive.received) == 4 * 12 and report.worst_rover_connected_fraction >= 0.95
