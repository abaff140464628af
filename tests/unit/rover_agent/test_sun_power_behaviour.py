"""Staying in the sun: the default behaviour charges in sunlight and keeps out of shadow when low;
``sun_ignoring`` does not; the agent does nothing while its rover is off. Scripted sensor data, no router,
then both behaviours on ``polar_night_edge`` in one process."""

from __future__ import annotations

import pytest
from agent_kit import RUN, joined_agent
from procs import SCENARIOS

from harness.loopback import run_mission
from rover_agent.behaviour import DefaultBehaviour, Goal, Hold, MoveTo, Rotate, View
from rover_agent.examples import SunIgnoring
from rover_agent.registry import load_behaviour
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.params import RoverParams
from schemas.scenario import load_scenario
from shared.pose import Pose

PARAMS = RoverParams()  # low_charge_fraction 0.5, recharge_to_fraction 0.95
GOAL = Goal(0, 1, "waypoint", 0.0, 50.0)
KEYS = ks.Keyspace("w")
ORIGIN = Pose(0.0, 0.0, 0.0)


def _view(battery=None, sunlit=None, pose=ORIGIN, time=0.0) -> View:
    return View(time, pose, GOAL, (), 0.0, battery, sunlit)


def _behaviour(cls=DefaultBehaviour):
    b = cls(1, PARAMS)
    b.start_goal(GOAL)
    return b


def test_with_charge_and_sun_or_without_power_sensors_the_decision_is_unchanged():
    plain = _behaviour().decide(_view())
    assert isinstance(plain, MoveTo)
    assert _behaviour().decide(_view(battery=0.9, sunlit=True)) == plain
    assert _behaviour().decide(_view(battery=0.9, sunlit=False)) == plain  # enough charge to cross a shadow


def test_low_in_sunlight_it_charges_up_then_goes_on():
    b = _behaviour()
    assert b.decide(_view(battery=0.3, sunlit=True)) == Hold(1.0)
    assert b.state == "charging"
    assert b.decide(_view(battery=0.7, sunlit=True, time=5.0)) == Hold(6.0)  # charging goes on to the top
    decision = b.decide(_view(battery=0.96, sunlit=True, time=10.0))
    assert isinstance(decision, MoveTo) and b.state == "migration"


def test_the_sun_ignoring_behaviour_walks_on_whatever_its_charge():
    decision = _behaviour(SunIgnoring).decide(_view(battery=0.2, sunlit=True))
    assert isinstance(decision, MoveTo)
    b = _behaviour(SunIgnoring)
    b.decide(_view(battery=0.4, sunlit=True))
    assert not b.should_cancel(_view(battery=0.4, sunlit=False))
    assert load_behaviour("sun_ignoring") is SunIgnoring


def test_walking_into_shadow_when_low_it_stops_and_walks_back_to_the_light():
    b = _behaviour()
    assert isinstance(b.decide(_view(battery=0.45, sunlit=True)), Hold)  # low: charges first...
    b = _behaviour()
    first = b.decide(_view(battery=0.6, sunlit=True))  # ...but with 0.6 it sets off, remembering (0, 0) as lit
    assert isinstance(first, MoveTo)
    assert not b.should_cancel(_view(battery=0.55, sunlit=True))
    assert b.should_cancel(_view(battery=0.45, sunlit=False))  # the panel went dark with the charge low
    b.cancelled(1.0)
    assert b.crowd.hold_until == 0.0  # no rover to give way to: no wait
    back = b.decide(_view(battery=0.44, sunlit=False, pose=Pose(0.0, 4.0, 0.0), time=1.2))
    assert back == Rotate(180.0) or back == Rotate(-180.0)  # turn round towards the lit spot behind
    back = b.decide(_view(battery=0.44, sunlit=False, pose=Pose(0.0, 4.0, 180.0), time=2.0))
    assert isinstance(back, MoveTo) and back.z == pytest.approx(4.0, abs=0.01)  # straight back to it
    assert b.decide(_view(battery=0.43, sunlit=True, pose=Pose(0.0, 0.0, 180.0), time=3.0)) == Hold(4.0)


def test_having_entered_a_shadow_with_enough_charge_it_crosses_it():
    b = _behaviour()
    b.decide(_view(battery=0.9, sunlit=True))
    b.decide(_view(battery=0.7, sunlit=False, pose=Pose(0.0, 9.0, 0.0), time=3.0))
    decision = b.decide(_view(battery=0.3, sunlit=False, pose=Pose(0.0, 18.0, 0.0), time=6.0))
    assert isinstance(decision, MoveTo) and decision.z > 0  # on, not back
    assert not b.should_cancel(_view(battery=0.2, sunlit=False))


def _feed(agent, message):
    topic = next(t for t, model in m.TOPIC_MODELS.items() if model is type(message))
    return agent.handle(topic, codec.encode(message))


def test_the_agent_does_nothing_while_its_rover_is_off_and_says_why():
    agent = joined_agent(1, KEYS, PARAMS)
    _feed(agent, m.Calibration(x=0.0, z=0.0, heading_deg=0.0))
    _feed(agent, m.MissionDirection(goal_index=0, goals_total=1, kind="waypoint", bearing_deg=0.0, distance_m=50.0))
    _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0))
    _feed(agent, m.Battery(stamp=0.1, charge_wh=0.0, capacity_wh=20.0, empty=True))
    assert _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[])) == []
    out = agent.on_clock(m.Clock(tick=100, sim_time=5.0, time_scale=1.0, run=RUN))
    status, = (msg for _, msg in out if isinstance(msg, m.RoverStatus))  # beside it, the estimate it shares
    assert status.detail == "off: battery empty"
    assert not any(isinstance(msg, m.MoveAction | m.RotateAction) for _, msg in out)
    _feed(agent, m.Battery(stamp=0.3, charge_wh=19.0, capacity_wh=20.0))
    _feed(agent, m.Temperature(stamp=0.3, celsius=-40.0, shutdown=True))
    assert _feed(agent, m.Perception(stamp=0.4, angles_deg=[], distances_m=[], kinds=[])) == []
    _feed(agent, m.Temperature(stamp=0.5, celsius=-15.0))
    _feed(agent, m.Sunlight(stamp=0.5, lit=True))
    (key, _), = _feed(agent, m.Perception(stamp=0.6, angles_deg=[], distances_m=[], kinds=[]))
    assert key == KEYS.rover(1, ks.MOVE_ACTION)


def test_on_polar_night_edge_the_default_rover_arrives_and_the_sun_ignoring_one_dies_in_shadow():
    scenario = load_scenario(SCENARIOS / "polar_night_edge.yaml")
    default = run_mission(scenario, 90.0).report()
    blind = run_mission(scenario, 90.0, behaviour=SunIgnoring).report()
    assert default.rovers_reached_final_goal == 1 and default.complete and default.power_shutdowns == 0
    assert blind.rovers_reached_final_goal == 0 and not blind.complete
    assert blind.power_shutdowns == 1 and blind.cold_shutdowns == 1  # empty in the dark, then frozen
    assert 0 < default.power_budget_efficiency <= 1 and default.energy_used_wh > blind.energy_used_wh
