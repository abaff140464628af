"""Run a whole mission in one process, with no router: the world, lander and rover agents wired
through their pure ``handle`` functions, every message still encoded and decoded with the codec.

Deterministic and fast: the behaviour checker and the tests of mission logic use it. As in lockstep, photos
arrive on their due tick, and an agent that publishes on a tick the world would not wait for (its
``next_wake`` misses a timer) is an error here. The cross-process path is tested separately over a real router.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from lander_agent.mission import MissionPlan
from lander_agent.runtime import Lander, PhotoArchive
from rover_agent.agent import RoverAgent
from rover_agent.behaviour import BaseBehaviour
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.mission import calibration
from schemas.scenario import Scenario
from world_service.lockstep import AckPlan
from world_service.sim import PhotoJob, World

Drop = Callable[[str, m.Message], bool]
"""Fault injection: says which samples the link loses (key and message); lost samples are never delivered."""


def run_mission(scenario: Scenario, max_sim_time: float, archive: PhotoArchive | None = None,
                behaviour: type[BaseBehaviour] | None = None, map_folder: Path | None = None,
                drop: Drop | None = None) -> World:
    """The world at the end; with ``map_folder``, the lander's traverse map is written there as it ends."""
    keys = ks.Keyspace("loopback")
    world = World(scenario, keys)
    world.lockstep = True
    lander = Lander(MissionPlan(scenario), keys, archive, map_folder)
    params = scenario.rover_params
    agents = {rid: RoverAgent(rid, keys, params, behaviour(rid, params) if behaviour else None,
                              dispatch=calibration(scenario, rid)) for rid in world.bodies}
    plan = AckPlan(keys, world.dt)
    photos: list[PhotoJob] = []

    def cascade(pending: list[tuple[str, m.Message]]) -> None:
        """Deliver samples and everything they set off, in order, until nothing more is said."""
        while pending:
            key, message = pending.pop(0)
            plan.note(key)
            if drop is not None and drop(key, message):
                continue
            pending += _deliver(key, codec.encode(message), world, lander, agents, keys)

    while world.sim_time < max_sim_time and not world.complete:
        photos += world.photo_jobs
        world.photo_jobs = []
        due = [(keys.rover(job.rover_id, ks.PHOTO), world.render(job)) for job in photos
               if job.due_tick <= world.tick + 1]
        photos = [job for job in photos if job.due_tick > world.tick + 1]
        out = world.step()
        clock = next(message for key, message in out if key == keys.clock)
        cascade([*due, *((key, message) for key, message in out if key != keys.clock)])
        clock = clock.model_copy(update={"acks": plan.ask(world.tick, {ks.LANDER_ID, *agents})})
        if clock.acks:  # as the world service: no clock on a tick that waits for nobody
            answers = _deliver(keys.clock, codec.encode(clock), world, lander, agents, keys)
            _note_acks(answers, plan, clock)
            cascade(answers)  # handled before the next tick, as the service handles what came before the acks
    world.observed_state()  # the final state, as the world service publishes it before its final report
    lander.final_map()
    return world


def _note_acks(answers: list[tuple[str, m.Message]], plan: AckPlan, clock: m.Clock) -> None:
    """Take the acks out of the agents' answers to the clock; anything from an agent not asked is an error."""
    for key, message in list(answers):
        if isinstance(message, m.Ack):
            answers.remove((key, message))
            plan.acked(plan.agent_of(key), message.tick, message.wake)
    for key, _ in answers:
        if plan.agent_of(key) not in clock.acks:
            raise AssertionError(f"{key} published on tick {clock.tick}, which the world does not wait for "
                                 f"(asked: {clock.acks}): the agent's next_wake() misses a timer")


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

