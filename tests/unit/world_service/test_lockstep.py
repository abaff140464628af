"""Lockstep without waiting for every agent after every tick: whom the world waits for, what agents answer, and
photos rendered in a camera process on their due tick. The cross-process runs (determinism, shared processes)
are in test_e2e_run.py and test_shared_process.py; these need no router."""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import threading
from pathlib import Path

import numpy as np
import pytest

from bus import priority
from harness.loopback import run_mission
from harness.rounds import Rounds
from rover_agent.agent import RoverAgent
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.scenario import load_scenario
from shared.lockstep import lockstep_answer
from world_service.camera import rendering
from world_service.camera.photographer import APPROACH_RADII, CraterApproach, Photographer
from world_service.camera.photos import CameraProcess, build_ground
from world_service.lockstep import AckPlan, ClockResend, LockstepTick
from world_service.presence import Agents, note_ack
from world_service.sim import World
from world_service.terrain.views import DenseView, UncachedView

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"
KEYS = ks.Keyspace("test")
DT = 0.05


# ---- the world's side: whom a tick waits for ----


def test_a_tick_waits_only_for_agents_sent_a_sample_they_may_answer():
    plan = AckPlan(KEYS, DT)
    for agent in (0, 1, 2, 3):
        plan.acked(agent, 0, wake=10.0)
    plan.note(KEYS.rover(1, ks.GYROSCOPE))  # only updates what rover 1 knows
    plan.note(KEYS.rover(2, ks.PERCEPTION))  # rover 2 may decide and move
    plan.note(KEYS.lander(ks.COMM_IN))  # the lander may answer a goal report
    plan.note(KEYS.rover(3, ks.NAVIGATION_STATUS))
    assert plan.ask(1, {0, 1, 2, 3}) == [0, 2]
    assert plan.ask(2, {0, 1, 2, 3}) == [], "the record starts again after each tick"


def test_agents_are_asked_again_when_their_timers_are_due():
    plan = AckPlan(KEYS, DT)
    present = {1, 2}
    assert plan.ask(1, present) == [1, 2], "an agent that has not acked yet is asked every tick"
    plan.acked(1, 1, wake=1.0)  # due at tick 20
    plan.acked(2, 1, wake=None)  # may act on any tick
    assert [t for t in range(2, 25) if 1 in plan.ask(t, present)] == list(range(20, 25))
    assert all(2 in plan.ask(t, present) for t in range(25, 30))


def test_a_wake_time_in_the_past_still_means_the_next_tick():
    plan = AckPlan(KEYS, DT)
    plan.acked(1, 40, wake=0.5)
    assert plan.ask(40, {1}) == []
    assert plan.ask(41, {1}) == [1]


def test_the_agent_of_a_key_is_the_lander_or_the_rover_it_names():
    plan = AckPlan(KEYS, DT)
    assert plan.agent_of(KEYS.lander(ks.ACK)) == ks.LANDER_ID == plan.agent_of(KEYS.lander(ks.COMM_OUT))
    assert plan.agent_of(KEYS.rover(7, ks.ACK)) == 7
    with pytest.raises(ValueError):
        plan.agent_of(KEYS.clock)


def test_an_ack_counts_only_from_the_lander_s_key_or_a_rover_the_scenario_has():
    """``rover/0/ack`` is no lander: a forged ack there must not let a tick go on without it; it is counted."""
    world = World(load_scenario(SCENARIOS / "crater_observation.yaml"), KEYS)
    agents = Agents(KEYS, tick=LockstepTick(world))
    agents.tick.waiting = {ks.LANDER_ID, 1}
    ack = codec.encode(m.Ack(tick=world.clock.tick))
    for key in (KEYS.rover(0, ks.ACK), KEYS.rover(99, ks.ACK)):
        note_ack(world, agents, key, ack)
    assert agents.tick.waiting == {ks.LANDER_ID, 1} and world.rejected.by_topic[ks.ACK] == 2
    note_ack(world, agents, KEYS.lander(ks.ACK), ack)
    note_ack(world, agents, KEYS.rover(1, ks.ACK), ack)
    assert agents.tick.waiting == set()


def test_agents_that_left_are_not_waited_for():
    plan = AckPlan(KEYS, DT)
    plan.note(KEYS.rover(5, ks.PERCEPTION))
    plan.forget(5)
    assert plan.ask(1, {1}) == [1]


# ---- the agents' side ----


def _clock(tick: int, acks: list[int] | None) -> m.Clock:
    return m.Clock(tick=tick, sim_time=tick * DT, time_scale=0.0, lockstep=True, acks=acks)


def test_an_agent_acks_with_its_wake_time_only_when_asked():
    status = (KEYS.rover(1, ks.STATUS), m.RoverStatus(stamp=0.0, state="waiting"))
    asked = lockstep_answer([status], _clock(3, [1, 4]), 1, KEYS.rover(1, ks.ACK), lambda: 1.5)
    assert asked == [status, (KEYS.rover(1, ks.ACK), m.Ack(tick=3, wake=1.5))]
    assert lockstep_answer([], _clock(3, [4]), 1, KEYS.rover(1, ks.ACK), lambda: 1.5) == []
    everyone = lockstep_answer([], _clock(3, None), 1, KEYS.rover(1, ks.ACK), lambda: 1.5)
    assert everyone == [(KEYS.rover(1, ks.ACK), m.Ack(tick=3, wake=1.5))]


def test_a_lost_clock_is_sent_again_after_a_few_round_trips_never_later_than_50_ms():
    resend = ClockResend()
    assert resend.first_wait() == ClockResend.FIRST_MAX_S  # nothing learnt yet
    for _ in range(50):
        resend.acked(0.001, resent=False)
    assert resend.first_wait() == pytest.approx(ClockResend.FLOOR_S)  # 4 x 1 ms, below the floor
    for _ in range(50):
        resend.acked(0.003, resent=False)
    assert resend.first_wait() == pytest.approx(ClockResend.FACTOR * 0.003, rel=0.05)
    for _ in range(50):
        resend.acked(0.5, resent=True)  # ticks that needed a resend say nothing of the round trip
    assert resend.first_wait() == pytest.approx(ClockResend.FACTOR * 0.003, rel=0.05)
    for _ in range(50):
        resend.acked(0.040, resent=False)  # slow agents: no sooner than 50 ms, as before it learnt
    assert resend.first_wait() == ClockResend.FIRST_MAX_S


def test_resends_back_off_to_a_second():
    resend, wait, waits = ClockResend(), 0.005, []
    for _ in range(12):
        wait = resend.next_wait(wait)
        waits.append(wait)
    assert waits[:3] == [0.01, 0.02, 0.04] and waits[-1] == ClockResend.CEILING_S and resend.resends == 12


def test_publishing_on_a_tick_nobody_waits_for_is_reported(caplog):
    status = (KEYS.rover(1, ks.STATUS), m.RoverStatus(stamp=0.0, state="waiting"))
    with caplog.at_level(logging.WARNING, logger="lunarsim.lockstep"):
        out = lockstep_answer([status], _clock(7, [2]), 1, KEYS.rover(1, ks.ACK), lambda: 9.0)
    assert out == [status], "what it sends still goes out"
    assert "agent 1 publishes status on tick 7" in caplog.text and "next_wake" in caplog.text


def test_a_rover_agents_timers_fire_no_earlier_than_its_wake_time():
    """Drive a lone agent's clock tick by tick: whatever on_clock sends by itself comes at or after the wake time
    of its previous ack, which is what lets the world skip asking it in between."""
    agent = RoverAgent(1, KEYS, load_scenario(SCENARIOS / "crater_observation.yaml").rover_params)
    wake = 0.0
    for tick in range(1, 200):
        out = agent.on_clock(_clock(tick, None))
        sent = [key for key, message in out if not isinstance(message, m.Ack)]
        if sent:
            assert tick * DT >= wake - DT / 2, f"tick {tick} sent {sent} before its wake time {wake}"
        wake = next(message.wake for _, message in out if isinstance(message, m.Ack))
        if tick == 63:  # a finished goal adds the goal report's timer; it finishes on an input the world waits for
            agent.mission.finished_goal = (0, "reached")
            wake = 0.0
    assert agent.mission.reported_at > 3.0, "the goal report was sent (and resent) along the way"


def test_a_loopback_mission_keeps_to_the_plan_and_waits_for_few_agents(monkeypatch):
    """run_mission raises if an agent publishes on a tick it was not asked for; count how many ticks asked."""
    asked: list[list[int]] = []
    original = AckPlan.ask

    def counting(self, tick, present):
        asked.append(original(self, tick, present))
        return asked[-1]

    monkeypatch.setattr(AckPlan, "ask", counting)
    world = run_mission(load_scenario(SCENARIOS / "crater_observation.yaml"), max_sim_time=20.0)
    assert world.clock.tick == len(asked) and world.clock.tick >= 400
    mean = sum(map(len, asked)) / len(asked)
    assert mean < 2.0, f"a tick waited for {mean:.2f} of the 6 agents on average"


def test_an_answer_to_a_radio_delivery_reaches_the_world_after_its_next_step_as_over_zenoh():
    """The world service takes a tick's answers only once all are in, so what it delivers meanwhile is answered
    into the next tick. In process, a reply that came back within the tick put the daisy chain's release (goal
    report, the lander's answer, a relay's move) a tick ahead of ``lunarsim run --lockstep``."""
    rounds = Rounds(load_scenario(SCENARIOS / "crater_observation.yaml"), max_sim_time=5.0)
    ping = (rounds.keys.rover(1, ks.COMM_OUT), m.OutboundComm(targets=[2], payload=b"ping"))
    pong = (rounds.keys.rover(2, ks.COMM_OUT), m.OutboundComm(targets=[1], payload=b"pong"))
    heard, said, seen = rounds.advance({}), False, []
    while heard and len(seen) < 2:
        answers: dict[int, list] = {}
        for rid, samples in heard.items():
            for topic, payload in samples:
                if topic == ks.COMM_IN:
                    seen.append((rid, codec.decode(m.InboundComm, payload).payload, rounds.world.clock.tick))
                    answers[rid] = [pong] if rid == 2 else []
        if not said and 1 in heard and any(topic == ks.PERCEPTION for topic, _ in heard[1]):
            said, answers[1] = True, [ping]
        heard = rounds.advance(answers)
    (to2, ping_got, tick), (to1, pong_got, later) = seen
    assert (to2, ping_got, to1, pong_got) == (2, b"ping", 1, b"pong")
    assert later == tick + 1  # the rover said ping on a tick; the pong it drew came back on the next


# ---- photos ----


@pytest.fixture(scope="module")
def crater_world():
    scenario = load_scenario(SCENARIOS / "crater_observation.yaml")
    return scenario, World(scenario, KEYS)


def _photo_jobs(world: World) -> list:
    for rid in world.actuator.bodies:
        world.receive(KEYS.rover(rid, ks.PHOTO_ACTION), codec.encode(m.PhotoAction(label=f"rover{rid}")))
    return world.take_photo_jobs()


def test_a_photo_is_due_the_cameras_capture_time_after_its_action(crater_world):
    scenario, world = crater_world
    capture = scenario.rover_params.camera.capture_time_s
    assert all(job.due_tick == world.clock.tick + round(capture / world.clock.dt) for job in _photo_jobs(world))


@pytest.mark.parametrize("ahead", [True, False], ids=["ground-built-ahead", "ground-at-first-photo"])
def test_the_camera_process_renders_the_worlds_photos_byte_for_byte(crater_world, ahead):
    scenario, world = crater_world
    jobs = _photo_jobs(world)
    process = CameraProcess(scenario)
    try:
        if ahead:
            process.prepare()
        photos = [process.submit(job) for job in jobs]
        assert [f.result(timeout=60) for f in photos] == [world.render(job) for job in jobs]
    finally:
        process.close()


def _ground_built(process: CameraProcess) -> bool:
    """Whether the camera process holds its ground, asked in that process once what it was given before is done
    (one worker, first in first out)."""
    probe = "__import__('world_service.camera.photos', fromlist=['_'])._ground is not None"
    return process.pool.submit(eval, probe).result(timeout=60)


def test_the_camera_is_asked_for_its_ground_once_a_rover_nears_a_crater_goals_crater(crater_world):
    scenario, _ = crater_world
    crater = scenario.crater_of(next(goal for goal in scenario.mission if goal.kind == "crater"))
    approach = CraterApproach(scenario)
    starts = [(r.x, r.z) for r in scenario.rovers]
    assert not approach.reached(starts)  # the rovers start far off: a short run never builds it
    near = APPROACH_RADII * crater.radius_m * 0.99
    assert approach.reached([*starts, (crater.x + near, crater.z)])
    no_crater_goal = scenario.model_copy(update={"mission": [g.model_copy(update={"kind": "waypoint"})
                                                              for g in scenario.mission]})
    assert not CraterApproach(no_crater_goal).reached([(crater.x, crater.z)])


def test_a_lockstep_camera_builds_its_ground_once_the_published_state_shows_a_rover_near_the_crater(crater_world):
    scenario, _ = crater_world
    world = World(scenario, KEYS)  # its own: a rover is moved
    jobs = _photo_jobs(world)
    process = CameraProcess(scenario)
    try:
        photographer = Photographer(world, True, process)
        photographer.await_camera(threading.Event(), lambda: None)
        photographer.watch([(world.keys.state, world.observed_state())])
        assert not _ground_built(process)  # the rovers far from the crater: nothing built yet
        crater = scenario.crater_of(next(goal for goal in scenario.mission if goal.kind == "crater"))
        body = world.actuator.bodies[1]
        body.x, body.z = crater.x + crater.radius_m, crater.z
        photographer.watch([(world.keys.clock, world.clock.message()), (world.keys.state, world.observed_state())])
        assert _ground_built(process)
        assert [process.submit(job).result(timeout=60) for job in jobs] == [world.render(job) for job in jobs]
    finally:
        process.close()


@pytest.mark.parametrize("crater_goal", [True, False], ids=["crater-goal", "no-crater-goal"])
def test_a_real_time_camera_has_its_ground_before_the_clock_only_for_a_mission_with_a_crater_goal(crater_world,
                                                                                                 crater_goal):
    """A real-time clock does not wait for a photo: one of a crater's rim must not be late by the build. A mission
    with no crater goal builds nothing ahead, however near a crater its rovers drive."""
    scenario, _ = crater_world
    if not crater_goal:
        scenario = scenario.model_copy(update={"mission": [g.model_copy(update={"kind": "waypoint"})
                                                           for g in scenario.mission]})
    world = World(scenario, KEYS)
    process = CameraProcess(scenario)
    try:
        photographer = Photographer(world, False, process)
        photographer.await_camera(threading.Event(), lambda: None)
        assert process.ready().done() and _ground_built(process) == crater_goal
        crater = next(c for goal in scenario.mission if (c := scenario.crater_of(goal)) is not None)
        world.actuator.bodies[1].x, world.actuator.bodies[1].z = crater.x + crater.radius_m, crater.z
        photographer.watch([(world.keys.state, world.observed_state())])
        assert _ground_built(process) == crater_goal
    finally:
        process.close()


def test_a_camera_closed_while_it_builds_its_ground_ends_and_takes_no_more_work(crater_world):
    """A mission that ends before its first photo does not wait for a build nobody needs."""
    scenario, _ = crater_world
    process = CameraProcess(scenario)
    pid = process.started.result(timeout=60)
    process.prepare()
    process.close()
    assert not os.path.exists(f"/proc/{pid}")  # closed means joined: the process is gone, not a zombie
    with pytest.raises(RuntimeError):  # shut down
        process.prepare()


def test_the_camera_gives_way_in_a_real_time_crowd_only(crater_world):
    """With a crowd in real time it renders below the world, in the batch class and never idle, so other work on
    the machine cannot starve it; in lockstep the clock waits for it (bus.priority)."""
    scenario, _ = crater_world
    crowd = priority.CROWD
    cases = ((False, crowd, os.SCHED_BATCH), (False, 5, os.SCHED_OTHER), (True, crowd, os.SCHED_OTHER))
    for lockstep, rovers, policy in cases:
        process = CameraProcess(scenario, priority.for_camera(lockstep, rovers))
        try:
            assert process.pool.submit(os.sched_getscheduler, 0).result(timeout=60) == policy
        finally:
            process.close()


def _die_while_starting(*_args: object) -> None:
    """The camera's initializer, ending its process before it can answer any job: a signal from the test would race
    the start of a forked camera, which can answer first."""
    os._exit(1)


def test_the_clock_waits_for_the_camera_process_and_renders_itself_if_it_cannot_start(crater_world, caplog,
                                                                                      monkeypatch):
    scenario, world = crater_world
    stop, waits = threading.Event(), []
    process = CameraProcess(scenario)
    try:
        photographer = Photographer(world, True, process)
        photographer.await_camera(stop, lambda: waits.append(1))
        assert process.started.done() and photographer.camera is process  # up: it will render
    finally:
        process.close()
    monkeypatch.setattr("world_service.camera.photos._start", _die_while_starting)
    broken = CameraProcess(scenario)
    photographer = Photographer(world, True, broken)
    photographer.await_camera(stop, lambda: waits.append(1))
    assert photographer.camera is None and "the camera process died" in caplog.text  # photos rendered in the world
    broken.close()


def test_the_whole_grid_view_samples_the_same_heights_as_the_tiles(crater_world):
    scenario, world = crater_world
    dense = build_ground(scenario)
    assert isinstance(dense, DenseView)
    rng = np.random.default_rng(3)
    x = rng.uniform(-400, 400, 5000)  # inside and well outside the terrain (clamped at its edge)
    z = rng.uniform(-400, 400, 5000)
    assert np.array_equal(dense.height(x, z), world.terrain.height(x, z))


def test_the_height_bound_holds_over_the_whole_terrain(crater_world):
    _, world = crater_world
    assert float(world.terrain.heights.max()) <= world.terrain.max_height_bound()


class _NoBound:
    """The same ground without a height bound, so the camera marches every ray to its full range."""

    def __init__(self, terrain) -> None:
        self.terrain = terrain

    def height(self, x, z):
        return self.terrain.height(x, z)

    def grid_around(self, x, z, reach):
        return dataclasses.replace(self.terrain.grid_around(x, z, reach), ceiling=math.inf)


def test_dropping_rays_above_the_highest_ground_does_not_change_the_photo(crater_world):
    scenario, world = crater_world
    for body in world.actuator.bodies.values():
        args = (world.scene, np.zeros(0), np.zeros(0), 0.3, body.x, body.z, body.heading,
                scenario.rover_params.camera)
        fast = rendering.render(UncachedView(world.terrain), *args, tilt_deg=-5.0)  # looking up: much sky
        assert np.array_equal(fast, rendering.render(_NoBound(world.terrain), *args, tilt_deg=-5.0))
