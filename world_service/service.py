"""The world service's Zenoh loop: the simulation clock and the I/O around a world (``served.ServedWorld``: the
simulation or the hardware twin), which does none itself.

Startup waits (up to ``start_timeout``) for the lander and every rover agent to announce themselves
with a liveliness token, so no rover misses the start. Then the clock runs in one of two ways:

- real time, scaled by ``time_scale`` (``<= 0``: as fast as the world can step);
- lockstep: after each tick the world waits until every agent that may answer it has acknowledged it
  (``Ack`` on its own ``ack`` key, sent after it has handled the tick and published its answers; which
  agents may answer is ``world_service.lockstep``'s business). What arrived in the meantime is handled in
  key order, so the run depends on the scenario and seed only, not on machine load, and goes as fast as
  the processes allow.

Photos take the camera's ``capture_time_s`` of simulated time in both modes: a camera process renders them
meanwhile (``world_service.camera.photos``), and in lockstep the clock waits for a render not done when its photo
is due. The clock starts once that process is up.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import msgspec

from bus import priority, snapshot
from bus.bus import Bus, Received
from bus.process import freeze_start_up_heap
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from world_service.camera.photographer import Photographer
from world_service.camera.photos import CameraProcess
from world_service.lockstep import ClockResend, LockstepTick
from world_service.presence import Agents, agent_name, note_ack, note_liveliness
from world_service.rover_ids import IdDesk
from world_service.served import ServedWorld

if TYPE_CHECKING:
    from schemas.scenario import Scenario

log = logging.getLogger("lunarsim.world")

SAVE_PERIOD_S = 1.0
"""Simulated seconds between two saves of the world's state (``world_service.resume``): a rover walks at most 3.5 m
in that time, which a restart may cost it."""


@dataclass
class ClockSettings:
    time_scale: float = 1.0
    max_sim_time: float | None = None
    start_timeout: float = 30.0
    wait_for_lander: bool = True
    lockstep: bool = False
    ack_timeout: float = 30.0
    photo_dir: Path | None = None
    state_file: Path | None = None


def declare_io(bus: Bus, keys: ks.Keyspace, world: type[ServedWorld] | ServedWorld) -> None:
    """Subscribe to what ``world`` takes (``input_keys``) and watch the agents' liveliness tokens."""
    for key in world.input_keys(keys):
        bus.subscribe(key)
    bus.watch_liveliness(keys.alive_rovers)
    bus.watch_liveliness(keys.alive_lander)


def handle(world: ServedWorld, bus: Bus, item: Received, agents: Agents) -> None:
    """Route one inbox item: liveliness updates the watchdog, acks the lockstep, data goes to the world."""
    if item.alive is not None:
        note_liveliness(world, agents, item.key, item.alive)
    elif item.key.endswith(f"/{ks.ACK}"):
        note_ack(world, agents, item.key, item.payload)
    else:
        for key, message in world.receive(item.key, item.payload):
            _publish(bus, agents, key, message)


def _publish(bus: Bus, agents: Agents, key: str, message: m.Message) -> None:
    if agents.tick is not None:
        agents.tick.note([(key, message)])
    bus.publish(key, message)


def wait_for_agents(world: ServedWorld, bus: Bus, settings: ClockSettings, stop: threading.Event,
                    agents: Agents) -> None:
    """Until every rover's and the lander's token is there (or ``start_timeout``), answering id requests."""
    keys = world.keys
    agents.desk = IdDesk(world.rover_ids)
    bus.serve(keys.rover_ids, lambda requester: codec.encode(agents.desk.grant(requester.decode(errors="replace"))))
    wanted = {keys.alive_rover(rid) for rid in world.rover_ids}
    if settings.wait_for_lander:
        wanted.add(keys.alive_lander)
    log.info("run %s of %s (seed %d): waiting up to %g s for %d agent(s) on %s", world.clock.run_id,
             world.scenario.name, world.scenario.seed, settings.start_timeout, len(wanted), keys.prefix)
    deadline = time.monotonic() + settings.start_timeout
    next_clock = 0.0
    while not stop.is_set() and not wanted <= agents.present and time.monotonic() < deadline:
        if time.monotonic() >= next_clock:
            bus.publish(keys.clock, world.clock.message(running=False))
            next_clock = time.monotonic() + 0.5
        item = bus.receive(timeout=0.1)
        if item is not None:
            handle(world, bus, item, agents)
    world.set_lander_alive(keys.alive_lander in agents.present)  # one that never came is away from the start
    missing = sorted(wanted - agents.present)
    if missing:
        log.warning("starting without %d agent(s): %s", len(missing), ", ".join(missing))
    else:
        log.info("every agent is there (%d)", len(wanted))


def _step_realtime(world: ServedWorld, bus: Bus, photographer: Photographer, state_file: Path | None) -> None:
    """One tick in real time: due photos, the world's samples, then the clock at ``CLOCK_HZ`` (a granted step
    always shows it)."""
    for key, message in photographer.take(world.clock.tick + 1):
        bus.publish(key, message)
    world.dropped_messages = sum(bus.inbox.dropped.values())
    out = world.step()
    _keep(world, state_file)
    clock_key = world.keys.clock
    for key, message in out:
        if key != clock_key or world.clock.announced():
            bus.publish(key, message)


def _step_lockstep(world: ServedWorld, bus: Bus, photographer: Photographer, tick: LockstepTick, agents: Agents,
                   state_file: Path | None, tally: LockstepTally) -> None:
    """One tick in lockstep (``LockstepTick.step``): the clock goes out only when the tick waits for someone."""
    t0 = time.perf_counter()
    photos = photographer.take(world.clock.tick + 1)
    world.dropped_messages = sum(bus.inbox.dropped.values())
    samples, clock = tick.step(photos, set(agents.ids.values()))
    photographer.watch(samples)
    t1 = time.perf_counter()
    for key, message in samples:
        bus.publish(key, message)
    if clock is not None:
        bus.publish(world.keys.clock, clock)
    t2 = time.perf_counter()
    _keep(world, state_file)  # the tick is out: saved while the agents handle it, not before they get it
    tally.stepping += t1 - t0 + time.perf_counter() - t2
    tally.publishing += t2 - t1


def _keep(world: ServedWorld, state_file: Path | None) -> None:
    """The world's state, every ``SAVE_PERIOD_S`` simulated seconds, for a restart to resume."""
    if state_file is not None and world.RESUMABLE and world.clock.tick % world.clock.period(1.0 / SAVE_PERIOD_S) == 0:
        snapshot.save(world, state_file)


def _hold(world: ServedWorld, bus: Bus, agents: Agents, stop: threading.Event) -> None:
    """Paused by the ground: say so on the clock (agents answer nothing to a stopped clock) and handle what
    arrives, until a resume or a step."""
    bus.publish(world.keys.clock, world.clock.message(running=False))
    deadline = time.monotonic() + 0.5
    while not stop.is_set() and world.clock.hold.waiting and time.monotonic() < deadline:
        item = bus.receive(timeout=0.05)
        if item is not None:
            handle(world, bus, item, agents)


def start_camera(scenario: Scenario, lockstep: bool) -> CameraProcess:
    """The camera process of a world that renders its photos (``ServedWorld.RENDERS_PHOTOS``), forked before the
    world's Zenoh session opens. It builds its ground (Numba's loops, the terrain: most of a CPU second) when the
    photographer asks (``Photographer.await_camera`` says when), or at the first photo."""
    return CameraProcess(scenario, priority.for_camera(lockstep, len(scenario.rovers)))


def serve(world: ServedWorld, bus: Bus, settings: ClockSettings, stop: threading.Event, report_file: Path | None = None,
          lingering: bool = True, camera: CameraProcess | None = None) -> m.MissionReport:
    """The world service's life on ``bus``: the mission (``run``), its report written to ``report_file``, then, while
    ``lingering``, the final statistics until ``stop``. ``camera``: started already (``start_camera``), else
    ``run`` starts one."""
    declare_io(bus, world.keys, world)
    report = run(world, bus, settings, stop, camera)
    if report_file is not None:
        report_file.write_text(json.dumps(msgspec.to_builtins(report), indent=2) + "\n")
    if lingering:
        linger(world, bus, report, stop)
    return report


def run(world: ServedWorld, bus: Bus, settings: ClockSettings, stop: threading.Event,
        camera: CameraProcess | None = None) -> m.MissionReport:
    """Run the mission until every rover is done or stuck, ``max_sim_time`` passes, or ``stop`` is set."""
    world.clock.time_scale, world.clock.lockstep = (0.0, True) if settings.lockstep else (settings.time_scale, False)
    if camera is None and world.RENDERS_PHOTOS:
        camera = start_camera(world.scenario, settings.lockstep)  # starts while the agents connect
    elif not world.RENDERS_PHOTOS and camera is not None:
        camera.close()
        camera = None
    agents = Agents(world.keys)
    photographer = Photographer(world, settings.lockstep, camera, settings.photo_dir)
    try:
        try:
            wait_for_agents(world, bus, settings, stop, agents)
            photographer.await_camera(stop, lambda: bus.publish(world.keys.clock, world.clock.message(running=False)))
            freeze_start_up_heap()
            agents.tick = LockstepTick(world, settings.max_sim_time) if settings.lockstep else None
            log.info("clock started at t = %.1f s: %s", world.clock.sim_time,
                     "lockstep" if settings.lockstep else f"real time x {settings.time_scale:g}")
            (_run_lockstep if settings.lockstep else _run_realtime)(world, bus, settings, stop, agents, photographer)
        finally:
            for key, message in photographer.finish():
                bus.publish(key, message)
        if settings.state_file is not None:  # over, or stopped on purpose: a state is kept only by a world killed
            snapshot.discard(settings.state_file)
        bus.publish(world.keys.state, world.observed_state())  # the final state, then the report computed from it
        report = world.report()
        bus.publish(world.keys.stats, m.WorldStats(stamp=world.clock.sim_time, report=report, final=True))
    finally:
        photographer.close()  # after the report: the launcher need not wait for the camera process to end
    _log_end(world, report, stop.is_set())
    return report


def _log_end(world: ServedWorld, report: m.MissionReport, stopped: bool) -> None:
    how = "stopped" if stopped and not world.complete else "complete" if world.complete else "ended"
    log.info("mission %s at t = %.1f s: %d/%d rovers reached their final goal, %d stuck (%d counted by the "
             "watchdog)", how, world.clock.sim_time, report.rovers_reached_final_goal, report.rovers_total,
             report.rovers_stuck, report.rovers_stalled)
    refused = ", ".join(f"{n} on {topic}" for topic, n in sorted(world.rejected.by_topic.items()))
    log.info("refused %d sample(s)%s; dropped %d over the inbox's bound; agents refused %d", report.rejected_messages,
             f" ({refused})" if refused else "", report.dropped_messages, report.agent_rejected_messages)


def _run_realtime(world: ServedWorld, bus: Bus, settings: ClockSettings, stop: threading.Event, agents: Agents,
                  photographer: Photographer) -> None:
    period = world.clock.dt / settings.time_scale if settings.time_scale > 0 else 0.0
    next_tick = time.monotonic()
    while not stop.is_set():
        for item in bus.drain():
            handle(world, bus, item, agents)
        if world.clock.hold.held():
            _hold(world, bus, agents, stop)
            next_tick = time.monotonic()
            continue
        _step_realtime(world, bus, photographer, settings.state_file)
        if world.complete or (settings.max_sim_time is not None and world.clock.sim_time >= settings.max_sim_time):
            return
        next_tick += period
        delay = next_tick - time.monotonic()
        if delay > 0:
            stop.wait(delay)
        elif delay < -1.0:
            next_tick = time.monotonic()  # fell far behind: do not sprint to catch up


def _run_lockstep(world: ServedWorld, bus: Bus, settings: ClockSettings, stop: threading.Event, agents: Agents,
                  photographer: Photographer) -> None:
    """The schedule is ``LockstepTick``'s; this loop does its I/O: publishes, and waits for the acks."""
    tick = agents.tick
    tally = LockstepTally(start=time.perf_counter())
    resend = ClockResend()
    try:
        while not stop.is_set():
            while world.clock.hold.held() and not stop.is_set():
                _hold(world, bus, agents, stop)
            _step_lockstep(world, bus, photographer, tick, agents, settings.state_file, tally)
            if tick.over:
                return
            tally.ticks += 1
            tally.waited += bool(tick.waiting)
            t0 = time.perf_counter()
            _collect_until_acked(world, bus, settings, stop, agents, resend)
            t1 = time.perf_counter()
            late = tick.take()
            t2 = time.perf_counter()
            for key, message in late:
                bus.publish(key, message)
            tally.waiting += t1 - t0
            tally.taking += t2 - t1
            tally.publishing += time.perf_counter() - t2
    finally:
        log.info("%s; waiting for photos %.2f s; clocks sent again %d", tally.summary(world.clock.sim_time),
                 photographer.waited_s, resend.resends)


@dataclass
class LockstepTally:
    """Where a lockstep run's wall time went, logged at the end: the first thing to read when it is slow."""

    start: float
    ticks: int = 0
    waited: int = 0
    stepping: float = 0.0
    publishing: float = 0.0
    waiting: float = 0.0
    taking: float = 0.0
    cpu_start: float = field(default_factory=time.process_time)

    def summary(self, sim_time: float) -> str:
        """Also the world's own CPU time: far below the wall time, the world spends its steps waiting for a core."""
        wall = time.perf_counter() - self.start
        cpu = time.process_time() - self.cpu_start
        return (f"lockstep: {sim_time:.1f} s simulated in {wall:.2f} s ({sim_time / max(wall, 1e-9):.1f}x real "
                f"time); {self.ticks} ticks, {self.waited} waited for acks ({self.waiting:.2f} s), stepping "
                f"{self.stepping:.2f} s, publishing {self.publishing:.2f} s, taking answers {self.taking:.2f} s; the "
                f"world's CPU {cpu:.2f} s")


def _collect_until_acked(world: ServedWorld, bus: Bus, settings: ClockSettings, stop: threading.Event,
                         agents: Agents, resend: ClockResend) -> None:
    """Hand the tick the agents' answers until every agent it waits for has acknowledged it, sending its clock
    again while acks are overdue (``ClockResend``); then what else has arrived (answers no tick waited for, ground
    commands) without waiting for more."""
    tick = agents.tick
    sent = time.monotonic()
    deadline = sent + settings.ack_timeout
    wait = resend.first_wait()
    resend_at = sent + wait
    resent = False
    while not stop.is_set():
        item = bus.receive(timeout=min(0.5, max(0.0, resend_at - time.monotonic())) if tick.waiting else 0)
        if tick.waiting and tick.clock is not None and time.monotonic() > resend_at:
            bus.publish(world.keys.clock, tick.clock)
            wait, resent = resend.next_wait(wait), True
            resend_at = time.monotonic() + wait
        if item is None:
            if not tick.waiting:
                break
            if time.monotonic() > deadline:
                late = ", ".join(agent_name(agent) for agent in sorted(tick.waiting))
                log.warning("tick %d: no ack after %g s from %s; going on without them", world.clock.tick,
                            settings.ack_timeout, late)
                tick.waiting.clear()
            continue
        if item.alive is not None:
            note_liveliness(world, agents, item.key, item.alive)
        elif item.key.endswith(f"/{ks.ACK}"):
            awaited = bool(tick.waiting)
            note_ack(world, agents, item.key, item.payload)
            if awaited and not tick.waiting:
                resend.acked(time.monotonic() - sent, resent)
        else:
            tick.answer(item.key, item.payload)


def linger(world: ServedWorld, bus: Bus, report: m.MissionReport, stop: threading.Event) -> None:
    """After the mission: keep answering with the final statistics until told to stop."""
    final = m.WorldStats(stamp=world.clock.sim_time, report=report, final=True)
    stopped = world.clock.message(running=False)
    while not stop.wait(1.0):
        bus.publish(world.keys.stats, final)
        bus.publish(world.keys.clock, stopped)
