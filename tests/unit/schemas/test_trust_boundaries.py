"""Hostile but well-formed values, drawn from every message model, fed to the world, the lander and a rover agent
in process: none raises, every refusal is counted, whatever they publish afterwards still encodes, and no received
value names a file.

The same payloads go through a real router to a running mission in ``tests/e2e/test_attacks.py``.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hostile import pack, pack_radio, payloads, radio_payloads
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from procs import SCENARIOS

from lander_agent.archive import PhotoArchive
from lander_agent.lander import Lander
from lander_agent.mission import MissionPlan
from rover_agent.agent import RoverAgent
from schemas import codec, radio
from schemas import keyspace as ks
from schemas import messages as m
from schemas.scenario import load_scenario
from schemas.wire_limits import ACTION_ID_STRIDE, COUNT_LIMIT
from world_service.sim import World

KEYS = ks.Keyspace("attack")
SCENARIO = load_scenario(SCENARIOS / "crater_observation.yaml")
FAST = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                       HealthCheck.data_too_large])


def _encodes(out: list) -> None:
    for _, message in out:
        codec.encode(message)


def _refused(model: type[m.Message], payload: bytes) -> bool:
    try:
        codec.decode(model, payload)
    except codec.DecodeError:
        return True
    return False


# ---- the world ----

WORLD_INPUTS = [(KEYS.rover(1, topic), m.TOPIC_MODELS[topic]) for topic in World.INPUT_TOPICS if topic != ks.ACK]
WORLD_INPUTS += [(KEYS.rover(999, ks.MOVE_ACTION), m.MoveAction), (KEYS.lander(ks.COMM_OUT), m.OutboundComm),
                 (KEYS.lander(ks.STATUS), m.LanderStatus), (KEYS.ground_command, m.GroundCommand)]


@pytest.fixture(scope="module")
def world() -> World:
    return World(SCENARIO, KEYS)


@FAST
@given(data=st.data())
@pytest.mark.parametrize(("key", "model"), WORLD_INPUTS, ids=[k.split("/", 2)[-1] for k, _ in WORLD_INPUTS])
def test_the_world_counts_what_it_refuses_and_keeps_stepping(world, key, model, data):
    payload = data.draw(payloads(model))
    before = world.rejected.total
    out = world.receive(key, payload)
    if _refused(model, payload):
        assert world.rejected.total == before + 1 and out == []
    _encodes(out)
    _encodes(world.step())
    codec.encode(world.world_state())
    codec.encode(world.report())


def test_counters_at_their_bound_from_every_sender_still_sum_and_encode(world):
    """Ten rounds of statuses claiming the largest count no longer overflow the world's report."""
    for _ in range(10):
        world.receive(KEYS.lander(ks.STATUS), codec.encode(m.LanderStatus(stamp=1.0, phase="migration",
                                                                          rejected=COUNT_LIMIT)))
        for rid in (1, 2):
            world.receive(KEYS.rover(rid, ks.STATUS), codec.encode(m.RoverStatus(stamp=1.0, state="migration",
                                                                                 rejected=COUNT_LIMIT)))
    assert world.world_state().counters.agent_rejected >= 3 * COUNT_LIMIT
    codec.encode(world.report())
    before = world.rejected.total
    world.receive(KEYS.rover(1, ks.STATUS), pack({"stamp": 1.0, "state": "done", "rejected": 2**64 - 1}))
    assert world.rejected.total == before + 1


def test_an_action_id_from_the_future_cannot_lock_the_rovers_own_ids_out():
    world = World(SCENARIO, KEYS)
    world.step()
    for _ in range(5):
        (_, refusal), = world.receive(KEYS.rover(3, ks.ROTATE_ACTION),
                                      codec.encode(m.RotateAction(degrees=1.0, action_id=2**63 - 1)))
        assert refusal.reason == "out_of_sequence"
    assert world.rejected.by_topic[ks.ROTATE_ACTION] == 5
    own = int(world.clock.sim_time * 1000) * ACTION_ID_STRIDE + 1  # as the agent takes its first id
    out = world.receive(KEYS.rover(3, ks.ROTATE_ACTION), codec.encode(m.RotateAction(degrees=1.0, action_id=own)))
    assert [type(msg) for _, msg in out] == [m.NavigationStatus]


def test_a_stale_action_is_refused_and_counted():
    world = World(SCENARIO, KEYS)
    world.step()
    world.receive(KEYS.rover(1, ks.ROTATE_ACTION), codec.encode(m.RotateAction(degrees=1.0, action_id=5)))
    (_, refusal), = world.receive(KEYS.rover(1, ks.ROTATE_ACTION),
                                  codec.encode(m.RotateAction(degrees=1.0, action_id=3)))
    assert refusal.reason == "stale" and world.rejected.by_topic[ks.ROTATE_ACTION] == 1


# ---- the lander ----

LANDER_INPUTS = [(KEYS.clock, m.Clock), (KEYS.lander(ks.COMM_PARTNERS), m.CommPartners),
                 (KEYS.ground_command, m.GroundCommand), (KEYS.lander(ks.COMM_IN), m.InboundComm)]


@pytest.fixture(scope="module")
def archive_root(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("lander")


@pytest.fixture(scope="module")
def lander(archive_root) -> Lander:
    return Lander(MissionPlan(SCENARIO), KEYS, PhotoArchive(archive_root / "run" / "archive"))


@FAST
@given(data=st.data())
@pytest.mark.parametrize(("key", "model"), LANDER_INPUTS, ids=[k.rsplit("/", 1)[-1] for k, _ in LANDER_INPUTS])
def test_the_lander_counts_what_it_refuses(lander, key, model, data):
    payload = data.draw(payloads(model))
    before = lander.rejected.total
    out = lander.handle(key, payload)
    if _refused(model, payload):
        assert lander.rejected.total == before + 1 and out == []
    _encodes(out)
    _encodes(lander.broadcast(lander.now))


@FAST
@given(inner=radio_payloads(), sender=st.sampled_from([1, 2, 5]))
def test_the_lander_takes_any_radio_message_as_data(lander, archive_root, inner, sender):
    out = lander.handle(KEYS.lander(ks.COMM_IN), codec.encode(m.InboundComm(sender=sender, payload=inner)))
    _encodes(out)
    _encodes(lander.broadcast(lander.now))
    escaped = [p for p in archive_root.rglob("*") if not p.is_relative_to(archive_root / "run")]
    assert escaped == []


def test_a_photo_label_is_data_never_a_file_name(tmp_path):
    archive = PhotoArchive(tmp_path / "run")
    lander = Lander(MissionPlan(SCENARIO), KEYS, archive)
    png = b"\x89PNG\r\n\x1a\n" + b"\x00" * 16
    for label in ["../../escape/x", "/tmp/escape/x", "a/b", "x" * 64, "\u00e9\u00e9"]:
        report = radio.PhotoReport(goal_index=0, label=label, stamp=1.0, png=png)
        (_, ack), = lander.handle(KEYS.lander(ks.COMM_IN), codec.encode(m.InboundComm(
            sender=1, payload=radio.pack(report))))
        assert radio.unpack(ack.payload).labels == [label]
    files = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*") if p.is_file())
    assert files == ["run/index.jsonl", *[f"run/rover1/{n:05d}.png" for n in range(1, 6)]]
    too_long = pack_radio("photo_report", {"goal_index": 0, "label": "x" * 300, "stamp": 1.0, "png": png})
    assert lander.handle(KEYS.lander(ks.COMM_IN), codec.encode(m.InboundComm(sender=1, payload=too_long))) == []
    assert lander.rejected.total == 1


def test_a_rover_fills_no_more_than_its_share_of_the_archive_in_bytes_even_across_a_restart(tmp_path, monkeypatch):
    from lander_agent import archive as archive_module

    monkeypatch.setattr(archive_module, "MAX_BYTES_PER_ROVER", 100_000)
    png = b"\x89PNG\r\n\x1a\n" + bytes(30_000)

    def send(lander: Lander, sender: int, label: str) -> bool:
        report = radio.PhotoReport(goal_index=0, label=label, stamp=1.0, png=png)
        return lander.handle(KEYS.lander(ks.COMM_IN), codec.encode(m.InboundComm(
            sender=sender, payload=radio.pack(report)))) != []  # acked: archived

    lander = Lander(MissionPlan(SCENARIO), KEYS, PhotoArchive(tmp_path))
    assert [send(lander, 1, f"p{i}") for i in range(5)] == [True, True, True, False, False]
    assert send(lander, 2, "p0") and lander.archive.refused == 2 and lander.rejected.total == 2
    again = Lander(MissionPlan(SCENARIO), KEYS, PhotoArchive(tmp_path))  # a restarted lander, the same folder
    assert not send(again, 1, "p9") and send(again, 2, "p1")
    assert len(list((tmp_path / "rover1").glob("*.png"))) == 3
    assert sorted(p.name for p in (tmp_path / "rover2").glob("*.png")) == ["00001.png", "00002.png"]  # none over


# ---- a rover agent ----

AGENT_INPUTS = [(topic, m.TOPIC_MODELS[topic]) for topic in ks.ROVER_INPUTS]


@pytest.fixture(scope="module")
def agent() -> RoverAgent:
    from agent_kit import joined_agent

    return joined_agent(1, KEYS, SCENARIO.rover_params)


def _clock(agent: RoverAgent) -> m.Clock:
    return m.Clock(tick=1, sim_time=agent.now + 0.2, time_scale=1.0, run=agent.restarts.run)


@FAST
@given(data=st.data())
@pytest.mark.parametrize(("topic", "model"), AGENT_INPUTS, ids=[t for t, _ in AGENT_INPUTS])
def test_a_rover_agent_counts_what_it_refuses(agent, topic, model, data):
    payload = data.draw(payloads(model))
    before = agent.rejected.total
    out = agent.handle(topic, payload)
    if _refused(model, payload):
        assert agent.rejected.total == before + 1 and out == []
    _encodes(out)
    _encodes([agent.status(), *agent.on_clock(_clock(agent))])


@FAST
@given(inner=radio_payloads(), sender=st.sampled_from([0, 2, 3]))
def test_a_rover_agent_takes_any_radio_message_as_data(agent, inner, sender):
    _encodes(agent.handle(ks.COMM_IN, codec.encode(m.InboundComm(sender=sender, payload=inner))))
    _encodes([agent.status(), *agent.on_clock(_clock(agent))])


def test_the_worlds_copy_of_a_photo_is_named_by_the_world(tmp_path):
    import json

    import numpy as np

    from world_service.camera.photographer import save_photo
    from world_service.camera.photos import PhotoJob

    for stamp, label in [(1.0, "../../escape/x"), (2.0, "/tmp/escape/x"), (3.0, "")]:
        job = PhotoJob(4, stamp, label, 0, 0.0, 0.0, 0.0, np.array([]), np.array([]))
        save_photo(tmp_path / "photos", job, m.Photo(stamp=stamp, label=label, png=b"\x89PNG\r\n\x1a\n"))
    files = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.rglob("*") if p.is_file())
    assert files == ["photos/index.jsonl", "photos/rover4_t000001.00.png", "photos/rover4_t000002.00.png",
                     "photos/rover4_t000003.00.png"]
    index = [json.loads(line) for line in (tmp_path / "photos" / "index.jsonl").read_text().splitlines()]
    assert [entry["label"] for entry in index] == ["../../escape/x", "/tmp/escape/x", ""]


@pytest.mark.parametrize(("model", "fields"), [
    (m.MissionDirection, {"goal_index": 0, "goals_total": 0, "kind": "crater", "bearing_deg": 0.0, "distance_m": 1.0}),
    (m.MissionDirection, {"goal_index": 0, "goals_total": 1, "kind": "crater", "bearing_deg": 0.0, "distance_m": -1.0}),
    (m.Clock, {"tick": 0, "sim_time": -1.0, "time_scale": 1.0}),
    (radio.PoseEstimate, {"stamp": -5.0, "x": 0.0, "z": 0.0, "cov_xx": 0.0, "cov_xz": 0.0, "cov_zz": 0.0}),
    (m.GroundCommand, {"command": "seek", "seconds": -1.0}),
], ids=["no goals", "negative distance", "negative time", "negative stamp", "negative seek"])
def test_a_fields_own_bound_is_kept_beside_its_types(model, fields):
    """A field's own bound beside an annotated type's (each a ``Meta`` of ``schemas.wire_limits``) is kept."""
    with pytest.raises(codec.DecodeError):
        codec.decode(model, pack(fields))
