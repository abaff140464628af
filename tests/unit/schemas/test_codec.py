"""The msgpack codec: every payload model round-trips, and every decoder turns garbage into DecodeError."""

from __future__ import annotations

import inspect
import math
import random
import typing
from pathlib import Path

import msgpack
import msgspec
import pytest

from schemas import codec, radio
from schemas import messages as m

SAMPLES: dict[type, m.Message] = {
    m.Perception: m.Perception(stamp=1.25, angles_deg=[-10.5, 0.0, 42.0], distances_m=[3.5, 1.0, 9.75],
                               kinds=["rover", "obstacle", "crater_terrain"]),
    m.MoveAction: m.MoveAction(x=-1.5, z=7.25),
    m.RotateAction: m.RotateAction(degrees=-90.0),
    m.NavigationStatus: m.NavigationStatus(stamp=3.0, action="rotate", remaining=12.5, outcome="cancelled"),
    m.CancelAction: m.CancelAction(),
    m.Ack: m.Ack(tick=42),
    m.Telemetry: m.Telemetry(stamp=1.5, x=0.25, z=3.0, heading_deg=12.5, pitch_deg=-2.0, moving=True),
    m.RoverIdGrant: m.RoverIdGrant(id=3),
    m.CancelResult: m.CancelResult(x=0.25, z=3.5, angle_deg=-4.0, reason="collided"),
    m.SpeedAction: m.SpeedAction(level=2),
    m.ActionRejected: m.ActionRejected(action="move", reason="blocked", detail="rock"),
    m.Gyroscope: m.Gyroscope(stamp=0.05, pitch_deg=-3.5),
    m.Battery: m.Battery(stamp=1.0, charge_wh=12.5, capacity_wh=20.0, solar_w=3.25, empty=False),
    m.Temperature: m.Temperature(stamp=1.0, celsius=-12.5, shutdown=True),
    m.Sunlight: m.Sunlight(stamp=1.0, lit=False),
    m.OutboundComm: m.OutboundComm(targets=[0, 3], payload=b"\x00\xffhello", channel="calibration"),
    m.InboundComm: m.InboundComm(sender=4, payload=b"\x01\x02"),
    m.CommPartners: m.CommPartners(ids=[0, 2, 5]),
    m.MissionDirection: m.MissionDirection(goal_index=1, goals_total=3, kind="crater", bearing_deg=212.5,
                                           distance_m=88.0),
    m.Calibration: m.Calibration(x=50.0, z=-50.0, heading_deg=180.074),
    m.PhotoAction: m.PhotoAction(label="rim-30"),
    m.Photo: m.Photo(stamp=9.5, label="rim-30", png=b"\x89PNG\r\n\x1a\n\x00\x00"),
    m.RoverStatus: m.RoverStatus(stamp=2.0, state="climbing", goal_index=0, detail="pitch 3.1"),
    m.WorldState: m.WorldState(
        stamp=4.0,
        rovers=[m.RoverTruth(id=1, x=-510.0, z=100.0, heading_deg=180.0, action="move", state="migration",
                             goal_index=0, distance_to_goal_m=120.5, distance_covered_m=3.25, alive=True),
                m.RoverTruth(id=2, x=-500.0, z=100.0, heading_deg=90.0, action="idle", state="done",
                             goal_index=1, distance_to_goal_m=0.0, distance_covered_m=80.0, alive=False)],
        comm_links=[(0, 1), (1, 2)],
    ),
    m.MissionReport: m.MissionReport(
        scenario="crater_observation", seed=7, relative_path_length_m=108.4, average_distance_covered_m=110.2,
        average_path_efficiency=0.98, total_distance_covered_m=551.0, rovers_reached_final_goal=4,
        rovers_total=5, rover_collisions=1, obstacle_collisions=2, rovers_stuck=1, mission_duration_s=43.1,
        wall_time_s=12.5, complete=True, rejected_messages=3,
    ),
    m.LanderStatus: m.LanderStatus(stamp=5.0, phase="migration", rover_goals={1: 0, 2: 1}, connected=[1, 2],
                                   relay_chain=[0, 1, 2]),
    m.Clock: m.Clock(tick=12, sim_time=0.6, time_scale=1.0, running=False),
    radio.GoalReport: radio.GoalReport(goal_index=2, outcome="stuck"),
}
SAMPLES[m.EstimatedPose] = m.EstimatedPose(stamp=3.0, x=1.5, z=-2.0, heading_deg=45.0, cov_xx=0.5, cov_xz=0.1,
                                           cov_zz=0.4, cov_xh=0.01, cov_zh=-0.01, cov_hh=0.002, moving=True)
SAMPLES[m.WorldStats] = m.WorldStats(stamp=6.0, report=SAMPLES[m.MissionReport], final=True)

SCENARIO = Path(__file__).resolve().parents[3] / "scenarios" / "crater_observation.yaml"
MODELS = sorted(SAMPLES, key=lambda model: model.__name__)


def test_every_topic_model_and_extra_model_has_a_sample():
    required = set(m.TOPIC_MODELS.values()) | {m.WorldState, m.WorldStats, m.MissionReport, m.LanderStatus,
                                               m.Clock, radio.GoalReport}
    assert required <= set(SAMPLES)


@pytest.mark.parametrize("model", MODELS, ids=lambda model: model.__name__)
def test_round_trip(model):
    message = SAMPLES[model]
    assert type(message) is model
    payload = codec.encode(message)
    assert isinstance(payload, bytes)
    assert codec.decode(model, payload) == message


def _msgpack_python_encoding(message) -> bytes:
    """What msgpack-python makes of ``[version, fields]``, nested messages as their fields: the wire format every
    recording made before holds, which ``codec.encode`` must match byte for byte."""
    fields = msgspec.to_builtins(message, builtin_types=(bytes,))
    return msgpack.packb([codec.SCHEMA_VERSION, fields], use_bin_type=True)


@pytest.mark.parametrize("model", MODELS, ids=lambda model: model.__name__)
def test_encoding_is_byte_for_byte_that_of_msgpack_python(model):
    assert codec.encode(SAMPLES[model]) == _msgpack_python_encoding(SAMPLES[model])


def _schema_models() -> list[type[msgspec.Struct]]:
    found, todo = [], [msgspec.Struct]
    while todo:
        for sub in todo.pop().__subclasses__():
            todo.append(sub)
            if sub.__module__.startswith("schemas."):
                found.append(sub)
    return found


def test_every_schema_model_is_frozen_strict_and_encodes_every_field_by_name():
    """Receivers refuse unknown fields and read each by its name; a renamed, omitted or positional field would
    change the wire format without changing the codec."""
    models = _schema_models()
    assert m.WorldState in models and radio.GoalReport in models
    for model in models:
        config = model.__struct_config__
        assert config.frozen and config.forbid_unknown_fields, model
        assert not config.array_like and not config.omit_defaults and config.tag is None, model
        assert model.__struct_encode_fields__ == model.__struct_fields__, model
        kinds = {p.kind for p in inspect.signature(model).parameters.values()}
        assert kinds <= {inspect.Parameter.KEYWORD_ONLY}, model


def _floats_bounded(annotation) -> bool:
    """Whether every float in ``annotation`` is bounded on both sides (so neither nan nor inf passes)."""
    origin, args = typing.get_origin(annotation), typing.get_args(annotation)
    if origin is typing.Annotated:
        metas = [a for a in args[1:] if isinstance(a, msgspec.Meta)]
        if args[0] is float:
            low = any(m.ge is not None or m.gt is not None for m in metas)
            high = any(m.le is not None or m.lt is not None for m in metas)
            return low and high
        return _floats_bounded(args[0])
    if annotation is float:
        return False
    return all(_floats_bounded(a) for a in args if a is not Ellipsis)


@pytest.mark.parametrize("model", _schema_models(), ids=lambda model: model.__name__)
def test_every_float_of_every_schema_model_is_bounded(model):
    """msgspec has no switch for nan and inf: a bound on each side refuses both (``wire_limits.finite``)."""
    hints = typing.get_type_hints(model, include_extras=True)
    assert [name for name in model.__struct_fields__ if not _floats_bounded(hints[name])] == []


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
@pytest.mark.parametrize(("model", "field"), [(m.Temperature, "celsius"), (m.Battery, "charge_wh"),
                                              (m.MoveAction, "x"), (m.RoverTruth, "x")])
def test_nan_and_inf_are_refused(model, field, value):
    fields = {**msgspec.to_builtins(_sample_of(model), builtin_types=(bytes,)), field: value}
    payload = msgpack.packb([codec.SCHEMA_VERSION, fields], use_bin_type=True)
    _assert_rejected(model, payload, f"{model.__name__}: {field}:")


def _sample_of(model):
    if model is m.RoverTruth:
        return SAMPLES[m.WorldState].rovers[0]
    return SAMPLES[model]


def test_what_the_world_builds_encodes_as_msgpack_python_would():
    """The world builds its messages from NumPy arrays: every message of 25 ticks of a real mission, and a state,
    encodes exactly as before, and holds only Python values (an encoder that knows no NumPy takes each)."""
    from schemas import keyspace as ks
    from schemas.scenario import load_scenario
    from world_service.sim import World

    world = World(load_scenario(SCENARIO), ks.Keyspace("codec"))
    for rid in world.actuator.bodies:
        world.receive(world.keys.rover(rid, ks.MOVE_ACTION), codec.encode(m.MoveAction(x=0.5, z=4.0)))
    out = [item for _ in range(25) for item in world.step()] + [("state", world.observed_state())]
    out.append(("clock", msgspec.structs.replace(world.clock.message(), acks=[1, 2])))
    assert {type(message) for _, message in out} >= {m.Gyroscope, m.Perception, m.WorldState, m.Clock}
    plain = msgspec.msgpack.Encoder()
    for _, message in out:
        assert codec.encode(message) == _msgpack_python_encoding(message) == plain.encode((1, message)), message


def test_round_trip_keeps_types_of_tuples_int_keys_and_bytes():
    state = codec.decode(m.WorldState, codec.encode(SAMPLES[m.WorldState]))
    assert state.comm_links == [(0, 1), (1, 2)] and isinstance(state.comm_links[0], tuple)
    lander = codec.decode(m.LanderStatus, codec.encode(SAMPLES[m.LanderStatus]))
    assert lander.rover_goals == {1: 0, 2: 1} and all(isinstance(k, int) for k in lander.rover_goals)
    photo = codec.decode(m.Photo, codec.encode(SAMPLES[m.Photo]))
    assert photo.png == b"\x89PNG\r\n\x1a\n\x00\x00"


def test_envelope_is_version_then_fields():
    version, fields = msgpack.unpackb(codec.encode(m.MoveAction(x=1.0, z=2.0)), raw=False)
    assert version == codec.SCHEMA_VERSION == 1
    assert fields == {"x": 1.0, "z": 2.0, "action_id": 0}


def _assert_rejected(model, payload, *fragments):
    with pytest.raises(codec.DecodeError) as info:
        codec.decode(model, payload)
    text = str(info.value)
    assert text.startswith(f"{model.__name__}:"), text
    for fragment in fragments:
        assert fragment in text, text
    return text


@pytest.mark.parametrize("model", MODELS, ids=lambda model: model.__name__)
def test_random_bytes_are_rejected(model):
    rng = random.Random(f"codec-{model.__name__}")
    for _ in range(200):
        garbage = rng.randbytes(rng.randint(1, 64))
        _assert_rejected(model, garbage)


@pytest.mark.parametrize("model", MODELS, ids=lambda model: model.__name__)
def test_empty_payload_is_rejected(model):
    _assert_rejected(model, b"", "not msgpack")


@pytest.mark.parametrize("model", MODELS, ids=lambda model: model.__name__)
@pytest.mark.parametrize("shape", [
    42, "text", None, [], [1], [1, 2, 3], {"x": 1.0}, [1, [1, 2]], [1, "fields"], [{}, 1],
], ids=repr)
def test_msgpack_of_the_wrong_shape_is_rejected(model, shape):
    _assert_rejected(model, msgpack.packb(shape, use_bin_type=True), "expected [schema_version, {fields}]")


@pytest.mark.parametrize("model", MODELS, ids=lambda model: model.__name__)
@pytest.mark.parametrize("version", [0, 2, -1, 99, "1", None, [1]])
def test_wrong_schema_version_is_rejected(model, version):
    fields = msgspec.to_builtins(SAMPLES[model], builtin_types=(bytes,))
    payload = msgpack.packb([version, fields], use_bin_type=True)
    _assert_rejected(model, payload, "schema version", repr(version))


@pytest.mark.parametrize("version", [True, 1.0])
def test_schema_version_must_be_the_integer_1(version):
    payload = msgpack.packb([version, {"x": 1.0, "z": 2.0}], use_bin_type=True)
    _assert_rejected(m.MoveAction, payload, "schema version")


def _foreign_sample(model):
    """A valid encoding of another model with a field the target does not have (so it cannot be read as one)."""
    own = set(model.__struct_fields__)
    for other in MODELS:
        if other is not model and not set(other.__struct_fields__) <= own:
            return SAMPLES[other]
    raise AssertionError(f"no foreign sample for {model.__name__}")


@pytest.mark.parametrize("model", MODELS, ids=lambda model: model.__name__)
def test_valid_encoding_of_a_different_model_is_rejected(model):
    foreign = _foreign_sample(model)
    _assert_rejected(model, codec.encode(foreign))


@pytest.mark.parametrize(("model", "other"), [
    (m.MoveAction, m.Calibration),  # a subset of Calibration's fields: the extra heading_deg is refused
    (m.Calibration, m.MoveAction),  # heading_deg missing
    (m.CancelAction, m.RotateAction),
    (m.RotateAction, m.CancelAction),
    (m.InboundComm, m.OutboundComm),
    (m.WorldStats, m.MissionReport),
    (radio.GoalReport, m.MissionDirection),
], ids=lambda model: model.__name__)
def test_close_relatives_are_not_confused(model, other):
    _assert_rejected(model, codec.encode(SAMPLES[other]))


@pytest.mark.parametrize("model", MODELS, ids=lambda model: model.__name__)
def test_extra_fields_are_rejected(model):
    fields = {**msgspec.to_builtins(SAMPLES[model], builtin_types=(bytes,)), "bogus_field": 1}
    payload = msgpack.packb([codec.SCHEMA_VERSION, fields], use_bin_type=True)
    _assert_rejected(model, payload, "bogus_field")


@pytest.mark.parametrize(("model", "fields", "path"), [
    (m.Perception, {"stamp": 0.0, "angles_deg": [1.0], "distances_m": [], "kinds": []}, "<root>"),
    (m.Perception, {"stamp": 0.0, "angles_deg": [1.0], "distances_m": [2.0], "kinds": ["cheese"]}, "kinds.0"),
    (m.SpeedAction, {"level": 4}, "level"),
    (m.SpeedAction, {"level": 0}, "level"),
    (m.MissionDirection, {"goal_index": -1, "goals_total": 1, "kind": "crater", "bearing_deg": 0.0,
                          "distance_m": 1.0}, "goal_index"),
    (m.NavigationStatus, {"stamp": 0.0, "action": "fly", "remaining": 0.0}, "action"),
    (m.MoveAction, {"x": 1.0}, "z"),
    (m.MoveAction, {"x": [1.0], "z": 2.0}, "x"),
    (m.WorldState, {"stamp": 0.0, "rovers": [{"id": 1}]}, "rovers.0.x"),
    (radio.GoalReport, {"goal_index": 0, "outcome": "maybe"}, "outcome"),
])
def test_invalid_field_values_name_model_and_field_path(model, fields, path):
    payload = msgpack.packb([codec.SCHEMA_VERSION, fields], use_bin_type=True)
    _assert_rejected(model, payload, f"{model.__name__}: {path}:")


def test_perception_columns_of_different_lengths_are_rejected():
    payload = msgpack.packb([1, {"stamp": 0.0, "angles_deg": [1.0, 2.0], "distances_m": [1.0], "kinds": ["rover"]}])
    _assert_rejected(m.Perception, payload, "same length")


# ---- radio payloads ----


def test_radio_pack_unpack_round_trip():
    report = radio.GoalReport(goal_index=3, outcome="reached")
    assert radio.unpack(radio.pack(report)) == report


@pytest.mark.parametrize("tag", ["goal_reprot", "", "GoalReport", 7, None, b"goal_report"], ids=repr)
def test_radio_unknown_tag_is_rejected(tag):
    body = codec.encode(radio.GoalReport(goal_index=0, outcome="reached"))
    payload = msgpack.packb([tag, body], use_bin_type=True)
    with pytest.raises(codec.DecodeError, match="unknown tag"):
        radio.unpack(payload)


def test_radio_body_that_is_not_bytes_is_rejected():
    payload = msgpack.packb(["goal_report", {"goal_index": 0, "outcome": "reached"}], use_bin_type=True)
    with pytest.raises(codec.DecodeError, match="radio payload"):
        radio.unpack(payload)


def test_radio_body_of_the_wrong_model_is_rejected_naming_it():
    body = codec.encode(m.MoveAction(x=1.0, z=2.0))
    payload = msgpack.packb(["goal_report", body], use_bin_type=True)
    with pytest.raises(codec.DecodeError, match=r"^GoalReport:"):
        radio.unpack(payload)


@pytest.mark.parametrize("shape", [None, 5, "goal_report", [], ["goal_report"], ["a", "b", "c"], {"a": 1}],
                         ids=repr)
def test_radio_wrong_shape_is_rejected(shape):
    with pytest.raises(codec.DecodeError, match="radio payload"):
        radio.unpack(msgpack.packb(shape, use_bin_type=True))


def test_radio_garbage_is_rejected():
    rng = random.Random("radio-garbage")
    for payload in [b"", *(rng.randbytes(rng.randint(1, 64)) for _ in range(300))]:
        with pytest.raises(codec.DecodeError):
            radio.unpack(payload)


# ---- checked: a message built from untrusted values ----


def test_checked_gives_the_message_a_receiver_would_decode():
    """Built from a user's or a driver's values: ints and NumPy scalars become the floats the model holds, lists
    its tuples, exactly as a receiver would see them."""
    import numpy as np

    built = m.MissionDirection(goal_index=np.int64(1), goals_total=2, kind="waypoint", bearing_deg=np.float64(90.5),
                               distance_m=3, station=[1, 2])
    message = codec.checked(built)
    assert message == m.MissionDirection(goal_index=1, goals_total=2, kind="waypoint", bearing_deg=90.5,
                                         distance_m=3.0, station=(1.0, 2.0))
    assert type(message.goal_index) is int and type(message.distance_m) is float
    assert isinstance(message.station, tuple)


@pytest.mark.parametrize(("message", "fragment"), [
    (m.MoveAction(x=1e12, z=0.0), "MoveAction: x: Expected `float` <= "),
    (m.MoveAction(x=math.nan, z=0.0), "MoveAction: x: "),
    (m.PhotoAction(label="a\nb"), "PhotoAction: label: "),
    (m.GroundCommand(command="stop", rover_id=-1), "GroundCommand: rover_id: "),
    (m.MoveAction(x=object(), z=0.0), "MoveAction: cannot encode object"),
], ids=lambda v: type(v).__name__ if isinstance(v, m.Message) else None)
def test_checked_refuses_what_a_receiver_would_refuse_naming_the_field(message, fragment):
    with pytest.raises(codec.DecodeError) as info:
        codec.checked(message)
    assert fragment in str(info.value)
