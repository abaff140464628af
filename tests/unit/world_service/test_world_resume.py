"""A killed world's saved state (``world_service.resume``): resumed when it works with this code, refused with one
clear log line when it does not (a world pickled by a version whose parts held other attributes), never a crash."""

from __future__ import annotations

import logging

import zenoh
from procs import SCENARIOS

from bus import snapshot
from bus.bus import Bus
from bus.zenoh_config import build_config
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.scenario import load_scenario
from world_service import resume, service
from world_service.camera.photographer import Photographer
from world_service.lockstep import LockstepTick
from world_service.presence import Agents
from world_service.sim import World

KEYS = ks.Keyspace("resume")
SCENARIO = load_scenario(SCENARIOS / "crater_observation.yaml").with_overrides(rovers=2)


def _under_way() -> World:
    world = World(SCENARIO, KEYS)
    world.receive(KEYS.rover(1, ks.MOVE_ACTION), codec.encode(m.MoveAction(x=0.0, z=4.0, action_id=1)))
    for _ in range(10):
        world.step()
    return world


def test_a_saved_world_resumes_where_it_was_with_every_agent_counted_gone(tmp_path):
    world = _under_way()
    snapshot.save(world, tmp_path / "world.state")
    resumed = resume.load(tmp_path / "world.state", SCENARIO)
    assert resumed is not None and resumed.clock.tick == world.clock.tick == 10
    assert resumed.clock.run_id == world.clock.run_id and resumed.resumes == 1
    assert (resumed.actuator.bodies[1].x, resumed.actuator.bodies[1].z) == (world.actuator.bodies[1].x,
                                                                            world.actuator.bodies[1].z)
    assert not any(resumed.actuator.alive.values())
    assert resumed.step()[-1][0] == KEYS.clock  # and it goes on


def test_a_world_saved_by_code_whose_parts_differ_is_refused_with_a_reason(tmp_path, caplog):
    world = _under_way()
    del world.actuator.ledger  # as a version whose actuation kept its actions elsewhere would have pickled it
    snapshot.save(world, tmp_path / "world.state")
    with caplog.at_level(logging.INFO, logger="lunarsim.world"):
        assert resume.load(tmp_path / "world.state", SCENARIO) is None
    refusals = [r.getMessage() for r in caplog.records if r.name == "lunarsim.world"]
    assert len(refusals) == 1, refusals
    assert "does not work with this version of the code" in refusals[0] and "ledger" in refusals[0], refusals[0]


def test_the_trial_step_leaves_the_saved_world_as_it_was(tmp_path):
    world = _under_way()
    snapshot.save(world, tmp_path / "world.state")
    loaded = snapshot.load(tmp_path / "world.state", logging.getLogger("test"))
    assert resume.unworkable(loaded) is None
    assert loaded.clock.tick == 10 and loaded.world_state() == world.world_state()


def test_a_saved_world_holds_its_terrain_tiles_by_key_and_resumes_with_the_same_heights(tmp_path):
    world = _under_way()
    tiles = world.terrain.loaded_tiles
    assert tiles, "the rovers' ground is loaded by now"
    snapshot.save(world, tmp_path / "world.state")
    arrays = sum(world.terrain.tile(k).heights.nbytes for k in tiles)
    assert (tmp_path / "world.state").stat().st_size < arrays / 4  # the keys, not the arrays
    resumed = snapshot.load(tmp_path / "world.state", logging.getLogger("test"))
    assert resumed.terrain.loaded_tiles == tiles and resumed.terrain.tiles_generated == world.terrain.tiles_generated
    for key in tiles:
        assert (resumed.terrain.tile(key).heights == world.terrain.tile(key).heights).all()
    assert resumed.sensors.terrain is resumed.terrain  # one terrain, shared by every part, as before the save
    for _ in range(20):
        assert resumed.step() == world.step()


class _Sent(Bus):
    """A bus on a session of its own (no router, nothing listening) that keeps the keys it put, in order."""

    def __init__(self) -> None:
        super().__init__(zenoh.open(build_config(mode="peer")), declare_publishers=False)
        self.keys: list[str] = []

    def put(self, key: str, payload: bytes) -> None:
        self.keys.append(key)
        super().put(key, payload)


def test_a_lockstep_world_saves_its_state_once_the_tick_is_out_not_before(tmp_path, monkeypatch):
    """The save (a millisecond or more) would otherwise sit between the agents and the tick they wait for."""
    world = World(SCENARIO, KEYS)
    world.clock.lockstep = True
    sent_at_save: dict[int, int] = {}  # the step that saved -> how many samples were out then
    sent_after_step: list[int] = []
    real_save = snapshot.save
    with _Sent() as bus:
        def save(state: object, path) -> None:
            sent_at_save[len(sent_after_step)] = len(bus.keys)
            real_save(state, path)

        monkeypatch.setattr(service.snapshot, "save", save)
        tick, tally = LockstepTick(world), service.LockstepTally(start=0.0)
        photographer = Photographer(world, True, None)
        for _ in range(2 * world.clock.period(1.0 / service.SAVE_PERIOD_S)):
            service._step_lockstep(world, bus, photographer, tick, Agents(KEYS), tmp_path / "world.state", tally)
            sent_after_step.append(len(bus.keys))
    assert len(sent_at_save) == 2 and (tmp_path / "world.state").exists()
    for step, sent in sent_at_save.items():  # every sample of the saving tick was out before its save
        assert sent == sent_after_step[step] > sent_after_step[step - 1], (step, sent, sent_after_step)
