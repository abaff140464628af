"""``lunarsim export-rosbag``: a recorded crater mission as a rosbag2 folder (MCAP, CDR) that ``rosbags``' own
reader opens, with every bridged topic, its type, every message the recording holds for it, equal to what the
bridge's mapping makes of it."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest
import yaml
from procs import SCENARIOS, free_port, run_cli_mission

from deploy import cli
from ros2_bridge import ros_types
from ros2_bridge import topics as tp
from ros2_bridge.mapping import RayLayout
from ros2_bridge.translator import Translator
from schemas.keyspace import Keyspace
from schemas.scenario import load_scenario
from sessions.format import read_samples

pytestmark = pytest.mark.e2e
WORLD = "bag"


@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("crater") / "run"
    run_cli_mission(out, str(SCENARIOS / "crater_observation.yaml"), "--rovers", "2", "--lockstep",
                    "--max-sim-time", "40", "--world", WORLD, "--quiet", "--port", str(free_port()))
    return out / "session.mcap"


def _read_bag(folder: Path) -> dict[str, list[tuple[str, int, dict]]]:
    from rosbags.rosbag2 import Reader

    found: dict[str, list] = {}
    with Reader(folder) as reader:
        for connection, timestamp, raw in reader.messages():
            found.setdefault(connection.topic, []).append(
                (connection.msgtype, timestamp, ros_types.decode(connection.msgtype, bytes(raw))))
    return found


def test_the_export_reads_back_with_every_topic_type_and_message(recorded: Path, tmp_path: Path, capsys):
    bag = tmp_path / "bag"
    assert cli.main(["export-rosbag", str(recorded), "-o", str(bag)]) == 0
    assert "wrote" in capsys.readouterr().out
    metadata = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert metadata["version"] == 9 and metadata["storage_identifier"] == "mcap"
    found = _read_bag(bag)

    keys = Keyspace(WORLD)
    raw = Counter(sample.key for sample in read_samples(recorded))
    for rover in (1, 2):
        assert len(found[f"/rover_{rover}/scan"]) == raw[keys.rover(rover, "perception")] > 0
        assert len(found[f"/rover_{rover}/imu"]) == raw[keys.rover(rover, "gyroscope")] > 0
        assert len(found[f"/rover_{rover}/odom"]) == raw[keys.rover(rover, "pose_estimate")] > 0
        assert len(found[f"/rover_{rover}/navigation_status"]) == (raw[keys.rover(rover, "navigation_status")]
                                                                   + raw[keys.rover(rover, "action_rejected")])
    assert len(found["/clock"]) == raw[keys.clock] > 0
    assert len(found.get("/lander/map", [])) == raw[keys.lander("map")]
    types = {t.name: t.ros_type for t in tp.TOPICS}
    for topic, messages in found.items():
        generic = topic.replace("rover_1", "rover_{id}").replace("rover_2", "rover_{id}")
        assert {ros_type for ros_type, _, _ in messages} == {types[generic]}, topic
    assert "/tf" not in found

    scenario = load_scenario(SCENARIOS / "crater_observation.yaml")
    mapping = Translator(keys, RayLayout.of(scenario.rover_params.perception),
                         scenario.rover_params.perception.gyroscope_noise_std_deg)
    expected: dict[str, list[tuple[int, dict]]] = {}
    for sample in read_samples(recorded):
        for topic, ros_type, fields in mapping.outbound(sample.key, sample.payload):
            expected.setdefault(topic, []).append(
                (sample.log_time_ns, ros_types.decode(ros_type, ros_types.encode(ros_type, fields))))
    assert set(expected) == set(found)
    for topic, messages in found.items():
        assert [(t, fields) for _, t, fields in messages] == expected[topic], topic


def test_an_existing_output_is_refused_before_anything_is_read(tmp_path: Path, capsys):
    (tmp_path / "bag").mkdir()
    assert cli.main(["export-rosbag", str(tmp_path / "missing.mcap"), "-o", str(tmp_path / "bag")]) == 2
    assert "already exists" in capsys.readouterr().err
