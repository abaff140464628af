"""The rover agent's Zenoh loop: subscribe to the rover's keys, feed the agent, publish what it returns."""

from __future__ import annotations

import logging
import threading

from bus.bus import Bus
from bus.process import freeze_start_up_heap
from bus.world_watch import ClockWatch
from rover_agent.agent import SUBSCRIBED_TOPICS, RoverAgent
from rover_agent.restarts.saved_state import STATE_WRITER
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m

log = logging.getLogger("lunarsim.rover")


def run(agents: RoverAgent | list[RoverAgent], bus: Bus, stop: threading.Event) -> None:
    """Run one agent, or several sharing this process and its Zenoh session (``--ids``): each keeps its own
    subscriptions and liveliness token, so the world and the router see them exactly as separate processes."""
    agents = [agents] if isinstance(agents, RoverAgent) else agents
    keys = agents[0].keys
    by_prefix: dict[str, RoverAgent] = {}
    bus.subscribe(keys.clock)  # before the tokens: the world starts the clock once it sees them
    for agent in agents:
        by_prefix[keys.rover(agent.id, "")] = agent
        for topic in SUBSCRIBED_TOPICS:
            bus.subscribe(keys.rover(agent.id, topic))
        bus.declare_token(keys.alive_rover(agent.id))
    who = f"rover {agents[0].id}" if len(agents) == 1 else f"rovers {agents[0].id}..{agents[-1].id}"
    watch = ClockWatch(who, keys.clock)
    log.info("%s: started on %s, waiting for the world's clock", who, keys.prefix)
    freeze_start_up_heap()
    try:
        _loop(agents, bus, stop, watch, by_prefix)
    finally:
        STATE_WRITER.flush()  # the states of the last actions, before the process ends
        for agent in agents:
            log.info("rover %d: stopping as %s at t = %.1f s; refused %d sample(s)", agent.id, agent.state,
                     agent.now, agent.rejected.total)


def _loop(agents: list[RoverAgent], bus: Bus, stop: threading.Event, watch: ClockWatch,
          by_prefix: dict[str, RoverAgent]) -> None:
    keys = agents[0].keys
    while not stop.is_set():
        item = bus.receive(timeout=0.2)
        watch.check()
        if item is None:
            continue
        if item.key == keys.clock:
            watch.heard()
            clock = _decode_clock(agents, item.payload)
            out = [o for agent in agents for o in agent.on_clock(clock)] if clock is not None else []
        else:
            prefix = item.key[:item.key.rindex("/") + 1]
            out = by_prefix[prefix].handle(item.key[len(prefix):], item.payload)
        for key, message in out:
            bus.publish(key, message)


def _decode_clock(agents: list[RoverAgent], payload: bytes) -> m.Clock | None:
    """Decoded once for every agent of the process; a bad one is counted by each, as separate processes would."""
    try:
        return codec.decode(m.Clock, payload)
    except codec.DecodeError as exc:
        for agent in agents:
            agent.rejected.count(ks.CLOCK, exc)
        log.warning("rover(s) %s: rejected clock sample: %s", ",".join(str(a.id) for a in agents), exc)
        return None
