"""Foxglove export, report, trajectory plot and live view, checked on a small recording (no router needed).

The exported messages are decoded with the protobuf runtime from the schemas (FileDescriptorSets) the
foxglove SDK wrote into the file, not from compiled classes: what Foxglove will read is what we check.
"""

from __future__ import annotations

import json
import socket
from collections import Counter
from pathlib import Path

import msgspec
import numpy as np
import pytest
from google.protobuf.message import Message
from hostile import huge_lander_map
from procs import SCENARIOS, free_port
from protobuf_schemas import message_class

from deploy import cli
from schemas import codec
from schemas import messages as m
from schemas.scenario import load_scenario
from sessions.format import Sample, read_samples
from sessions.gaps import ClockMark
from sessions.writer import SessionWriter

SCENARIO_FILE = SCENARIOS / "crater_observation.yaml"
STATE_KEY = "lunar/test/world/state"
PHOTO_KEY = "lunar/test/rover/2/photo"
MAP_KEY = "lunar/test/lander/map"
T0 = 1_700_000_000_000_000_000
PNG = b"\x89PNG\r\n\x1a\n" + bytes(range(64))


# ---- decoding with the schemas in the file ----


def read_foxglove(path: Path) -> dict[str, list[tuple[int, str, Message | bytes]]]:
    """topic -> [(log time, encoding, decoded message or raw payload)] of an MCAP file."""
    from mcap.reader import make_reader

    out: dict[str, list] = {}
    with open(path, "rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=True):
            if channel.message_encoding == "protobuf":
                assert schema.encoding == "protobuf"
                decoded = message_class(schema.data, schema.name).FromString(message.data)
            else:
                decoded = message.data
            out.setdefault(channel.topic, []).append((message.log_time, channel.message_encoding, decoded))
    return out


# ---- a recording ----


def state(i: int) -> m.WorldState:
    def rover(rid: int, x: float, z: float) -> m.RoverTruth:
        return m.RoverTruth(id=rid, x=x, z=z, heading_deg=180.0, action="move", state="migration", goal_index=0,
                            distance_to_goal_m=50.0, distance_covered_m=2.0 * i, alive=True)

    return m.WorldState(stamp=float(i), rovers=[rover(1, -510.0, 100.0 - 2 * i), rover(2, -500.0, 100.0 - 3 * i)],
                        comm_links=[(0, 1), (1, 2)], relays=[1])


@pytest.fixture
def recording(tmp_path: Path) -> Path:
    path = tmp_path / "in.mcap"
    writer = SessionWriter(path, {"scenario": SCENARIO_FILE.read_text(encoding="utf-8")})
    for i in range(3):
        t = T0 + i * 1_000_000_000
        writer.write(Sample(STATE_KEY, codec.encode(state(i)), t, t))
        writer.write(Sample("lunar/test/rover/1/gyroscope", codec.encode(m.Gyroscope(stamp=i, pitch_deg=1.0)), t, t))
    writer.write(Sample(PHOTO_KEY, codec.encode(m.Photo(stamp=2.5, label="crater", png=PNG)), T0 + 2_500_000_000,
                        T0 + 2_500_000_000))
    writer.write(Sample(MAP_KEY, codec.encode(lander_map()), T0 + 2_700_000_000, T0 + 2_700_000_000))
    writer.close()
    return path


MAP_CODES = np.array([[0, 1, 1, 2], [3, 1, 4, 0], [0, 0, 1, 1]], np.uint8)
"""A 4 x 3 map: row 0 is the lowest z (unknown, free, free, obstacle), then crater and rover cells."""


def lander_map() -> m.LanderMap:
    """A map as the lander publishes it, built by the lander's own code from a class array."""
    from lander_agent.mapping import PRECEDENCE, GridSpec, TraverseMap

    spec = GridSpec(origin_x=-600.0, origin_z=20.0, cell_m=2.0, width=4, height=3)
    grid = TraverseMap(spec, (-560.0, 50.0))
    for code in PRECEDENCE:
        grid.seen[code] = np.equal(MAP_CODES, code)
    grid.rovers[1] = (0, -595.0, 23.0)  # the rover cell: column 2, row 1
    return grid.to_message(2.7)


def _ns(stamp: Message) -> int:
    """google.protobuf.Timestamp, as the foxglove schemas carry it."""
    return stamp.seconds * 1_000_000_000 + stamp.nanos


def _pos(pose: Message) -> tuple[float, float, float]:
    p = pose.position
    return p.x, p.y, p.z


# ---- export ----


def test_export_writes_scene_transforms_and_photos(recording: Path, tmp_path: Path):
    out = tmp_path / "out.mcap"
    assert cli.main(["export-foxglove", str(recording), "-o", str(out), "--terrain-cells", "32"]) == 0
    topics = read_foxglove(out)
    assert set(topics) == {"/scene", "/tf", "/rover_2/photo", "/map"}

    scene = topics["/scene"]
    assert len(scene) == 1 + 3  # static, then one update per world state
    static = {e.id: e for e in scene[0][2].entities}
    assert {"terrain", "craters", "rocks", "walls", "lander", "goals"} <= set(static)
    assert len(static["rocks"].cylinders) == 9
    terrain = static["terrain"].triangles[0]
    assert len(terrain.points) > 100 and len(terrain.indices) % 3 == 0
    lander = static["lander"].cylinders[0]
    assert _pos(lander.pose)[:2] == (-560.0, 50.0)

    for i, (log_time, _, update) in enumerate(scene[1:]):
        assert log_time == T0 + i * 1_000_000_000
        entities = {e.id: e for e in update.entities}
        cubes = entities["rovers"].cubes
        assert len(cubes) == 2
        assert [_pos(c.pose)[:2] for c in cubes] == [(-510.0, 100.0 - 2 * i), (-500.0, 100.0 - 3 * i)]
        assert _ns(entities["rovers"].timestamp) == log_time
        chain = entities["links"].lines
        assert sum(len(line.points) for line in chain) == 4  # two links, two ends each

    tf = topics["/tf"]
    assert len(tf) == 6
    last = {t.child_frame_id: t for _, _, t in tf[-2:]}
    assert set(last) == {"rover_1", "rover_2"}
    assert last["rover_2"].parent_frame_id == "world"
    assert (last["rover_2"].translation.x, last["rover_2"].translation.y) == (-500.0, 94.0)

    (log_time, _, photo), = topics["/rover_2/photo"]
    assert photo.data == PNG and photo.format == "png" and photo.frame_id == "rover_2"
    assert _ns(photo.timestamp) == log_time == T0 + 2_500_000_000


def test_heading_points_rover_x_along_the_heading():
    from sessions.foxglove import heading_quaternion

    for heading, (fx, fy) in ((0.0, (0.0, 1.0)), (90.0, (1.0, 0.0)), (180.0, (0.0, -1.0))):
        q = heading_quaternion(heading)
        # The SDK keeps its fields to itself: read them back through the encoding.
        schema = type(q).get_schema()
        decoded = message_class(schema.data, schema.name).FromString(q.encode())
        assert schema.name == "foxglove.Quaternion"
        z, w = decoded.z, decoded.w
        yaw_x, yaw_y = 1 - 2 * z * z, 2 * z * w  # rotated +x for a rotation about z
        assert (yaw_x, yaw_y) == pytest.approx((fx, fy), abs=1e-9)


def test_export_keeps_raw_channels(recording: Path, tmp_path: Path):
    out = tmp_path / "out.mcap"
    assert cli.main(["export-foxglove", str(recording), "-o", str(out), "--keep-raw", "--no-trails",
                     "--terrain-cells", "16"]) == 0
    topics = read_foxglove(out)
    assert [e for _, e, _ in topics[STATE_KEY]] == ["msgpack"] * 3
    assert codec.decode(m.WorldState, topics[STATE_KEY][1][2]) == state(1)
    assert len(topics["lunar/test/rover/1/gyroscope"]) == 3
    from sessions.format import SESSION_METADATA, read_metadata

    assert "scenario" in read_metadata(out)[SESSION_METADATA]


def test_export_writes_each_schema_once_shared_by_the_channels_of_its_type(tmp_path: Path):
    path = tmp_path / "photos.mcap"
    writer = SessionWriter(path, {"scenario": SCENARIO_FILE.read_text(encoding="utf-8")})
    for rover in (1, 2, 3, 4, 2):
        t = T0 + rover * 1_000_000
        writer.write(Sample(f"lunar/test/rover/{rover}/photo", codec.encode(m.Photo(stamp=1.0, png=PNG)), t, t))
    writer.write(Sample(STATE_KEY, codec.encode(state(0)), T0 + 10**7, T0 + 10**7))
    writer.close()
    out = tmp_path / "out.mcap"
    assert cli.main(["export-foxglove", str(path), "-o", str(out), "--terrain-cells", "8"]) == 0
    from mcap.reader import make_reader

    with open(out, "rb") as stream:
        summary = make_reader(stream).get_summary()
    names = [schema.name for schema in summary.schemas.values()]
    assert sorted(names) == sorted(set(names)) and names.count("foxglove.CompressedImage") == 1
    photo_schemas = {c.schema_id for c in summary.channels.values() if c.topic.endswith("/photo")}
    assert len(photo_schemas) == 1 and summary.schemas[photo_schemas.pop()].name == "foxglove.CompressedImage"
    assert sorted(t for t in read_foxglove(out) if t.endswith("/photo")) == [f"/rover_{i}/photo" for i in (1, 2, 3, 4)]


def test_photo_keys_with_ids_no_rover_has_are_not_exported(tmp_path: Path):
    from sessions.foxglove import rover_of_key

    assert rover_of_key("lunar/test/rover/12/photo") == 12
    for rover in ("²", "99999999999999999999", "1001", "-1", "x"):
        key = f"lunar/test/rover/{rover}/photo"
        assert rover_of_key(key) is None, key
    path = tmp_path / "ids.mcap"
    writer = SessionWriter(path, {"world": "test"})
    for key in ("lunar/test/rover/99999999999999999999/photo", "lunar/test/rover/2/photo"):
        writer.write(Sample(key, codec.encode(m.Photo(stamp=1.0, png=PNG)), T0, T0))
    writer.close()
    assert cli.main(["export-foxglove", str(path), "-o", str(tmp_path / "out.mcap")]) == 0
    assert [t for t in read_foxglove(tmp_path / "out.mcap") if t.endswith("/photo")] == ["/rover_2/photo"]


def test_export_of_a_missing_file_exits_2_naming_it(tmp_path: Path, capsys):
    assert cli.main(["export-foxglove", "missing.mcap", "-o", str(tmp_path / "x.mcap")]) == 2
    assert "missing.mcap" in capsys.readouterr().err
    assert not (tmp_path / "x.mcap").exists()


def test_export_of_a_file_that_is_not_mcap_exits_2(tmp_path: Path, capsys):
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"not an mcap file at all")
    assert cli.main(["export-foxglove", str(bad), "-o", str(tmp_path / "x.mcap")]) == 2
    assert "bad.mcap" in capsys.readouterr().err


# ---- report ----


def test_report_skips_and_counts_world_states_that_do_not_decode(recording: Path, tmp_path: Path, capsys):
    broken = tmp_path / "broken.mcap"
    writer = SessionWriter(broken, {"world": "test", "scenario": SCENARIO_FILE.read_text(encoding="utf-8")})
    for sample in read_samples(recording):
        writer.write(sample)
    writer.write(Sample(STATE_KEY, b"\x92\x01\x80", T0 + 5 * 10**9, T0 + 5 * 10**9))  # the envelope, no fields
    writer.write(Sample("lunar/test/ground/command", b"garbage", T0 + 6 * 10**9, T0 + 6 * 10**9))
    writer.close()
    stats = tmp_path / "stats.json"
    assert cli.main(["report", str(broken), "--json", str(stats), "--plot", str(tmp_path / "paths.png")]) == 0
    out = capsys.readouterr().out
    # the recording's map is a hand-made 4 x 3 grid, not the scenario's: counted too, not scored
    assert (f"warning: {broken}: skipped 3 malformed samples (lunar/test/ground/command, {MAP_KEY}, "
            f"{STATE_KEY})") in out
    assert json.loads(stats.read_text())["map_corridor_mapped"] is None
    assert json.loads(stats.read_text())["mission_duration_s"] == 2.0  # the last state that decodes
    assert (tmp_path / "paths.png").stat().st_size > 10_000


def test_report_says_a_recording_has_a_gap(recording: Path, tmp_path: Path, capsys):
    from sessions.gaps import GapTracker

    gaps = GapTracker()
    gaps.connection(True, T0)
    gaps.clock(ClockMark(T0, 20, 1.0, "r"))
    gaps.connection(False, T0 + 10**9)
    gaps.connection(True, T0 + 8 * 10**9)
    gaps.clock(ClockMark(T0 + 9 * 10**9, 180, 9.0, "r"))
    path = tmp_path / "gap.mcap"
    writer = SessionWriter(path, {"world": "test", "scenario": SCENARIO_FILE.read_text(encoding="utf-8")})
    for sample in read_samples(recording):
        writer.write(sample)
    writer.close(gaps=gaps.metadata())
    assert cli.main(["report", str(path), "--no-plot"]) == 0
    assert (f"warning: {path} has 1 gap: the recorder lost its router for 7.0 s; 8.0 simulated s not recorded: "
            "the figures hold only what was recorded") in capsys.readouterr().out


# ---- plot ----


def test_plot_writes_a_png_of_the_asked_size(recording: Path, tmp_path: Path):
    from PIL import Image

    from sessions.plot import draw_trajectories

    out = draw_trajectories(recording, load_scenario(SCENARIO_FILE), tmp_path / "plot" / "paths.png",
                            size_px=(600, 450), terrain_cells=48)
    assert out.stat().st_size > 10_000
    with Image.open(out) as image:
        assert image.size == (600, 450)


def test_plot_takes_samples_too(tmp_path: Path):
    from sessions.plot import rover_paths

    samples = [Sample(STATE_KEY, codec.encode(state(i)), T0 + i, T0 + i) for i in range(3)]
    paths, last = rover_paths(samples)
    assert sorted(paths) == [1, 2] and paths[2][-1].tolist() == [-500.0, 94.0]
    assert last == state(2)


# ---- live view ----


def test_live_view_serves_and_stops(tmp_path: Path):
    import foxglove

    from web.foxglove_live import LiveScene

    live = LiveScene(load_scenario(SCENARIO_FILE), terrain_cells=16)
    capture = tmp_path / "live.mcap"
    sink = foxglove.open_mcap(capture, context=live.context)  # what a client would receive
    port = free_port()
    server = live.serve("127.0.0.1", port)
    try:
        assert server.port == port
        with socket.create_connection(("127.0.0.1", port), timeout=5):
            pass
        assert live.handle(Sample(STATE_KEY, codec.encode(state(1)), T0, T0))
        assert live.handle(Sample(PHOTO_KEY, codec.encode(m.Photo(stamp=1.0, png=PNG)), T0 + 1, T0 + 1))
        assert live.handle(Sample(MAP_KEY, codec.encode(lander_map()), T0 + 3, T0 + 3))
        assert not live.handle(Sample("lunar/test/rover/1/status",
                                      codec.encode(m.RoverStatus(stamp=1, state="done")), T0 + 2, T0 + 2))
    finally:
        server.stop()
        sink.close()
        live.close()
    topics = read_foxglove(capture)
    assert len(topics["/scene"]) == 2  # static first, then the state
    assert len(topics["/tf"]) == 2
    assert topics["/rover_2/photo"][0][2].data == PNG
    (_, _, grid), = topics["/map"]
    assert grid.column_count == 4 and len(grid.data) == MAP_CODES.size * 5


def test_export_writes_the_lander_map_as_a_grid(recording: Path, tmp_path: Path):
    """Each cell of ``/map`` carries the lander's class code and the map PNG's colour; unknown cells are clear."""
    from lander_agent.mapping import COLOURS

    out = tmp_path / "out.mcap"
    assert cli.main(["export-foxglove", str(recording), "-o", str(out), "--terrain-cells", "32"]) == 0
    (log_time, _, grid), = read_foxglove(out)["/map"]
    assert log_time == _ns(grid.timestamp) == T0 + 2_700_000_000
    assert grid.frame_id == "world" and grid.column_count == 4 and (grid.cell_size.x, grid.cell_size.y) == (2.0, 2.0)
    assert (grid.pose.position.x, grid.pose.position.y) == (-600.0, 20.0) and grid.pose.position.z > 0
    fields = {f.name: f.offset for f in grid.fields}
    assert fields == {"class": 0, "red": 1, "green": 2, "blue": 3, "alpha": 4} and grid.cell_stride == 5
    cells = np.frombuffer(grid.data, np.uint8).reshape(-1, grid.row_stride // grid.cell_stride, grid.cell_stride)
    assert cells.shape == (3, 4, 5)
    assert (cells[..., 0] == MAP_CODES).all()
    assert (cells[0, 3, 1:4] == COLOURS[2]).all() and cells[0, 3, 4] > 0  # obstacle red, seen
    assert (cells[1, 2, 1:4] == COLOURS[4]).all()  # a rover
    assert (cells[..., 4][MAP_CODES == 0] == 0).all() and (cells[..., 4][MAP_CODES != 0] > 0).all()


def test_a_map_past_the_viewers_bound_becomes_a_coarser_grid():
    from sessions import foxglove as fx

    encoded = fx.map_grid(codec.decode(m.LanderMap, huge_lander_map(4096, 2048)), T0)
    schema = type(encoded).get_schema()
    grid = message_class(schema.data, schema.name).FromString(encoded.encode())
    assert grid.column_count == 2048 and grid.cell_size.x == 2.0 and len(grid.data) == 2048 * 1024 * 5
    assert grid.data[0] == 2 and grid.data[5] == 1  # the obstacle's block, then free ground


def test_report_scores_only_a_map_of_the_scenarios_grid():
    """A map on the lander's key that is not the grid the scenario's lander builds (here 8 million cells) is
    counted, neither unpacked nor scored, and hides no map of the scenario's grid recorded before it."""
    from lander_agent.mapping import TraverseMap
    from sessions.report import report_from_samples

    scenario = load_scenario(SCENARIO_FILE)
    own = codec.encode(TraverseMap.for_scenario(scenario).to_message(2.0))
    state = codec.encode(m.WorldState(stamp=2.0, rovers=[]))
    for maps, scored in (([huge_lander_map(4096, 2048)], False), ([own], True), ([own, huge_lander_map()], True)):
        malformed = Counter()
        samples = [Sample(STATE_KEY, state, T0, T0)] + [Sample(MAP_KEY, payload, T0, T0) for payload in maps]
        report = report_from_samples(scenario, samples, "test", malformed)
        assert (report.map_corridor_mapped is not None) == scored
        assert malformed[MAP_KEY] == sum(payload != own for payload in maps) and set(malformed) <= {MAP_KEY}


def test_report_skips_and_counts_states_naming_rovers_the_scenario_does_not_have():
    from sessions.report import report_from_samples

    scenario = load_scenario(SCENARIO_FILE)  # five rovers

    def state(stamp: float, *ids: int) -> Sample:
        rovers = [m.RoverTruth(id=i, x=0.0, z=0.0, heading_deg=0.0, action="idle", state="done", goal_index=0,
                               distance_to_goal_m=0.0, distance_covered_m=0.0, alive=True) for i in ids]
        return Sample(STATE_KEY, codec.encode(m.WorldState(stamp=stamp, rovers=rovers)), T0, T0)

    malformed = Counter()
    report = report_from_samples(scenario, [state(1.0, 1, 2), state(2.0, 1, 9), state(3.0, 0, 1)], "test", malformed)
    assert malformed == Counter({STATE_KEY: 2}) and report.mission_duration_s == 1.0


def test_a_malformed_map_is_skipped_with_a_warning(tmp_path: Path, capsys):
    path = tmp_path / "bad.mcap"
    writer = SessionWriter(path, {"scenario": SCENARIO_FILE.read_text(encoding="utf-8")})
    bad = msgspec.structs.replace(lander_map(), width=5)
    writer.write(Sample(MAP_KEY, codec.encode(bad), T0, T0))
    writer.close()
    assert cli.main(["export-foxglove", str(path), "-o", str(tmp_path / "out.mcap"), "--terrain-cells", "16"]) == 0
    assert "/map" not in read_foxglove(tmp_path / "out.mcap")
    assert "12 cells for a 5 x 3 grid" in capsys.readouterr().err
