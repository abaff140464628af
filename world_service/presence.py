"""Which agents are there, as the world service sees them: liveliness tokens coming and going, and in lockstep the
acks of the tick it waits on. No I/O: the service's loop hands each item here (``service.handle``).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field

from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from world_service.lockstep import LockstepTick
from world_service.rover_ids import IdDesk
from world_service.served import ServedWorld

log = logging.getLogger("lunarsim.world")


@dataclass
class Agents:
    """Which agents are present (liveliness) and, in lockstep, whose ack of the current tick is still due."""

    keys: ks.Keyspace
    present: set[str] = field(default_factory=set)
    ids: dict[str, int] = field(default_factory=dict)  # liveliness key -> agent id (0 the lander)
    desk: IdDesk | None = None
    tick: LockstepTick | None = None  # lockstep's schedule; None in real time

    def arrive(self, alive_key: str, agent: int) -> None:
        self.present.add(alive_key)
        self.ids[alive_key] = agent

    def leave(self, alive_key: str) -> None:
        self.present.discard(alive_key)
        agent = self.ids.pop(alive_key, None)
        if self.tick is not None and agent is not None:
            self.tick.forget(agent)


def note_liveliness(world: ServedWorld, agents: Agents, key: str, alive: bool) -> None:
    if not alive:
        agents.leave(key)
    if key == world.keys.alive_lander:
        if alive:
            agents.arrive(key, ks.LANDER_ID)
        world.set_lander_alive(alive)
        return
    try:
        rover_id = world.keys.parse_alive_key(key)
    except ValueError as exc:
        log.warning("ignored liveliness token: %s", exc)
        return
    if alive:
        agents.arrive(key, rover_id)
    world.set_alive(rover_id, alive)
    if agents.desk is not None:
        agents.desk.note_alive(rover_id, alive)


def note_ack(world: ServedWorld, agents: Agents, key: str, payload: bytes) -> None:
    """Acks matter only in lockstep (agents send none in real time), but a malformed one, or one naming a rover
    the scenario does not have, is counted and logged as any other rejected input, whatever the clock."""
    try:
        ack = codec.decode(m.Ack, payload)
        agent = acking_agent(world, key)
    except (codec.DecodeError, ValueError) as exc:
        world.count_rejected(key, exc)
        return
    if agents.tick is not None:
        agents.tick.ack(agent, ack)


def acking_agent(world: ServedWorld, key: str) -> int:
    """The agent an ack's key names: the lander by its own key, a rover by an id the scenario has (``rover/0``
    is no lander)."""
    if key == world.keys.lander(ks.ACK):
        return ks.LANDER_ID
    rover_id, _ = world.keys.parse_rover_key(key)
    if rover_id not in world.rover_ids:
        raise ValueError(f"no rover {rover_id} in this scenario")
    return rover_id


def agent_name(agent: int) -> str:
    return "the lander" if agent == ks.LANDER_ID else f"rover {agent}"
