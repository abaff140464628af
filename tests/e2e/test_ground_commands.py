"""Ground commands (needs N5, N6): the lander's plan, the rovers' response, and the command line."""

from __future__ import annotations

import math

import pytest
from procs import SCENARIOS, lunarsim, module, stop, wait_for

from harness.loopback import run_mission
from lander_agent.lander import Lander
from lander_agent.mission import MissionPlan
from schemas import keyspace as ks
from schemas import messages as m
from schemas.scenario import load_scenario
from shared.mission import CommandRefused

SCENARIO = load_scenario(SCENARIOS / "crater_observation.yaml")


def test_an_unknown_rover_is_refused_with_the_reason():
    lander = Lander(MissionPlan(SCENARIO), ks.Keyspace("t"))
    out = lander.on_ground_command(m.GroundCommand(request_id="r1", command="stop", rover_id=9))
    assert out == [(lander.keys.ground_command_result, m.CommandResult(
        request_id="r1", accepted=False, detail="there is no rover 9 (rovers are 1..5)"))]


@pytest.mark.parametrize("command", [
    m.GroundCommand(command="return"),
    m.GroundCommand(command="set_target", x=0.0),
    m.GroundCommand(command="set_target", x=100.0, z=100.0, kind="crater"),
])
def test_incomplete_or_impossible_commands_are_refused(command):
    with pytest.raises(CommandRefused):
        MissionPlan(SCENARIO).on_command(command)


def test_return_gives_the_rover_a_waypoint_at_the_lander():
    plan = MissionPlan(SCENARIO)
    assert plan.on_command(m.GroundCommand(command="return", rover_id=2)) == [2]
    direction = plan.direction_for(2)
    assert (direction.goal_index, direction.goals_total, direction.kind) == (1, 2, "waypoint")
    assert direction.distance_m == 0.0
    assert plan.direction_for(1).goal_index == 0  # the others keep their goal


def _with_command_at(time_s: float, command: m.GroundCommand):
    """A world whose ground station sends ``command`` at ``time_s`` (the loopback has no ground station)."""
    from world_service.sim import World

    original = World.step

    def step(self):
        out = original(self)
        if abs(self.clock.sim_time - time_s) < self.clock.dt / 2:
            out.append((self.keys.ground_command, command))
        return out

    return step


def test_a_rover_sent_back_goes_to_the_lander_and_the_mission_judges_it_there(monkeypatch):
    from world_service.sim import World

    monkeypatch.setattr(World, "step", _with_command_at(10.0, m.GroundCommand(command="return", rover_id=1)))
    world = run_mission(SCENARIO, 300)
    lander = SCENARIO.lander
    body = world.actuator.bodies[1]
    assert math.hypot(body.x - lander.x, body.z - lander.z) <= SCENARIO.rover_params.perception.perception_radius
    assert world.referee.status[1].state == "done" and world.report().rovers_reached_final_goal == 5


def test_a_stopped_rover_stays_put(monkeypatch):
    from world_service.sim import World

    monkeypatch.setattr(World, "step", _with_command_at(10.0, m.GroundCommand(command="stop", rover_id=3)))
    world = run_mission(SCENARIO, 300)
    assert world.referee.status[3].state == "stopped"
    assert world.actuator.bodies[3].distance_covered < 40  # it stopped early on its way (about 3.5 m/s for 10 s)
    assert world.complete and world.report().rovers_reached_final_goal == 4


@pytest.mark.e2e
def test_the_command_line_reaches_the_lander_and_reports_refusals(router, tmp_path):
    keys = ks.Keyspace("cmd")
    lander = module("lander_agent", str(SCENARIOS / "crater_observation.yaml"), "--world", "cmd",
                    "--connect", router)
    try:
        import zenoh

        from bus.zenoh_config import build_config

        with zenoh.open(build_config(connect=[router])) as session:
            alive = []
            token = session.liveliness().declare_subscriber(keys.alive_lander, lambda s: alive.append(s),
                                                            history=True)
            wait_for(lambda: alive, 30, "the lander")
            token.undeclare()
        refused = lunarsim("command", "stop", "--rover", "9", "--world", "cmd", "--connect", router)
        out, err = refused.communicate(timeout=60)
        assert refused.returncode == 1 and "refused: there is no rover 9" in out, out + err
        accepted = lunarsim("command", "return", "--rover", "2", "--world", "cmd", "--connect", router)
        out, err = accepted.communicate(timeout=60)
        assert accepted.returncode == 0 and "accepted: return sent to rover(s) 2" in out, out + err
        missing = lunarsim("command", "stop", "--rover", "1", "--world", "nobody", "--connect", router,
                           "--timeout", "1")
        out, err = missing.communicate(timeout=60)
        assert missing.returncode == 4 and "error: no lander answered" in err, err
    finally:
        stop(lander)


def test_a_repeated_command_is_answered_again_but_carried_out_once():
    plan = MissionPlan(load_scenario(SCENARIOS / "crater_observation.yaml"))
    command = m.GroundCommand(request_id="r7", command="return", rover_id=2)
    before = len(plan.missions.goals[2])
    assert plan.on_command(command) == [2]
    assert plan.on_command(command) == [2]  # the ground did not hear the first answer and sent it again
    assert len(plan.missions.goals[2]) == before + 1
    refused = m.GroundCommand(request_id="r8", command="stop", rover_id=9)
    for _ in range(2):
        with pytest.raises(CommandRefused, match="no rover 9"):
            plan.on_command(refused)


def test_a_target_beyond_any_scenario_is_dropped_as_malformed_and_the_lander_carries_on():
    """A ground client outside the checks of ``lunarsim command`` sends a target 10^12 m away: the lander counts it
    as a rejected sample (it cannot be a GroundCommand) and answers the next command as ever."""
    import msgpack

    from schemas import codec

    lander = Lander(MissionPlan(load_scenario(SCENARIOS / "crater_observation.yaml")), ks.Keyspace("far"))
    far = msgpack.packb([1, {"command": "set_target", "x": 1e12, "z": 0.0, "request_id": "a"}])
    assert lander.handle(lander.keys.ground_command, far) == [] and lander.rejected.total == 1
    stop = m.GroundCommand(request_id="b", command="stop", rover_id=1)
    (key, result), *_ = [o for o in lander.handle(lander.keys.ground_command, codec.encode(stop))
                         if isinstance(o[1], m.CommandResult)]
    assert key == lander.keys.ground_command_result and result.accepted and result.request_id == "b"
