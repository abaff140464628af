"""The world service process: the simulation clock and Zenoh I/O around ``World``.

Startup waits (up to ``start_timeout``) for the lander and every rover agent to announce themselves
with a liveliness token, so no rover misses the start. Then it ticks in real time, scaled by
``time_scale``; ``time_scale <= 0`` runs as fast as it can.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass

from deploy.bus import Bus, Received
from schemas import keyspace as ks
from schemas import messages as m
from world_service.sim import World

log = logging.getLogger("lunarsim.world")


@dataclass
class ClockSettings:
    time_scale: float = 1.0
    max_sim_time: float | None = None
    start_timeout: float = 30.0
    wait_for_lander: bool = True


def declare_io(bus: Bus, keys: ks.Keyspace) -> None:
    for topic in World.INPUT_TOPICS:
        bus.subscribe(keys.rovers(topic))
    bus.subscribe(keys.lander(ks.COMM_OUT))
    bus.watch_liveliness(keys.alive_rovers)
    bus.watch_liveliness(keys.alive_lander)


def handle(world: World, bus: Bus, item: Received, present: set[str]) -> None:
    """Route one inbox item: liveliness updates the watchdog, data goes to the world."""
    if item.alive is not None:
        (present.add if item.alive else present.discard)(item.key)
        if item.key != world.keys.alive_lander:
            try:
                world.set_alive(world.keys.parse_alive_key(item.key), item.alive)
            except ValueError as exc:
                log.warning("ignored liveliness token: %s", exc)
        return
    for key, message in world.receive(item.key, item.payload):
        bus.publish(key, message)


def wait_for_agents(world: World, bus: Bus, settings: ClockSettings, stop: threading.Event) -> set[str]:
    keys = world.keys
    wanted = {keys.alive_rover(rid) for rid in world.bodies}
    if settings.wait_for_lander:
        wanted.add(keys.alive_lander)
    present: set[str] = set()
    deadline = time.monotonic() + settings.start_timeout
    next_clock = 0.0
    while not stop.is_set() and not wanted <= present and time.monotonic() < deadline:
        if time.monotonic() >= next_clock:
            bus.publish(keys.clock, m.Clock(tick=0, sim_time=0.0, time_scale=settings.time_scale, running=False))
            next_clock = time.monotonic() + 0.5
        item = bus.receive(timeout=0.1)
        if item is not None:
            handle(world, bus, item, present)
    missing = sorted(wanted - present)
    if missing:
        log.warning("starting without %d agent(s): %s", len(missing), ", ".join(missing))
    return present


def run(world: World, bus: Bus, settings: ClockSettings, stop: threading.Event) -> m.MissionReport:
    """Run the mission until every rover is done or stuck, ``max_sim_time`` passes, or ``stop`` is set."""
    present = wait_for_agents(world, bus, settings, stop)
    period = world.dt / settings.time_scale if settings.time_scale > 0 else 0.0
    next_tick = time.monotonic()
    while not stop.is_set():
        for item in bus.drain():
            handle(world, bus, item, present)
        for key, message in world.step():
            if key == world.keys.clock:
                message = message.model_copy(update={"time_scale": settings.time_scale})
            bus.publish(key, message)
        if world.complete or (settings.max_sim_time is not None and world.sim_time >= settings.max_sim_time):
            break
        next_tick += period
        delay = next_tick - time.monotonic()
        if delay > 0:
            stop.wait(delay)
        elif delay < -1.0:
            next_tick = time.monotonic()  # fell far behind: do not sprint to catch up
    report = world.report()
    bus.publish(world.keys.state, world.world_state())
    bus.publish(world.keys.stats, m.WorldStats(stamp=world.sim_time, report=report, final=True))
    return report


def linger(world: World, bus: Bus, report: m.MissionReport, stop: threading.Event) -> None:
    """After the mission: keep answering with the final statistics until told to stop."""
    final = m.WorldStats(stamp=world.sim_time, report=report, final=True)
    stopped = m.Clock(tick=world.tick, sim_time=world.sim_time, time_scale=0.0, running=False)
    while not stop.wait(1.0):
        bus.publish(world.keys.stats, final)
        bus.publish(world.keys.clock, stopped)
