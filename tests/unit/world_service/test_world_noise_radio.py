"""World models added for the full simulation: slip, slopes, radio latency and loss, link statistics."""

from __future__ import annotations

import math

import numpy as np

from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.scenario import parse_scenario
from world_service.actuation import navigation as nav
from world_service.radio.airtime import DELIVERIES_PER_S_PER_RADIO
from world_service.sim import World

KEYS = ks.Keyspace("unit")


def _world(rovers=((0.0, 0.0, 0.0),), lander=(-200.0, -200.0), walls=(), seed=1, **params) -> World:
    return World(parse_scenario({
        "name": "unit", "seed": seed, "lander": {"x": lander[0], "z": lander[1]},
        "rovers": [{"x": x, "z": z, "heading_deg": h} for x, z, h in rovers],
        "obstacles": {"walls": [{"points": list(w), "thickness_m": 1.0, "height_m": h} for w, h in walls]},
        "mission": [{"x": 0.0, "z": 300.0}],
        "rover_params": params,
    }), KEYS)


def _run_move(world: World, x: float, z: float, rover: int = 1) -> list[tuple[str, m.Message]]:
    out = world.receive(KEYS.rover(rover, ks.MOVE_ACTION), codec.encode(m.MoveAction(x=x, z=z)))
    for _ in range(400):
        out += world.step()
        if not world.actuator.bodies[rover].busy:
            return out
    raise AssertionError("the move never ended")


def test_without_slip_a_move_ends_exactly_on_its_goal():
    world = _world()
    _run_move(world, 0.0, 8.0)
    assert (world.actuator.bodies[1].x, world.actuator.bodies[1].z) == (0.0, 8.0)


def test_slip_moves_the_end_point_and_is_the_same_for_the_same_seed():
    ends = []
    for seed in (3, 3, 4):
        world = _world(seed=seed, navigation={"slip_std": 0.05, "heading_noise_std_deg": 2.0})
        _run_move(world, 0.0, 8.0)
        ends.append((world.actuator.bodies[1].x, world.actuator.bodies[1].z, world.actuator.bodies[1].heading))
    assert ends[0] == ends[1] != ends[2]
    x, z, _ = ends[0]
    assert math.hypot(x, z - 8.0) > 1e-6  # the rover believes (0, 8): dead reckoning drifts
    assert math.hypot(x, z - 8.0) < 8.0 * 0.05 * 6  # within six sigma


def test_climbing_is_slower_than_the_flat():
    params = _world().scenario.rover_params.navigation
    factors = nav.slope_factor(np.array([-10.0, 0.0, 12.5, 25.0, 40.0]), params)
    assert factors[0] == factors[1] == 1.0
    assert factors[2] == 1.0 - params.slope_slowdown / 2
    assert factors[3] == factors[4] == 1.0 - params.slope_slowdown


def test_radio_latency_delays_delivery_by_the_configured_time():
    world = _world(rovers=((0.0, 0.0, 0.0), (5.0, 0.0, 0.0)), communication={"latency_s": 0.5})
    msg = m.OutboundComm(targets=[2], payload=b"hello")
    assert world.receive(KEYS.rover(1, ks.COMM_OUT), codec.encode(msg)) == []
    arrived_at = None
    for _ in range(40):
        if any(k == KEYS.rover(2, ks.COMM_IN) for k, _ in world.step()):
            arrived_at = world.clock.sim_time
            break
    assert arrived_at is not None and abs(arrived_at - 0.5) < world.clock.dt + 1e-9


def test_radio_loss_drops_about_the_configured_share():
    world = _world(rovers=((0.0, 0.0, 0.0), (5.0, 0.0, 0.0)), communication={"loss_probability": 0.3})
    msg = codec.encode(m.OutboundComm(targets=[2], payload=b"x"))
    delivered = 0
    for _ in range(2000):  # one a tick: within the sender's airtime
        world.step()
        delivered += len(world.receive(KEYS.rover(1, ks.COMM_OUT), msg))
    assert world.radio.lost + delivered == 2000
    assert 0.25 < world.radio.lost / 2000 < 0.35


def test_a_sender_flooding_the_radio_gets_its_airtime_and_the_rest_is_counted():
    world = _world(rovers=((0.0, 0.0, 0.0), (5.0, 0.0, 0.0)))
    msg = codec.encode(m.OutboundComm(targets=[2], payload=b"x"))
    delivered = sum(len(world.receive(KEYS.rover(1, ks.COMM_OUT), msg)) for _ in range(1000))
    capacity = DELIVERIES_PER_S_PER_RADIO * 3  # two rovers and the lander: a second's worth at once
    assert delivered == capacity and world.rejected.by_topic[ks.COMM_OUT] == 1000 - capacity
    for _ in range(round(1.0 / world.clock.dt)):  # a second later the airtime is back, for the lander's traffic too
        world.step()
    assert len(world.receive(KEYS.rover(1, ks.COMM_OUT), msg)) == 1
    lander = codec.encode(m.OutboundComm(targets=[1, 2], payload=b"x"))
    assert len(world.receive(KEYS.lander(ks.COMM_OUT), lander)) == 2


def test_a_low_wall_does_not_hide_a_rover_from_the_lander_mast_but_a_high_one_does():
    rovers = ((0.0, 0.0, 0.0),)
    wall = ([(-10.0, 10.0), (10.0, 10.0)],)
    low = _world(rovers=rovers, lander=(0.0, 20.0), walls=[(wall[0], 1.0)])
    high = _world(rovers=rovers, lander=(0.0, 20.0), walls=[(wall[0], 5.0)])
    assert 1 in low.radio.graph.partners(ks.LANDER_ID)
    assert 1 not in high.radio.graph.partners(ks.LANDER_ID)


def test_leaving_the_lander_range_counts_a_connection_loss_and_disconnected_time():
    world = _world(rovers=((0.0, 0.0, 0.0),), lander=(0.0, -8.0), communication={"lander_comm_range": 10.0})
    _run_move(world, 0.0, 9.0)  # now 17 m from the lander
    for _ in range(round(3.0 / world.clock.dt)):
        world.step()
    report = world.report()
    assert report.lander_connection_losses == 1
    assert report.disconnected_time_s >= 2.0
    assert world.radio.graph.connected(1, ks.LANDER_ID) is False


def test_a_rover_between_the_lander_and_another_is_a_relay():
    world = _world(rovers=((0.0, 8.0, 0.0), (0.0, 16.0, 0.0)), lander=(0.0, 0.0),
                   communication={"lander_comm_range": 10.0})
    assert world.radio.graph.relays() == [1]
    assert world.radio.graph.connected(2, ks.LANDER_ID)


def test_a_crater_rim_between_two_rovers_blocks_their_link():
    def world(line_of_sight: bool) -> World:
        return World(parse_scenario({
            "name": "ridge", "lander": {"x": 200.0, "z": 200.0},
            # rover 1 on the plain 10 m outside the crest, rover 2 down in the bowl near the centre
            "rovers": [{"x": 0.0, "z": 48.0}, {"x": 0.0, "z": 5.0}],
            "craters": [{"x": 0.0, "z": 0.0, "radius_m": 38.0}],
            "mission": [{"x": 0.0, "z": 0.0, "kind": "crater"}],
            "rover_params": {"communication": {"comm_range": 100.0, "line_of_sight": line_of_sight}},
        }), KEYS)

    assert 2 not in world(True).radio.graph.partners(1)
    assert 2 in world(False).radio.graph.partners(1)
