"""A session file checked before any command uses it (``sessions.recording``): another tool's MCAP, a world name that
is not a safe keyspace name, a file cut short or damaged inside, foreign channels beside LunarSim's. Each is refused
by ``replay``, ``report`` and ``export-foxglove`` alike with one line and exit code 2, before a replay opens Zenoh."""

from __future__ import annotations

import json
import shlex
from pathlib import Path

import pytest
import zenoh
from procs import SCENARIOS, free_port, lunarsim, wait_for, wait_for_output

from bus.zenoh_config import build_config
from deploy.cli import main
from schemas import codec
from schemas import messages as m
from sessions.format import Sample, read_samples
from sessions.recording import check_recording, lunarsim_key
from sessions.writer import SessionWriter

BASE_NS = 1_700_000_000 * 10**9


def test_the_recorded_world_comes_from_the_metadata_else_the_keys(tmp_path):
    status = codec.encode(m.RoverStatus(stamp=0.0, state="waiting"))
    for name, session in (("meta", {"world": "moon"}), ("bare", None)):
        writer = SessionWriter(tmp_path / f"{name}.mcap", session)
        writer.write(Sample("lunar/other/rover/1/status", status, BASE_NS, BASE_NS))
        writer.close()
    assert check_recording(tmp_path / "meta.mcap").world == "moon"
    assert check_recording(tmp_path / "bare.mcap").world == "other"
    SessionWriter(tmp_path / "none.mcap", {"seed": "1"}).close()
    assert check_recording(tmp_path / "none.mcap").world is None


# Files that are not what they claim, refused by every command that reads one.

SCENARIO_FILE = SCENARIOS / "crater_observation.yaml"
COMMANDS = {"replay": ("--connect", f"tcp/127.0.0.1:{free_port()}", "--router-timeout", "0", "--quiet"),
            "report": ("--no-plot",), "export-foxglove": ("-o", "{tmp}/out.mcap", "--terrain-cells", "8")}
"""Every command that reads a recording, with what it needs besides the file (a replay that got past its checks
would find no router there, and never serves as one on the default port)."""


def run_command(command: str, path: Path, tmp_path: Path, capsys) -> tuple[int, str]:
    """``lunarsim COMMAND FILE ...`` in this process: (exit code, stderr)."""
    extra = [a.replace("{tmp}", str(tmp_path)) for a in COMMANDS[command]]
    code = main([command, str(path), *extra])
    return code, capsys.readouterr().err


def write_recording(path: Path, session: dict[str, str] | None = None, world: str = "w1", states: int = 200,
                    chunk_size: int = 4000) -> list[Sample]:
    """A small recording as ``lunarsim record --scenario`` makes one: world states and clocks in small chunks."""
    session = {"world": world, "scenario": SCENARIO_FILE.read_text(encoding="utf-8")} if session is None else session
    writer = SessionWriter(path, session, chunk_size=chunk_size)
    written = []
    for i in range(states):
        t = BASE_NS + i * 100_000_000
        rover = m.RoverTruth(id=1, x=-510.0, z=100.0 - 0.1 * i, heading_deg=180.0, action="move", state="migration",
                             goal_index=0, distance_to_goal_m=50.0, distance_covered_m=0.1 * i, alive=True)
        for key, message in ((f"lunar/{world}/world/state", m.WorldState(stamp=i / 10, rovers=[rover])),
                             (f"lunar/{world}/world/clock", m.Clock(tick=i, sim_time=i / 10, time_scale=1.0))):
            written.append(Sample(key, codec.encode(message), t, t))
            writer.write(written[-1])
    writer.close()
    return written


def write_foreign(path: Path, channels: dict[str, int], metadata: dict[str, str] | None = None) -> None:
    """An MCAP file as another tool writes one: JSON channels named as it likes."""
    from mcap.writer import Writer

    with open(path, "wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="another tool")
        schema = writer.register_schema("Foo", "jsonschema", b'{"type": "object"}')
        for topic, count in channels.items():
            channel = writer.register_channel(topic, "json", schema)
            for i in range(count):
                writer.add_message(channel, log_time=BASE_NS + i, publish_time=BASE_NS + i,
                                   data=json.dumps({"i": i}).encode())
        if metadata:
            writer.add_metadata("lunarsim.session", metadata)
        writer.finish()


@pytest.mark.parametrize("command", COMMANDS)
def test_a_file_of_another_tool_is_refused_in_one_line_naming_its_channels(tmp_path, capsys, command):
    path = tmp_path / "foreign.mcap"
    write_foreign(path, {"/foo": 5, "/bar/baz": 2})
    code, err = run_command(command, path, tmp_path, capsys)
    assert code == 2
    assert err == f"error: {path}: not a LunarSim recording (no lunarsim metadata; channels: /bar/baz, /foo)\n"
    assert not (tmp_path / "out.mcap").exists()


@pytest.mark.parametrize("command", COMMANDS)
def test_lunarsim_metadata_over_foreign_channels_only_is_refused(tmp_path, capsys, command):
    path = tmp_path / "foreign.mcap"
    write_foreign(path, {"/foo": 1, "lunar/w1/rover/*/move_action": 1}, metadata={"world": "w1"})
    code, err = run_command(command, path, tmp_path, capsys)
    assert code == 2
    assert err == f"error: {path}: holds no LunarSim key (channels: /foo, lunar/w1/rover/*/move_action)\n"


@pytest.mark.parametrize("world", ["../../evil", "-rf", "a.b", "x" * 65, "w\n1", "@admin", ""])
@pytest.mark.parametrize("command", COMMANDS)
def test_a_recorded_world_name_that_is_not_a_safe_keyspace_name_is_refused(tmp_path, capsys, command, world):
    path = tmp_path / "evil.mcap"
    write_recording(path, {"world": world}, states=3)
    code, err = run_command(command, path, tmp_path, capsys)
    assert code == 2 and len(err.splitlines()) == 1, err
    assert err.startswith(f"error: {path}: the recorded world name {world[:60]!r} is not a valid world name")


@pytest.mark.parametrize("keep", [0.3, 0.6, 0.97])
@pytest.mark.parametrize("command", COMMANDS)
def test_a_file_cut_short_is_refused_with_the_recover_command_that_mends_it(tmp_path, capsys, command, keep):
    whole = tmp_path / "whole.mcap"
    written = write_recording(whole)
    data = whole.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * keep)])
    code, err = run_command(command, cut, tmp_path, capsys)
    assert code == 2 and len(err.splitlines()) == 1, err
    assert err.startswith(f"error: {cut}: the file ends early")
    suggested = shlex.split(err.split("run '", 1)[1].split("'", 1)[0])  # the command it names, run as given
    assert suggested[:2] == ["lunarsim", "recover"]
    assert main(suggested[1:]) == 0
    fixed = Path(suggested[-1])
    recovered = list(read_samples(fixed))
    assert recovered and recovered == written[: len(recovered)]  # cut in the summary, every message is kept
    capsys.readouterr()
    assert main(["report", str(fixed), "--no-plot"]) == 0  # the recovered file serves where the cut one did not


def test_a_file_damaged_inside_is_refused_in_one_line(tmp_path, capsys):
    """Its summary is whole, so the damage shows only as the file is read: a replay would meet it while playing."""
    path = tmp_path / "damaged.mcap"
    write_recording(path)
    data = bytearray(path.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 64] = bytes(64)  # inside a chunk: its compressed data no longer decompresses
    path.write_bytes(bytes(data))
    for command in ("report", "export-foxglove"):
        code, err = run_command(command, path, tmp_path, capsys)
        assert code == 2 and len(err.strip().splitlines()) == 1, (command, err)
        assert f"{path}: damaged MCAP recording (" in err and "lunarsim recover" in err


def test_a_closed_file_written_without_a_summary_is_read_record_by_record(tmp_path):
    from mcap.writer import IndexType, Writer

    path = tmp_path / "no_summary.mcap"
    with open(path, "wb") as stream:
        writer = Writer(stream, index_types=IndexType.NONE, repeat_channels=False, repeat_schemas=False,
                        use_statistics=False, use_summary_offsets=False)
        writer.start(profile="lunarsim")
        ours, theirs = (writer.register_channel(topic, "msgpack", 0) for topic in ("lunar/w1/world/clock", "/foo"))
        for i in range(5):
            payload = codec.encode(m.Clock(tick=i, sim_time=i / 10, time_scale=1.0))
            writer.add_message(ours, log_time=BASE_NS + i, publish_time=0, data=payload)
            writer.add_message(theirs, log_time=BASE_NS + i, publish_time=0, data=b"{}")
        writer.add_metadata("lunarsim.session", {"world": "w1"})
        writer.finish()
    recording = check_recording(path)
    assert (recording.world, recording.keys, recording.foreign) == ("w1", {"lunar/w1/world/clock"}, {"/foo": 5})
    assert (recording.first_ns, recording.last_ns, recording.messages) == (BASE_NS, BASE_NS + 4, 5)
    assert [s.key for s in recording.samples()] == ["lunar/w1/world/clock"] * 5


def test_only_plain_keys_of_a_valid_world_are_lunarsim_keys():
    assert lunarsim_key("lunar/w1/rover/1/move_action") and lunarsim_key("lunar/w-1_x/world/clock")
    for topic in ("/foo", "lunar/w1", "lunar/w1/rover/*/move_action", "lunar/w1/rover/**", "lunar/../x/y",
                  "lunar/w1/rover//status", "lunar/w1/@admin/x", "lunar/w1/rover/1/$x", "lunar/-w/world/clock",
                  "other/w1/world/clock", "lunar/w1/" + "a/" * 200 + "b", "lunar/w1/rover/1/stätus"):
        assert not lunarsim_key(topic), topic


@pytest.mark.e2e
def test_a_replay_publishes_the_lunarsim_keys_of_a_mixed_file_and_says_what_it_skipped(router, tmp_path):
    path = tmp_path / "mixed.mcap"
    writer = SessionWriter(path, {"world": "w1"})
    status = codec.encode(m.RoverStatus(stamp=0.0, state="waiting"))
    for i in range(20):
        t = BASE_NS + i * 10**7
        for key in ("lunar/w1/rover/1/status", "/foo", "lunar/w1/rover/*/status", "lunar/w1/world/@x"):
            writer.write(Sample(key, status, t, t))
    writer.close()
    received: list[str] = []
    session = zenoh.open(build_config(connect=[router]))
    subscriber = session.declare_subscriber("lunar/**", lambda sample: received.append(str(sample.key_expr)))
    replay = lunarsim("replay", str(path), "--rate", "10", "--quiet", "--start-paused", "--connect", router)
    try:
        wait_for_output(replay, "replaying", 30)
        resume = codec.encode(m.GroundCommand(command="resume"))

        def resumed() -> bool:
            session.put("lunar/w1/ground/command", resume)
            return "lunar/w1/rover/1/status" in received

        wait_for(resumed, 20, "the first replayed sample", interval=0.2)
        out, err = replay.communicate(timeout=60)
    finally:
        replay.kill()
        subscriber.undeclare()
        session.close()
    assert replay.returncode == 0, err
    assert "replayed 20 samples" in out
    assert {k for k in received if k != "lunar/w1/ground/command"} == {"lunar/w1/rover/1/status"}
    assert (f"warning: {path}: skipping 3 channels not on a LunarSim key (60 messages): /foo, "
            "lunar/w1/rover/*/status, lunar/w1/world/@x") in err
    assert "Error" not in err and ".rs:" not in err
