"""The driver bridge's Zenoh loop: subscribe to the agent's keys (and the world clock), then alternate between the
inbox and the driver, publishing what the ``Bridge`` returns. The bridge itself does no I/O (``hardware.bridge``)."""

from __future__ import annotations

import logging
import threading

import zenoh

from bus import process
from bus.bus import Bus
from hardware.bridge import Bridge
from hardware.clock import MissionClock
from hardware.driver import Driver
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace

log = logging.getLogger("lunarsim.bridge")


def serve(driver: Driver, keys: Keyspace, rover_id: int, own_clock: bool, session: zenoh.Session) -> None:
    """Put ``driver`` on rover ``rover_id``'s keys until SIGINT or SIGTERM; ``own_clock``: publish a real-time clock
    (a bench, no world)."""
    bridge = Bridge(driver, keys, rover_id, MissionClock(own_clock))
    with Bus(session) as bus, process.stop_on_signals(process.SHUTDOWN_DEADLINE_S) as stop:
        bus.wake_on(stop)
        log.info("bridge for rover %d connected (driver %s)", rover_id, type(driver).__name__)
        run(bridge, bus, stop)


def run(bridge: Bridge, bus: Bus, stop: threading.Event) -> None:
    """Subscribe to the agent's keys (and the world clock), then alternate between the inbox and the driver."""
    prefix = bridge.key("")
    for topic in bridge.input_topics:
        bus.subscribe(bridge.key(topic))
    if not bridge.clock.own:
        bus.subscribe(bridge.keys.clock)
    bus.watch_liveliness(bridge.keys.alive_rover(bridge.id))
    while not stop.is_set():
        item = bus.receive(timeout=min(0.05, bridge.seconds_to_next()))
        out = []
        if item is not None and item.alive is not None:
            bridge.agent_alive(item.alive)
        elif item is not None and item.key == bridge.keys.clock:
            try:
                bridge.clock.on_clock(codec.decode(m.Clock, item.payload))
            except codec.DecodeError as exc:
                log.warning("rejected clock sample: %s", exc)
        elif item is not None:
            out = bridge.handle(item.key[len(prefix):], item.payload)
        for key, message in out + bridge.poll():
            bus.publish(key, message)
