"""Lost radio (``rover_agent.mission.contact``): a rover that waits for the lander's word and hears none heads for
the lander to regain contact, starting from its planned dispatch pose when no calibration came; the first word ends it.

Scripted sensor streams into a real ``RoverAgent``; the last test runs whole missions in process."""

from __future__ import annotations

import math

import pytest

from harness.loopback import run_mission
from rover_agent.agent import RoverAgent
from rover_agent.behaviour import Rotate
from rover_agent.mission.contact import CONTACT_WAIT_S
from scenarios.generator import generate
from schemas import codec, radio
from schemas import keyspace as ks
from schemas import messages as m
from schemas.params import RoverParams

KEYS = ks.Keyspace("w")
PARAMS = RoverParams()
DISPATCH = m.Calibration(x=30.0, z=40.0, heading_deg=90.0)
"""50 m north-east of the lander, facing east."""


def _feed(agent: RoverAgent, message: m.Message) -> list:
    topic = next(t for t, model in m.TOPIC_MODELS.items() if model is type(message))
    return agent.handle(topic, codec.encode(message))


def _running(agent: RoverAgent) -> RoverAgent:
    agent.on_clock(m.Clock(tick=0, sim_time=0.0, time_scale=1.0, run="r1"))
    return agent


def _sense(agent: RoverAgent, t: float) -> list:
    """A second of a quiet world: the clock, a level gyroscope and an empty perception at ``t``."""
    agent.on_clock(m.Clock(tick=int(t * 20), sim_time=t, time_scale=1.0, run="r1"))
    _feed(agent, m.Gyroscope(stamp=t, pitch_deg=0.0))
    return _feed(agent, m.Perception(stamp=t + 0.01, angles_deg=[], distances_m=[], kinds=[]))


def _moves(out: list) -> list[m.MoveAction]:
    return [msg for _, msg in out if isinstance(msg, m.MoveAction | m.RotateAction)]


def _silent_until_it_moves(agent: RoverAgent) -> tuple[float, list]:
    for t in range(1, 60):
        out = _moves(_sense(agent, float(t)))
        if out:
            return float(t), out
    raise AssertionError("the rover never went looking for the lander")


def test_a_rover_that_never_hears_the_lander_heads_for_it_from_its_planned_dispatch_pose():
    agent = _running(RoverAgent(1, KEYS, PARAMS, dispatch=DISPATCH))
    started, out = _silent_until_it_moves(agent)
    assert started >= CONTACT_WAIT_S
    assert (agent.pose.x, agent.pose.z) == (30.0, 40.0)
    action = out[0]
    if isinstance(action, m.MoveAction):  # relative to the rover facing east: the lander is behind and to the right
        assert action.x > 0 and action.z < 0
    else:
        assert 0 < action.degrees <= 180
    assert agent.mission.contact.seeking and "regain radio contact" in agent.status()[1].detail


def test_without_a_dispatch_pose_it_stays_and_says_it_does_not_know_where_it_is(caplog):
    agent = _running(RoverAgent(1, KEYS, PARAMS))
    for t in range(1, 40):
        assert _moves(_sense(agent, float(t))) == []
    assert agent.pose is None and "does not know where it is" in caplog.text


def test_a_few_seconds_of_silence_change_nothing():
    agent = _running(RoverAgent(1, KEYS, PARAMS, dispatch=DISPATCH))
    for t in range(1, int(CONTACT_WAIT_S) - 1):
        assert _moves(_sense(agent, float(t))) == []
    assert agent.pose is None and not agent.mission.contact.seeking


def test_the_first_mission_direction_ends_the_search_and_the_rover_takes_its_goal():
    agent = _running(RoverAgent(1, KEYS, PARAMS, dispatch=DISPATCH))
    _silent_until_it_moves(agent)
    flight = agent.actions.in_flight
    kind = "rotate" if isinstance(flight.decision, Rotate) else "move"
    _feed(agent, m.NavigationStatus(stamp=flight.sent_at + 2, action=kind, remaining=0.0, outcome="completed",
                                    action_id=flight.action_id))
    _feed(agent, m.MissionDirection(goal_index=0, goals_total=1, kind="waypoint", bearing_deg=0.0, distance_m=200.0))
    assert not agent.mission.contact.seeking and agent.state == "migration"
    assert agent.mission.goal.z == pytest.approx(200.0)
    assert agent.status()[1].detail == ""


def test_a_rover_between_goals_with_no_word_for_its_next_one_heads_for_the_lander():
    agent = _running(RoverAgent(1, KEYS, PARAMS))
    _feed(agent, m.Calibration(x=0.0, z=70.0, heading_deg=0.0))
    _feed(agent, m.MissionDirection(goal_index=0, goals_total=2, kind="waypoint", bearing_deg=0.0, distance_m=6.0))
    agent.finish("reached")  # the first goal done; its report will go unanswered
    assert agent.state == "waiting" and agent.mission.finished_goal == (0, "reached")
    started, _ = _silent_until_it_moves(agent)
    assert started >= CONTACT_WAIT_S and agent.mission.contact.seeking


def test_rovers_out_of_every_radio_reach_at_the_start_reach_their_goals():
    """Generated missions that start 1-2 rovers out of range of the lander and of every other rover: without the
    search they waited in silence until the watchdog counted them stuck."""
    cases = [g for g in map(generate, range(40)) if g.out_of_range and g.classes["noise"] in ("none", "low")][:3]
    assert cases
    for made in cases:
        world = run_mission(made.scenario, 1200.0)
        final = {r.id: r for r in world.referee.stats.last.rovers}
        for rid in made.out_of_range:
            assert final[rid].state in ("done", "relay"), (made.scenario.name, rid, final[rid])
            assert not final[rid].stalled
        assert world.complete and math.isfinite(world.report().mission_duration_s), made.scenario.name


def test_a_stop_from_the_lander_ends_the_search_and_the_rover_stays_stopped():
    """A rover looking for contact between goals is stopped (need N6). The stop comes by radio, so it is the lander's
    word: the search ends, and the direction of the goal it finished, sent again, must not set it off."""
    agent = _running(RoverAgent(1, KEYS, PARAMS))
    _feed(agent, m.Calibration(x=0.0, z=70.0, heading_deg=0.0))
    done = m.MissionDirection(goal_index=0, goals_total=2, kind="waypoint", bearing_deg=0.0, distance_m=76.0)
    _feed(agent, done)
    agent.finish("reached")
    _silent_until_it_moves(agent)
    agent.handle(ks.COMM_IN, codec.encode(m.InboundComm(sender=ks.LANDER_ID,
                                                        payload=radio.pack(radio.StopCommand()))))
    assert agent.state == "stopped" and not agent.mission.contact.seeking
    agent.actions.in_flight = None  # the cancel has come back
    for t in range(60, 60 + 3 * int(CONTACT_WAIT_S)):
        if t % 5 == 0:
            _feed(agent, done)
        assert _moves(_sense(agent, float(t))) == []
    assert agent.state == "stopped"


def test_a_search_that_got_nowhere_sets_off_again_after_another_wait():
    agent = _running(RoverAgent(1, KEYS, PARAMS, dispatch=DISPATCH))
    started, _ = _silent_until_it_moves(agent)
    agent.actions.in_flight = None
    agent.finish("stuck")  # blocked on the way: it waits, and says so
    assert agent.state == "waiting" and "blocked" in agent.status()[1].detail
    t = started + 1
    while not _moves(_sense(agent, t)):
        t += 1
        assert t < started + 3 * CONTACT_WAIT_S, "it never set off again"
    assert t - started >= CONTACT_WAIT_S
