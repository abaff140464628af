"""The world service process: the simulation clock and Zenoh I/O around ``World``.

Startup waits (up to ``start_timeout``) for the lander and every rover agent to announce themselves
with a liveliness token, so no rover misses the start. Then the clock runs in one of two ways:

- real time, scaled by ``time_scale`` (``<= 0``: as fast as the world can step);
- lockstep: after each tick the world waits until every live agent has acknowledged it (``Ack`` on
  its own ``ack`` key, sent after it has handled the tick and published its answers). What arrived in
  the meantime is handled in key order, so the run depends on the scenario and seed only, not on
  machine load, and goes as fast as the processes allow.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

from deploy.bus import Bus, Received
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from world_service.rover_ids import IdDesk
from world_service.sim import World

log = logging.getLogger("lunarsim.world")


@dataclass
class ClockSettings:
    time_scale: float = 1.0
    max_sim_time: float | None = None
    start_timeout: float = 30.0
    wait_for_lander: bool = True
    lockstep: bool = False
    ack_timeout: float = 30.0
    photo_dir: Path | None = None


class Photographer:
    """Renders the world's photo jobs and publishes (and saves) the PNGs.

    In lockstep a photo is rendered before the next tick, so runs stay reproducible; in real time a
    worker thread renders it, so a 0.4 s render does not stall the clock.
    """

    def __init__(self, world: World, bus: Bus, settings: ClockSettings) -> None:
        self.world, self.bus, self.settings = world, bus, settings
        self.inline = settings.lockstep
        self.pool = None if self.inline else ThreadPoolExecutor(max_workers=1, thread_name_prefix="camera")
        self.done: queue.SimpleQueue = queue.SimpleQueue()
        self.pending = 0

    def take(self) -> None:
        jobs, self.world.photo_jobs = self.world.photo_jobs, []
        for job in jobs:
            if self.inline:
                self._publish(job, self.world.render(job))
            else:
                self.pending += 1
                self.pool.submit(lambda j=job: self.done.put((j, self.world.render(j))))
        while not self.done.empty():
            self.pending -= 1
            self._publish(*self.done.get())

    def _publish(self, job, photo: m.Photo) -> None:
        self.bus.publish(self.world.keys.rover(job.rover_id, ks.PHOTO), photo)
        if self.settings.photo_dir is not None:
            self.settings.photo_dir.mkdir(parents=True, exist_ok=True)
            name = f"rover{job.rover_id}_t{job.stamp:09.2f}{'_' + job.label if job.label else ''}.png"
            (self.settings.photo_dir / name).write_bytes(photo.png)

    def close(self) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True)
            self.take()


@dataclass
class Agents:
    """Which agents are present (liveliness) and, in lockstep, which have acknowledged the current tick."""

    keys: ks.Keyspace
    present: set[str] = field(default_factory=set)
    acked: set[str] = field(default_factory=set)
    desk: IdDesk | None = None

    def ack_key_of(self, alive_key: str) -> str:
        if alive_key == self.keys.alive_lander:
            return self.keys.lander(ks.ACK)
        return self.keys.rover(self.keys.parse_alive_key(alive_key), ks.ACK)

    def waiting_for(self) -> set[str]:
        return {self.ack_key_of(k) for k in self.present} - self.acked


def declare_io(bus: Bus, keys: ks.Keyspace) -> None:
    for topic in World.INPUT_TOPICS:
        bus.subscribe(keys.rovers(topic))
    bus.subscribe(keys.lander(ks.COMM_OUT))
    bus.subscribe(keys.ground_command)
    bus.subscribe(keys.rovers(ks.ACK))
    bus.subscribe(keys.lander(ks.ACK))
    bus.watch_liveliness(keys.alive_rovers)
    bus.watch_liveliness(keys.alive_lander)


def note_liveliness(world: World, agents: Agents, item: Received) -> None:
    (agents.present.add if item.alive else agents.present.discard)(item.key)
    if item.key != world.keys.alive_lander:
        try:
            rover_id = world.keys.parse_alive_key(item.key)
        except ValueError as exc:
            log.warning("ignored liveliness token: %s", exc)
            return
        world.set_alive(rover_id, item.alive)
        if agents.desk is not None:
            agents.desk.note_alive(rover_id, item.alive)


def handle(world: World, bus: Bus, item: Received, agents: Agents) -> None:
    """Route one inbox item: liveliness updates the watchdog, acks the lockstep, data goes to the world."""
    if item.alive is not None:
        note_liveliness(world, agents, item)
    elif item.key.endswith(f"/{ks.ACK}"):
        _note_ack(world, agents, item)
    else:
        for key, message in world.receive(item.key, item.payload):
            bus.publish(key, message)


def _note_ack(world: World, agents: Agents, item: Received) -> None:
    try:
        if codec.decode(m.Ack, item.payload).tick == world.tick:
            agents.acked.add(item.key)
    except codec.DecodeError as exc:
        log.warning("rejected ack on %s: %s", item.key, exc)


def wait_for_agents(world: World, bus: Bus, settings: ClockSettings, stop: threading.Event) -> Agents:
    keys = world.keys
    agents = Agents(keys, desk=IdDesk(world.bodies))
    bus.serve(keys.rover_ids, lambda requester: codec.encode(agents.desk.grant(requester.decode(errors="replace"))))
    wanted = {keys.alive_rover(rid) for rid in world.bodies}
    if settings.wait_for_lander:
        wanted.add(keys.alive_lander)
    deadline = time.monotonic() + settings.start_timeout
    next_clock = 0.0
    while not stop.is_set() and not wanted <= agents.present and time.monotonic() < deadline:
        if time.monotonic() >= next_clock:
            bus.publish(keys.clock, world.clock(running=False))
            next_clock = time.monotonic() + 0.5
        item = bus.receive(timeout=0.1)
        if item is not None:
            handle(world, bus, item, agents)
    missing = sorted(wanted - agents.present)
    if missing:
        log.warning("starting without %d agent(s): %s", len(missing), ", ".join(missing))
    return agents


def _step(world: World, bus: Bus, photographer: Photographer) -> None:
    photographer.take()
    for key, message in world.step():
        bus.publish(key, message)


def _finished(world: World, settings: ClockSettings) -> bool:
    return world.complete or (settings.max_sim_time is not None and world.sim_time >= settings.max_sim_time)


def run(world: World, bus: Bus, settings: ClockSettings, stop: threading.Event) -> m.MissionReport:
    """Run the mission until every rover is done or stuck, ``max_sim_time`` passes, or ``stop`` is set."""
    world.time_scale, world.lockstep = (0.0, True) if settings.lockstep else (settings.time_scale, False)
    agents = wait_for_agents(world, bus, settings, stop)
    photographer = Photographer(world, bus, settings)
    try:
        (_run_lockstep if settings.lockstep else _run_realtime)(world, bus, settings, stop, agents, photographer)
    finally:
        photographer.close()
    bus.publish(world.keys.state, world.observed_state())  # the final state, then the report computed from it
    report = world.report()
    bus.publish(world.keys.stats, m.WorldStats(stamp=world.sim_time, report=report, final=True))
    return report


def _run_realtime(world: World, bus: Bus, settings: ClockSettings, stop: threading.Event, agents: Agents,
                  photographer: Photographer) -> None:
    period = world.dt / settings.time_scale if settings.time_scale > 0 else 0.0
    next_tick = time.monotonic()
    while not stop.is_set():
        for item in bus.drain():
            handle(world, bus, item, agents)
        _step(world, bus, photographer)
        if _finished(world, settings):
            return
        next_tick += period
        delay = next_tick - time.monotonic()
        if delay > 0:
            stop.wait(delay)
        elif delay < -1.0:
            next_tick = time.monotonic()  # fell far behind: do not sprint to catch up


def _run_lockstep(world: World, bus: Bus, settings: ClockSettings, stop: threading.Event, agents: Agents,
                  photographer: Photographer) -> None:
    while not stop.is_set():
        agents.acked.clear()
        _step(world, bus, photographer)
        if _finished(world, settings):
            return
        data = _collect_until_acked(world, bus, settings, stop, agents)
        for item in sorted(data, key=lambda r: r.key):  # stable: per-key order is kept
            handle(world, bus, item, agents)


def _collect_until_acked(world: World, bus: Bus, settings: ClockSettings, stop: threading.Event,
                         agents: Agents) -> list[Received]:
    """Gather the agents' answers to this tick until every live agent has acknowledged it."""
    data: list[Received] = []
    deadline = time.monotonic() + settings.ack_timeout
    while not stop.is_set() and agents.waiting_for():
        item = bus.receive(timeout=0.5)
        if item is None:
            if time.monotonic() > deadline:
                late = sorted(agents.waiting_for())
                log.warning("tick %d: no ack after %g s from %s; going on without them", world.tick,
                            settings.ack_timeout, ", ".join(late))
                agents.acked.update(late)
            continue
        if item.alive is not None:
            note_liveliness(world, agents, item)
        elif item.key.endswith(f"/{ks.ACK}"):
            _note_ack(world, agents, item)
        else:
            data.append(item)
    return data


def linger(world: World, bus: Bus, report: m.MissionReport, stop: threading.Event) -> None:
    """After the mission: keep answering with the final statistics until told to stop."""
    final = m.WorldStats(stamp=world.sim_time, report=report, final=True)
    stopped = world.clock(running=False)
    while not stop.wait(1.0):
        bus.publish(world.keys.stats, final)
        bus.publish(world.keys.clock, stopped)
