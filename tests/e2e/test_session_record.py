"""Recording sessions to MCAP: the file format, splitting, snapshots, gaps, and a real run recorded and recovered."""

from __future__ import annotations

import json
import signal
import threading
import time
from collections import Counter
from pathlib import Path

import msgspec
import pytest
import zenoh
from mcap.reader import make_reader
from procs import SCENARIOS, free_port, lunarsim, module, run_cli_mission, stop, wait_for, wait_for_output

from bus.zenoh_config import build_config
from deploy.children import wait_for_port
from schemas import codec
from schemas import messages as m
from sessions.format import (
    DROPS_METADATA,
    GAPS_METADATA,
    SESSION_METADATA,
    Sample,
    TopicFilter,
    decode,
    read_metadata,
    read_samples,
)
from sessions.recorder import Recorder, RollingBuffer
from sessions.recover import NotARecording, recover
from sessions.writer import SessionWriter, SplittingWriter


def _clock(tick: int) -> bytes:
    return codec.encode(m.Clock(tick=tick, sim_time=tick / 20, time_scale=1.0, running=True, lockstep=False))


def _samples(n: int, world: str = "w") -> list[Sample]:
    return [Sample(f"lunar/{world}/world/clock", _clock(i), 1_000_000_000 + i * 50_000_000, 999 + i)
            for i in range(n)]


def test_a_recording_keeps_keys_payloads_times_and_says_how_to_decode_them(tmp_path):
    path = tmp_path / "s.mcap"
    writer = SessionWriter(path, {"seed": "7"})
    samples = [*_samples(3), Sample("lunar/w/alive/rover/1", b"", 2_000_000_000, 2_000_000_000)]
    for sample in samples:
        writer.write(sample)
    writer.close(Counter({"lunar/w/rover/1/perception": 2}))
    assert list(read_samples(path)) == samples
    assert decode(samples[0]).tick == 0
    meta = read_metadata(path)
    assert meta[SESSION_METADATA] == {"seed": "7"}
    assert meta[DROPS_METADATA]["total"] == "2"
    assert json.loads(meta[DROPS_METADATA]["per_key"]) == {"lunar/w/rover/1/perception": 2}
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    encodings = {c.topic: (c.message_encoding, summary.schemas.get(c.schema_id)) for c in summary.channels.values()}
    encoding, schema = encodings["lunar/w/world/clock"]
    assert encoding == "msgpack" and schema.encoding == "jsonschema" and schema.name == "Clock"
    described = json.loads(schema.data)  # the file decodes without our code: envelope and fields are described
    assert described["prefixItems"][0]["const"] == codec.SCHEMA_VERSION
    assert set(described["prefixItems"][1]["properties"]) == set(m.Clock.__struct_fields__)
    assert encodings["lunar/w/alive/rover/1"][1] is None  # liveliness carries no message: no schema


def test_topic_filters_include_then_exclude():
    keep = TopicFilter(["lunar/w/rover/*"], ["*/perception"])
    assert keep("lunar/w/rover/1/gyroscope")
    assert not keep("lunar/w/rover/1/perception")
    assert not keep("lunar/w/world/state")
    assert TopicFilter()("anything")


def test_split_by_duration_and_size_makes_numbered_files_that_together_hold_everything(tmp_path):
    samples = _samples(100)  # 5 s of clock at 20 Hz
    writer = SplittingWriter(tmp_path / "s.mcap", split_duration_s=1.0)
    for sample in samples:
        writer.write(sample)
    writer.close()
    assert [p.name for p in writer.files] == [f"s-{i:03d}.mcap" for i in range(5)]
    assert [s for p in writer.files for s in read_samples(p)] == samples
    by_size = SplittingWriter(tmp_path / "b.mcap", split_size=1000)
    for sample in samples:
        by_size.write(sample)
    by_size.close()
    assert len(by_size.files) > 2 and sum(1 for p in by_size.files for _ in read_samples(p)) == 100


def test_snapshot_keeps_only_the_last_seconds(tmp_path):
    buffer = RollingBuffer(1.0, tmp_path / "s.mcap", {"world": "w"}, "lz4")
    for sample in _samples(100):
        buffer(sample)
    path = buffer.snapshot()
    kept = list(read_samples(path))
    assert path.name == "s-snapshot-000.mcap"
    assert len(kept) == 21 and kept[-1] == _samples(100)[-1]


def test_recover_keeps_complete_chunks_of_a_cut_file_and_refuses_garbage(tmp_path):
    path = tmp_path / "s.mcap"
    writer = SessionWriter(path, chunk_size=2000)
    samples = _samples(400)
    for sample in samples:
        writer.write(sample)
    writer.close()
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) // 2])
    result = recover(cut, tmp_path / "fixed.mcap")
    kept = list(read_samples(tmp_path / "fixed.mcap"))
    assert result.truncated and 0 < len(kept) == result.messages < 400
    assert kept == samples[: len(kept)]
    (tmp_path / "junk.mcap").write_bytes(b"not an mcap file at all")
    with pytest.raises(NotARecording, match=r"junk\.mcap"):
        recover(tmp_path / "junk.mcap", tmp_path / "out.mcap")


@pytest.mark.e2e
def test_lunarsim_run_records_the_session_and_a_killed_recorder_is_recovered(tmp_path, router):
    killed = tmp_path / "killed.mcap"
    recorder = lunarsim("record", "-o", str(killed), "--world", "rec", "--connect", router)
    wait_for_output(recorder, "recording", 20)
    report, _ = run_cli_mission(tmp_path / "run", str(SCENARIOS / "crater_observation.yaml"), "--lockstep",
                                "--world", "rec", "--connect", router, "--quiet", "--max-sim-time", "40")
    _wait_until_on_disk(killed, tmp_path / "probe.mcap", "lunar/rec/world/stats", deadline_s=5.0)
    recorder.send_signal(signal.SIGKILL)
    recorder.wait(timeout=10)
    session = tmp_path / "run" / "session.mcap"  # lunarsim run records by default
    samples = list(read_samples(session))
    keys = {s.key for s in samples}
    assert {"lunar/rec/world/state", "lunar/rec/world/clock", "lunar/rec/rover/1/perception",
            "lunar/rec/rover/1/move_action", "lunar/rec/lander/comm_out"} <= keys
    final = [decode(s) for s in samples if s.key == "lunar/rec/world/stats"][-1]
    map_fields = {k: v for k, v in report.items() if k.startswith("map_")}  # the launcher scores the lander's map
    assert map_fields["map_corridor_mapped"] > 0
    assert final.final and msgspec.to_builtins(final.report) == {**report, "wall_time_s": final.report.wall_time_s,
                                                         **dict.fromkeys(map_fields)}
    meta = read_metadata(session)
    assert meta[SESSION_METADATA]["seed"] == str(report["seed"]) and "mission:" in meta[SESSION_METADATA]["scenario"]
    assert meta[DROPS_METADATA]["total"] == "0"
    recomputed = tmp_path / "from_recording.json"  # statistics from the recording alone equal the live ones
    proc = lunarsim("report", str(session), "--json", str(recomputed), "--plot", str(tmp_path / "paths.png"))
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert json.loads(recomputed.read_text()) == {**report, "wall_time_s": None}
    assert (tmp_path / "paths.png").stat().st_size > 10_000
    proc = lunarsim("report", str(killed), "--no-plot")  # the killed recorder's file as it was left
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2 and err.startswith(f"error: {killed}: the file ends early"), err
    assert f"run 'lunarsim recover {killed} -o " in err and len(err.splitlines()) == 1
    fixed = tmp_path / "fixed.mcap"
    proc = lunarsim("recover", str(killed), "-o", str(fixed))
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    recovered = list(read_samples(fixed))
    assert len(recovered) > 100 and {s.key for s in recovered} & keys
    stop(recorder)


def _wait_until_on_disk(live: Path, probe: Path, key: str, deadline_s: float) -> None:
    """The recorder flushes by time, not only by chunk size: the mission's final report reaches the disk
    within about a second, without the recorder being stopped."""
    deadline = time.monotonic() + deadline_s
    while True:
        probe.write_bytes(live.read_bytes())
        recover(probe, probe.with_suffix(".fixed.mcap"))
        if any(s.key == key and decode(s).final for s in read_samples(probe.with_suffix(".fixed.mcap"))):
            return
        assert time.monotonic() < deadline, f"the final {key} was not on disk after {deadline_s} s"
        time.sleep(0.1)


def test_recover_names_a_missing_file(tmp_path):
    proc = lunarsim("recover", str(tmp_path / "nope.mcap"), "-o", str(tmp_path / "x.mcap"))
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 2 and "nope.mcap" in err


@pytest.mark.e2e
def test_snapshot_mode_writes_on_a_ground_command_and_on_sigusr1(tmp_path, router):
    base = tmp_path / "snap.mcap"
    recorder = lunarsim("record", "-o", str(base), "--snapshot", "30", "--world", "snap", "--connect", router)
    try:
        wait_for_output(recorder, "recording", 20)
        sent = lunarsim("command", "snapshot", "--world", "snap", "--connect", router)
        assert sent.wait(timeout=60) == 0
        first = wait_for_output(recorder, "snapshot written", 20)
        recorder.send_signal(signal.SIGUSR1)
        second = wait_for_output(recorder, "snapshot written", 20)
    finally:
        stop(recorder)
    assert "snap-snapshot-000.mcap" in first and "snap-snapshot-001.mcap" in second
    commands = [decode(s) for s in read_samples(tmp_path / "snap-snapshot-000.mcap")
                if s.key == "lunar/snap/ground/command"]
    assert [c.command for c in commands] == ["snapshot"]


def _per_key(path: Path) -> dict[str, list[bytes]]:
    """Each key's payloads in order from the world's first running clock up to its final report. Before it the
    world announces itself with a stopped clock twice a second until every agent has connected, and after
    the report processes are being shut down: how many of either there are depends on wall-clock timing, not
    on the simulation. So is a lockstep tick sent again because its acks were late, and an agent's ack of a tick
    it had acked already: the copy is the same bytes, right after the original on its key. Each run names itself
    with a new run id (a restarted agent tells its own run's state from an old one's by it): it is left out of the
    comparison."""
    sequences: dict[str, list[bytes]] = {}
    started = False
    for sample in read_samples(path):
        if sample.key.endswith("/world/clock") and not started:
            started = decode(sample).running
            if not started:
                continue
        sequence = sequences.setdefault(sample.key, [])
        payload = sample.payload
        if sample.key.endswith("/world/clock"):
            payload = codec.encode(msgspec.structs.replace(decode(sample), run=""))
        if sample.key.endswith(("/world/clock", "/ack")) and sequence and sequence[-1] == payload:
            continue
        sequence.append(payload)
        if sample.key.endswith("/world/stats") and decode(sample).final:
            break
    return sequences


@pytest.mark.e2e
def test_a_lockstep_rerun_from_a_recording_repeats_its_message_sequence(tmp_path):
    first, second = tmp_path / "first", tmp_path / "again"
    common = ("--lockstep", "--quiet", "--max-sim-time", "25")
    run_cli_mission(first, str(SCENARIOS / "crater_observation.yaml"), "--seed", "5", "--port",
                    str(free_port()), *common)
    report, _ = run_cli_mission(second, "--from", str(first / "session.mcap"), "--port", str(free_port()), *common)
    assert report["seed"] == 5
    old, new = _per_key(first / "session.mcap"), _per_key(second / "session.mcap")
    assert set(old) == set(new) and len(old) > 40
    # An agent's answer to the very last tick races the world's final report to the recorder: a key may
    # hold one sample more in one recording. Everything both recorded must be the same, in the same order.
    differing = [key for key in old if abs(len(old[key]) - len(new[key])) > 1
                 or old[key][:len(new[key])] != new[key][:len(old[key])]]
    assert differing == [], f"{len(differing)} keys differ, e.g. {differing[:3]}"
    assert sum(map(len, old.values())) > 5000


def test_a_writer_puts_its_header_on_disk_at_once_and_each_flush_makes_a_recoverable_chunk(tmp_path):
    """What a SIGKILL leaves: the bytes on disk, never closed. The recorder flushes every FLUSH_S."""
    path, copy = tmp_path / "live.mcap", tmp_path / "killed.mcap"
    writer = SessionWriter(path, {"seed": "3"})
    copy.write_bytes(path.read_bytes())
    result = recover(copy, tmp_path / "fixed0.mcap")
    assert (result.messages, result.truncated) == (0, True)
    assert read_metadata(tmp_path / "fixed0.mcap")[SESSION_METADATA] == {"seed": "3"}
    samples = _samples(30)
    for sample in samples:
        writer.write(sample)
    writer.flush()
    copy.write_bytes(path.read_bytes())
    result = recover(copy, tmp_path / "fixed1.mcap")
    assert list(read_samples(tmp_path / "fixed1.mcap")) == samples and result.messages == 30
    writer.close()


def test_a_world_whose_recording_could_not_be_read_back_is_not_recorded(tmp_path, capsys):
    from deploy.cli import main

    assert main(["record", "-o", str(tmp_path / "s.mcap"), "--world", "_x", "--router-timeout", "0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: --world: invalid world name '_x'") and len(err.splitlines()) == 1
    assert not (tmp_path / "s.mcap").exists()


def test_recover_names_an_empty_file(tmp_path):
    (tmp_path / "empty.mcap").write_bytes(b"")
    with pytest.raises(NotARecording, match="empty"):
        recover(tmp_path / "empty.mcap", tmp_path / "out.mcap")


# ---- gaps: what a recorder misses while it has lost its router ----


GAP_OUTAGE_S = 3.0
"""How long the router stays down: long enough for the world's clock to run on by seconds the recorder misses."""


@pytest.mark.e2e
def test_a_router_outage_is_a_gap_in_the_recorders_summary_its_metadata_and_the_report(tmp_path):
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    crater = str(SCENARIOS / "crater_observation.yaml")
    router = _router(port)
    path = tmp_path / "gap.mcap"
    recorder = lunarsim("record", "-o", str(path), "--world", "gap", "--scenario", crater, "--connect", endpoint)
    world = module("world_service", crater, "--world", "gap", "--connect", endpoint, "--start-timeout", "0",
                   "--no-lander")
    heard: list[m.Clock] = []
    watcher = zenoh.open(build_config(connect=[endpoint]))
    watcher.declare_subscriber("lunar/gap/world/clock",
                               lambda sample: heard.append(codec.decode(m.Clock, sample.payload.to_bytes())))
    try:
        wait_for_output(recorder, "recording", 30)
        wait_for(lambda: heard and heard[-1].running and heard[-1].sim_time > 1.0, 60, "the world's clock running")
        router.kill()
        router.wait(timeout=10)
        wait_for_output(recorder, "lost the router", 10)
        time.sleep(GAP_OUTAGE_S)  # the outage itself: while no process reaches another there is nothing to wait for
        router = _router(port)
        wait_for_output(recorder, "router back", 30)
        resumed = heard[-1].sim_time
        wait_for(lambda: heard[-1].sim_time > resumed + 2.0, 30, "the world's clock heard again through the router")
        recorder.send_signal(signal.SIGINT)
        out, err = recorder.communicate(timeout=60)
    finally:
        watcher.close()
        stop(recorder, world, router)
    assert recorder.returncode == 0, err
    assert "; 1 gap: the recorder lost its router for " in out.strip().splitlines()[-1]
    record = read_metadata(path)[GAPS_METADATA]
    (gap,) = json.loads(record["gaps"])
    assert record["count"] == "1" and gap["sim_s"] >= GAP_OUTAGE_S / 2  # the world ran at real time meanwhile
    recorded = [decode(s).sim_time for s in read_samples(path) if s.key == "lunar/gap/world/clock"]
    assert gap["sim_from"] in recorded and gap["sim_to"] in recorded  # bounded by clocks the file holds...
    assert not [t for t in recorded if gap["sim_from"] < t < gap["sim_to"]]  # ...and nothing between them
    report = lunarsim("report", str(path), "--no-plot")
    out, err = report.communicate(timeout=120)
    assert report.returncode == 0, err
    assert f"warning: {path} has 1 gap: the recorder lost its router for" in out


def _router(port: int):
    proc = module("deploy.router", "--listen", f"tcp/127.0.0.1:{port}")
    assert wait_for_port("127.0.0.1", port, 15, proc), "the router did not start"
    return proc


def test_a_writer_that_falls_behind_drops_and_counts_what_its_bound_cannot_hold_and_writes_the_rest():
    """The recorder's inbox is bounded: a stalled disk costs samples, counted per key, never memory without end;
    what was held is written once the writer moves again. One peer session delivers its own puts."""
    session = zenoh.open(build_config("peer"))
    stalled, written = threading.Event(), []

    def sink(sample: Sample) -> None:
        stalled.wait(30)
        written.append(sample.payload)

    recorder = Recorder(session, "lunar/w/**", sink, queue_samples=10)
    try:
        for i in range(50):
            session.put("lunar/w/rover/1/perception", str(i).encode())
        wait_for(lambda: recorder.received + sum(recorder.drops.values()) == 50, 10, "every put at the recorder")
        stalled.set()
        recorder.stop()
        assert recorder.drops == Counter({"lunar/w/rover/1/perception": 50 - recorder.received})
        assert 10 <= recorder.received <= 11  # the bound, and one the writer may have taken before it stalled
        assert written == [str(i).encode() for i in range(recorder.received)]
    finally:
        session.close()
