"""The rover agent's Zenoh loop: subscribe to this rover's keys, feed the agent, publish what it returns."""

from __future__ import annotations

import logging
import threading

from deploy.bus import Bus
from deploy.world_watch import ClockWatch
from rover_agent.agent import SUBSCRIBED_TOPICS, RoverAgent
from schemas import codec
from schemas import messages as m

log = logging.getLogger("lunarsim.rover")


def run(agent: RoverAgent, bus: Bus, stop: threading.Event) -> None:
    keys = agent.keys
    prefix = keys.rover(agent.id, "")
    for topic in SUBSCRIBED_TOPICS:
        bus.subscribe(keys.rover(agent.id, topic))
    bus.subscribe(keys.clock)
    bus.declare_token(keys.alive_rover(agent.id))
    watch = ClockWatch(f"rover {agent.id}", keys.clock)
    while not stop.is_set():
        item = bus.receive(timeout=0.2)
        watch.check()
        if item is None:
            continue
        if item.key == keys.clock:
            watch.heard()
            out = _on_clock(agent, item.payload)
        else:
            out = agent.handle(item.key[len(prefix):], item.payload)
        for key, message in out:
            bus.publish(key, message)


def _on_clock(agent: RoverAgent, payload: bytes) -> list:
    try:
        return agent.on_clock(codec.decode(m.Clock, payload))
    except codec.DecodeError as exc:
        agent.rejected += 1
        log.warning("rover %d: rejected clock sample: %s", agent.id, exc)
        return []
