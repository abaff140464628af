"""Lockstep without waiting for every agent after every tick: whom the world waits for, when what agents
answer takes effect, what agents answer, and photos rendered in a camera process on their due tick. The
cross-process runs (determinism, shared processes) are in test_e2e_run.py and test_shared_process.py; these
need no router."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from deploy.bus import Received
from deploy.loopback import run_mission
from rover_agent.agent import RoverAgent
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.lockstep import acts_on, lockstep_answer
from schemas.scenario import load_scenario
from world_service import camera
from world_service.lockstep import AckPlan, AnswerBook
from world_service.photos import CameraProcess, build_ground
from world_service.sim import World
from world_service.terrain import DenseView

SCENARIOS = Path(__file__).resolve().parent.parent / "scenarios"
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
    assert plan.ask(1, present) == [1, 2], "an agent that has not acked yet is asked"
    assert plan.ask(2, present) == [], "and then not again until its ack says when its timers are due"
    plan.acked(1, 1, wake=1.0)  # due at tick 20
    plan.acked(2, 1, wake=None)  # may act on any tick
    asks = {tick: plan.ask(tick, present) for tick in range(3, 25)}
    assert [tick for tick, asked in asks.items() if 1 in asked] == [20], "asked once its timers are due"
    assert [tick for tick, asked in asks.items() if 2 in asked] == [3], "no wake time: the next tick"


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


def test_agents_that_left_are_not_waited_for():
    plan = AckPlan(KEYS, DT)
    plan.note(KEYS.rover(5, ks.PERCEPTION))
    plan.forget(5)
    assert plan.ask(1, {1}) == [1]


# ---- the world's side: when answers take effect ----


def _sample(rover: int, topic: str = ks.MOVE_ACTION, payload: bytes = b"") -> Received:
    return Received(KEYS.rover(rover, topic), payload)


def _book(asked_on: dict[int, set[int]]) -> AnswerBook:
    """A book whose plan asked ``asked_on[tick]`` on each tick (the agents were sent perception)."""
    book = AnswerBook(AckPlan(KEYS, DT))
    for tick, agents in sorted(asked_on.items()):
        for agent in agents:
            book.plan.note(KEYS.rover(agent, ks.PERCEPTION))
        assert book.ask(tick, agents) == sorted(agents)
    return book


def test_answers_take_effect_with_the_tick_they_answer_not_as_they_arrive():
    """The world steps tick 2 while the rovers work on tick 1: rover 1 is quick and answers tick 2 before rover
    2 has answered tick 1. Tick 1's answers are rover 1's first and rover 2's, in key order; not the second."""
    book = _book({1: {1, 2}, 2: {1, 2}})
    book.add(_sample(1, payload=b"1 at tick 1"), 1)
    book.ack(1, 1, wake=5.0)
    book.add(_sample(1, payload=b"1 at tick 2"), 1)
    book.ack(1, 2, wake=5.0)
    assert not book.ready(1), "rover 2 has not answered tick 1"
    book.add(_sample(2, ks.ROTATE_ACTION, b"2 at tick 1"), 2)
    book.ack(2, 1, wake=5.0)
    assert book.ready(1) and not book.ready(2)
    assert [item.payload for item in book.take(1)] == [b"1 at tick 1", b"2 at tick 1"]
    book.ack(2, 2, wake=5.0)
    assert [item.payload for item in book.take(2)] == [b"1 at tick 2"]


def test_a_wake_time_counts_once_the_ack_carrying_it_takes_effect():
    book = _book({1: {1}})
    book.ack(1, 1, wake=0.0)  # due at once: but the world steps tick 2 before this ack takes effect
    assert book.plan.ask(2, {1}) == []
    book.take(1)
    assert book.plan.ask(3, {1}) == [1]


def test_giving_up_on_an_agent_applies_its_late_answer_with_the_next_tick():
    book = _book({1: {1, 2}, 2: {1}})
    book.ack(1, 1, wake=9.0)
    assert book.give_up(1) == [2]
    assert book.take(1) == []
    book.add(_sample(2, payload=b"late"), 2)
    book.ack(2, 1, wake=0.5)
    book.ack(1, 2, wake=9.0)
    assert [item.payload for item in book.take(2)] == [b"late"]
    assert book.plan.ask(11, {2}) == [2], "the late ack's wake time counts too"


def test_an_agent_that_leaves_is_not_waited_for_and_what_it_sent_still_takes_effect():
    book = _book({1: {1, 2}})
    book.add(_sample(2, payload=b"last words"), 2)
    book.ack(1, 1, wake=9.0)
    book.leave(2)
    assert book.ready(1)
    assert [item.payload for item in book.take(1)] == [b"last words"]


# ---- the agents' side ----


def _clock(tick: int, acks: list[int] | None) -> m.Clock:
    return m.Clock(tick=tick, sim_time=tick * DT, time_scale=0.0, lockstep=True, acks=acks)


def test_an_agent_acts_on_a_lockstep_clock_only_when_asked_and_acks_after_its_answers():
    assert acts_on(_clock(3, [1, 4]), 1) and acts_on(_clock(3, None), 1)
    assert not acts_on(_clock(3, [4]), 1)
    assert not acts_on(_clock(3, None).model_copy(update={"running": False}), 1)
    realtime = m.Clock(tick=3, sim_time=0.15, time_scale=1.0)
    assert acts_on(realtime, 1)
    status = (KEYS.rover(1, ks.STATUS), m.RoverStatus(stamp=0.0, state="waiting"))
    answer = lockstep_answer([status], _clock(3, [1, 4]), KEYS.rover(1, ks.ACK), 1.5)
    assert answer == [status, (KEYS.rover(1, ks.ACK), m.Ack(tick=3, wake=1.5))]
    assert lockstep_answer([status], realtime, KEYS.rover(1, ks.ACK), 1.5) == [status]


def test_a_rover_agents_timers_wait_for_a_tick_it_is_asked_on():
    """Its status is due every second: on a tick the world does not ask it for, it stays silent (what it sent
    would take effect whenever it arrived); it sends the status on the next tick it is asked on."""
    agent = RoverAgent(1, KEYS, load_scenario(SCENARIOS / "crater_observation.yaml").rover_params)
    assert [key for key, _ in agent.on_clock(_clock(1, [1]))] == [KEYS.rover(1, ks.STATUS), KEYS.rover(1, ks.ACK)]
    assert agent.next_wake() == pytest.approx(1.05)
    assert agent.on_clock(_clock(21, [2])) == [], "due, but not asked"
    assert next(key for key, _ in agent.on_clock(_clock(23, [1]))) == KEYS.rover(1, ks.STATUS)


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
            agent.finished_goal = (0, "reached")
            wake = 0.0
    assert agent._last_report > 3.0, "the goal report was sent (and resent) along the way"


def test_a_loopback_mission_keeps_to_the_plan_and_waits_for_few_agents(monkeypatch):
    """run_mission raises if an agent publishes on a tick it was not asked for; count how many ticks asked."""
    asked: list[list[int]] = []
    original = AckPlan.ask

    def counting(self, tick, present):
        asked.append(original(self, tick, present))
        return asked[-1]

    monkeypatch.setattr(AckPlan, "ask", counting)
    world = run_mission(load_scenario(SCENARIOS / "crater_observation.yaml"), max_sim_time=20.0)
    assert world.tick == len(asked) and world.tick >= 400
    mean = sum(map(len, asked)) / len(asked)
    assert mean < 2.0, f"a tick waited for {mean:.2f} of the 6 agents on average"


# ---- photos ----


@pytest.fixture(scope="module")
def crater_world():
    scenario = load_scenario(SCENARIOS / "crater_observation.yaml")
    return scenario, World(scenario, KEYS)


def _photo_jobs(world: World) -> list:
    for rid in world.bodies:
        world.receive(KEYS.rover(rid, ks.PHOTO_ACTION), codec.encode(m.PhotoAction(label=f"rover{rid}")))
    jobs, world.photo_jobs = world.photo_jobs, []
    return jobs


def test_a_photo_is_due_the_cameras_capture_time_after_its_action(crater_world):
    scenario, world = crater_world
    capture = scenario.rover_params.camera.capture_time_s
    assert all(job.due_tick == world.tick + round(capture / world.dt) for job in _photo_jobs(world))


def test_the_camera_process_renders_the_worlds_photos_byte_for_byte(crater_world):
    scenario, world = crater_world
    jobs = _photo_jobs(world)
    process = CameraProcess(scenario)
    try:
        photos = [process.submit(job) for job in jobs]
        assert [f.result(timeout=60) for f in photos] == [world.render(job) for job in jobs]
    finally:
        process.close()


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


def test_dropping_rays_above_the_highest_ground_does_not_change_the_photo(crater_world):
    scenario, world = crater_world
    for body in world.bodies.values():
        args = (world.scene, np.zeros(0), np.zeros(0), 0.3, body.x, body.z, body.heading,
                scenario.rover_params.camera)
        fast = camera.render(world.terrain.uncached(), *args, tilt_deg=-5.0)  # looking up: much sky
        assert np.array_equal(fast, camera.render(_NoBound(world.terrain), *args, tilt_deg=-5.0))
