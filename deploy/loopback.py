"""Run a whole mission in one process, with no router: the world, lander and rover agents wired
through their pure ``handle`` functions, every message still encoded and decoded with the codec.

Deterministic and fast: the behaviour checker and the tests of mission logic use it. Photos are rendered
before the next tick, as in lockstep. The cross-process path is tested separately over a real router.
"""

from __future__ import annotations

from pathlib import Path

from lander_agent.mission import MissionPlan
from lander_agent.runtime import Lander, PhotoArchive
from rover_agent.agent import RoverAgent
from rover_agent.behaviour import BaseBehaviour
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.scenario import Scenario
from world_service.sim import World


def run_mission(scenario: Scenario, max_sim_time: float, archive: PhotoArchive | None = None,
                behaviour: type[BaseBehaviour] | None = None, map_folder: Path | None = None) -> World:
    """The world at the end; with ``map_folder``, the lander's traverse map is written there as it ends."""
    keys = ks.Keyspace("loopback")
    world = World(scenario, keys)
    lander = Lander(MissionPlan(scenario), keys, archive, map_folder)
    params = scenario.rover_params
    agents = {rid: RoverAgent(rid, keys, params, behaviour(rid, params) if behaviour else None)
              for rid in world.bodies}
    pending: list[tuple[str, m.Message]] = []
    while world.sim_time < max_sim_time and not world.complete:
        photos, world.photo_jobs = world.photo_jobs, []  # rendered before the next tick, as in lockstep
        pending += [(keys.rover(job.rover_id, ks.PHOTO), world.render(job)) for job in photos]
        for key, message in world.step():
            pending += _deliver(key, codec.encode(message), world, lander, agents, keys)
        while pending:
            key, message = pending.pop(0)
            pending += _deliver(key, codec.encode(message), world, lander, agents, keys)
    world.observed_state()  # the final state, as the world service publishes it before its final report
    lander.final_map()
    return world


def _deliver(key, payload, world, lander, agents, keys):
    if key == keys.clock:
        out = lander.handle(key, payload)
        for agent in agents.values():
            out += agent.on_clock(codec.decode(m.Clock, payload))
        return out
    if key == keys.ground_command:  # the lander carries it out, the world follows it for its statistics
        return lander.handle(key, payload) + world.receive(key, payload)
    if key.startswith(keys.lander("")):
        return lander.handle(key, payload) if key != keys.lander(ks.COMM_OUT) else world.receive(key, payload)
    if key.startswith(f"{keys.prefix}/rover/"):
        rid, topic = keys.parse_rover_key(key)
        if topic in World.INPUT_TOPICS:
            return world.receive(key, payload)
        return agents[rid].handle(topic, payload)
    return []
