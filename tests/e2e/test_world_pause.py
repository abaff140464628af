"""The ground station holds the live world's clock: pause, step one tick at a time, resume (a real world service
over a real router, as the web view's controls and ``lunarsim command`` send them)."""

from __future__ import annotations

import pytest
import zenoh
from procs import SCENARIOS, module, stop, wait_for

from bus.zenoh_config import build_config
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace

pytestmark = pytest.mark.e2e


def test_pause_step_and_resume_hold_and_release_the_world_clock(router):
    keys = Keyspace("pause")
    world = module("world_service", str(SCENARIOS / "crater_observation.yaml"), "--world", "pause", "--connect",
                   router, "--start-timeout", "0", "--no-lander")
    clocks: list[m.Clock] = []

    def command(session: zenoh.Session, name: str) -> None:
        session.put(keys.ground_command, codec.encode(m.GroundCommand(command=name)))

    def last_running_tick_settles() -> int:
        wait_for(lambda: clocks and not clocks[-1].running, 10, "a stopped clock")
        return max(c.tick for c in clocks)

    try:
        with zenoh.open(build_config(connect=[router])) as session:
            sub = session.declare_subscriber(keys.clock, lambda s: clocks.append(
                codec.decode(m.Clock, s.payload.to_bytes())))
            wait_for(lambda: any(c.running and c.tick > 10 for c in clocks), 30, "the clock to run")
            command(session, "pause")
            paused_at = last_running_tick_settles()
            clocks.clear()
            wait_for(lambda: len(clocks) >= 2, 10, "two stopped clocks while paused")
            assert all(not c.running and c.tick == paused_at for c in clocks), clocks
            for expected in (paused_at + 1, paused_at + 2):
                command(session, "step")
                wait_for(lambda n=expected: any(c.tick == n for c in clocks), 10, f"tick {expected} after a step")
                wait_for(lambda n=expected: clocks[-1].tick == n and not clocks[-1].running, 10, "held again")
            command(session, "resume")
            wait_for(lambda: clocks[-1].running and clocks[-1].tick > paused_at + 20, 10, "the clock to run again")
            sub.undeclare()
        assert world.poll() is None, "the world keeps running"
    finally:
        stop(world)
    log = world.stdout.read()
    assert log.count("clock paused by a ground command") == 1, log  # the steps keep it paused: said once
    assert log.count("clock resumed by a ground command") == 1, log
