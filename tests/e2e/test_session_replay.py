"""``lunarsim replay``: the Player's timing and controls on a fake clock, the command line's errors and
controls, and one real record-then-replay over a router on loopback."""

from __future__ import annotations

import contextlib
import signal
import subprocess
import threading
import time
from types import SimpleNamespace

import pytest
import zenoh
from procs import SCENARIOS, USES_DEFAULT_PORT, lunarsim, run_cli_mission, wait_for

from bus.zenoh_config import build_config
from deploy.cli import main
from schemas import codec
from schemas import messages as m
from sessions import playback
from sessions.format import Sample, TopicFilter, read_samples
from sessions.replay import CLOCK_GLOB, Player, world_remapper
from sessions.writer import SessionWriter

BASE_NS = 1_700_000_000 * 10**9


class FakeClock:
    """Time that moves only when the player waits; ``at(t, f)`` runs ``f`` when the time reaches ``t``."""

    def __init__(self) -> None:
        self.now = 0.0
        self.events: list[tuple[float, object]] = []

    def __call__(self) -> float:
        return self.now

    def at(self, t: float, action) -> None:
        self.events.append((t, action))
        self.events.sort(key=lambda e: e[0])

    def wait(self, timeout: float | None) -> None:
        upcoming = self.events[0][0] if self.events else None
        assert timeout is not None or upcoming is not None, "paused with nothing left to resume it"
        target = upcoming if timeout is None else min(self.now + timeout, upcoming or float("inf"))
        self.now = max(self.now, target)
        while self.events and self.events[0][0] <= self.now:
            self.events.pop(0)[1]()


def samples(*times_s: float, world: str = "w1") -> list[Sample]:
    return [Sample(f"lunar/{world}/rover/{i}/status", f"p{i}".encode(), BASE_NS + round(t * 1e9), 0)
            for i, t in enumerate(times_s)]


def play(recorded: list[Sample], clock: FakeClock | None = None, **options) -> tuple[list, Player]:
    """Run a player on a fake clock; returns [(time, key, payload)] as published."""
    clock = clock or FakeClock()
    out: list[tuple[float, str, bytes]] = []
    player = Player(recorded, lambda k, p: out.append((round(clock.now, 6), k, p)), clock=clock,
                    wait=clock.wait, **options)
    player.run()
    return out, player


def times(out: list) -> list[float]:
    return [t for t, _, _ in out]


def payloads(out: list) -> list[bytes]:
    return [p for _, _, p in out]


# Timing.

def test_samples_go_out_with_their_recorded_gaps():
    out, player = play(samples(0, 0.5, 2.0))
    assert times(out) == [0, 0.5, 2.0]
    assert payloads(out) == [b"p0", b"p1", b"p2"] and player.published == 3
    assert player.duration_s == 2.0 and player.position_s == 2.0


def test_rate_divides_the_gaps():
    assert times(play(samples(0, 0.5, 2.0), rate=2)[0]) == [0, 0.25, 1.0]
    assert times(play(samples(0, 0.5, 2.0), rate=0.5)[0]) == [0, 1.0, 4.0]


def test_start_offset_skips_the_beginning_and_counts_from_there():
    out, _ = play(samples(0, 0.5, 2.0), start_offset_s=0.5)
    assert times(out) == [0, 1.5] and payloads(out) == [b"p1", b"p2"]


def test_loop_starts_again_at_the_offset_until_quit():
    clock = FakeClock()
    player_box: list[Player] = []
    clock.at(4.5, lambda: player_box[0].quit())
    out: list = []
    player = Player(samples(0, 0.5, 2.0), lambda k, p: out.append((clock.now, p)), loop=True, clock=clock,
                    wait=clock.wait)
    player_box.append(player)
    player.run()
    assert [t for t, _ in out] == [0, 0.5, 2.0, 2.0, 2.5, 4.0, 4.0]  # no pause between the end and the start
    assert player.loops == 2


def test_a_pause_delays_everything_after_it_by_its_length():
    clock = FakeClock()
    box: list[Player] = []
    clock.at(0.2, lambda: box[0].pause())
    clock.at(1.2, lambda: box[0].resume())
    out: list = []
    box.append(Player(samples(0, 0.5, 2.0), lambda k, p: out.append(clock.now), clock=clock, wait=clock.wait))
    box[0].run()
    assert [round(t, 6) for t in out] == [0, 1.5, 3.0]


def test_step_publishes_one_sample_while_paused_then_resume_keeps_the_gaps():
    clock = FakeClock()
    box: list[Player] = []
    positions: list[float] = []
    clock.at(1.0, lambda: box[0].step())
    clock.at(2.0, lambda: (box[0].step(), positions.append(box[0].position_s)))
    clock.at(3.0, lambda: box[0].resume())
    out: list = []
    box.append(Player(samples(0, 0.5, 2.0), lambda k, p: out.append((clock.now, p)), paused=True, clock=clock,
                      wait=clock.wait))
    box[0].run()
    assert out == [(1.0, b"p0"), (2.0, b"p1"), (4.5, b"p2")]
    assert positions == [0.0]  # the control is queued: carried out when the player next looks


def test_toggle_pauses_then_resumes():
    clock = FakeClock()
    box: list[Player] = []
    clock.at(0.1, lambda: box[0].toggle())
    clock.at(1.1, lambda: box[0].toggle())
    out: list = []
    box.append(Player(samples(0, 0.5), lambda k, p: out.append(clock.now), clock=clock, wait=clock.wait))
    box[0].run()
    assert [round(t, 6) for t in out] == [0, 1.5]


def test_seek_jumps_forward_and_back():
    clock = FakeClock()
    box: list[Player] = []
    clock.at(0.1, lambda: box[0].seek(1.0))  # forward: p1 is skipped, p2 is 1 s ahead
    clock.at(0.5, lambda: box[0].seek(0))  # back to the start before p2: everything again
    out: list = []
    box.append(Player(samples(0, 0.5, 2.0), lambda k, p: out.append((round(clock.now, 6), p)), clock=clock,
                      wait=clock.wait))
    box[0].run()
    assert out == [(0, b"p0"), (0.5, b"p0"), (1.0, b"p1"), (2.5, b"p2")]
    clock = FakeClock()
    clock.at(0.1, lambda: box[1].seek(1.9))
    box.append(Player(samples(0, 0.5, 2.0), lambda k, p: out.append((round(clock.now, 6), p)), clock=clock,
                      wait=clock.wait))
    out.clear()
    box[1].run()
    assert out == [(0, b"p0"), (0.2, b"p2")]


def test_seek_while_paused_stays_paused_at_the_new_position():
    clock = FakeClock()
    box: list[Player] = []
    seen: list[float] = []
    clock.at(1.0, lambda: box[0].seek(1.0))
    clock.at(2.0, lambda: (seen.append(box[0].position_s), box[0].resume()))
    out: list = []
    box.append(Player(samples(0, 0.5, 2.0), lambda k, p: out.append((clock.now, p)), paused=True, clock=clock,
                      wait=clock.wait))
    box[0].run()
    assert seen == [1.0]
    assert out == [(3.0, b"p2")]


def test_a_source_function_is_asked_again_from_the_seek_position():
    recorded = samples(0, 0.5, 2.0)
    asked: list[int | None] = []

    def source(start_ns):
        asked.append(start_ns)
        return [s for s in recorded if start_ns is None or s.log_time_ns >= start_ns]

    clock = FakeClock()
    box: list[Player] = []
    clock.at(0.1, lambda: box[0].seek(1.0))
    box.append(Player(source, lambda k, p: None, first_ns=recorded[0].log_time_ns,
                      last_ns=recorded[-1].log_time_ns, clock=clock, wait=clock.wait))
    assert box[0].run() == 2
    assert asked == [None, BASE_NS + 10**9]


def test_bad_options_are_refused():
    with pytest.raises(ValueError, match="rate"):
        Player(samples(0), lambda k, p: None, rate=0)
    with pytest.raises(ValueError, match="offset"):
        Player(samples(0), lambda k, p: None, start_offset_s=-1)


# Keys.

def test_remap_moves_keys_into_another_world():
    out, _ = play(samples(0, 1), remap=world_remapper("w1", "w2"))
    assert [k for _, k, _ in out] == ["lunar/w2/rover/0/status", "lunar/w2/rover/1/status"]
    assert world_remapper("w1", "w2")("lunar/w10/world/clock") == "lunar/w10/world/clock"


def test_the_world_clock_is_left_out_unless_asked_for():
    keep = TopicFilter(None, [CLOCK_GLOB])
    assert not keep("lunar/w1/world/clock")
    assert keep("lunar/w1/world/state") and keep("lunar/w1/rover/1/clock_like")


# Command line: errors and controls.

def test_keys_become_controls():
    assert playback.keys_to_controls(b" ") == ["toggle"]
    assert playback.keys_to_controls(b"S\x1b[Cq") == ["step", "step", "quit"]
    assert playback.keys_to_controls(b"x\x1b[A") == []


@pytest.mark.parametrize("case", ["missing", "not_mcap", "empty", "directory"])
def test_unusable_files_exit_2_naming_the_file(tmp_path, capsys, case):
    path = tmp_path / "x.mcap"
    if case == "not_mcap":
        path.write_text("hello")
    elif case == "empty":
        SessionWriter(path, {"world": "w1"}).close()
    elif case == "directory":
        path.mkdir()
    assert main(["replay", str(path), "--router-timeout", "0"]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and len(err.strip().splitlines()) == 1
    assert {"missing": "no such file", "not_mcap": "not an MCAP file", "empty": "empty",
            "directory": "not a file"}[case] in err


def test_a_recording_of_only_the_clock_says_why_nothing_is_left(tmp_path, capsys):
    path = tmp_path / "clock.mcap"
    writer = SessionWriter(path, {"world": "w1"})
    writer.write(Sample("lunar/w1/world/clock", codec.encode(m.Clock(tick=1, sim_time=0.1, time_scale=1)),
                        BASE_NS, BASE_NS))
    writer.close()
    assert main(["replay", str(path), "--router-timeout", "0"]) == 2
    assert "--clock" in capsys.readouterr().err


def test_ground_commands_control_the_player_and_bad_ones_are_ignored(capsys):
    controls: list[tuple[str, float]] = []
    player = SimpleNamespace(control=lambda name, seconds=0.0: controls.append((name, seconds)))
    own = playback.OwnCommands("lunar/w2/ground/command")
    handle = playback._command_handler(player, own)

    def send(payload: bytes) -> None:
        handle(SimpleNamespace(payload=SimpleNamespace(to_bytes=lambda: payload)))

    send(codec.encode(m.GroundCommand(command="pause")))
    send(codec.encode(m.GroundCommand(command="seek", seconds=12.5)))
    send(codec.encode(m.GroundCommand(command="stop", rover_id=1)))  # the lander's, not ours
    send(b"\x01garbage")
    recorded = codec.encode(m.GroundCommand(command="step", request_id="from-the-recording"))
    own.wrap(lambda k, p: None)("lunar/w2/ground/command", recorded)
    send(recorded)  # our own publication of a recorded command comes back: not a control
    assert controls == [("pause", 0.0), ("seek", 12.5)]
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


# Across processes.

@pytest.mark.e2e
def test_a_recorded_run_replays_into_another_world_with_the_same_samples(router, tmp_path):
    recording = tmp_path / "run.mcap"
    recorder = lunarsim("record", "-o", str(recording), "--world", "w1", "--connect", router)
    try:
        wait_for(lambda: _line_seen(recorder, "recording"), 30, "the recorder to subscribe")
        run_cli_mission(tmp_path / "run", str(SCENARIOS / "crater_observation.yaml"), "--lockstep", "--world",
                        "w1", "--connect", router, "-q", "--max-sim-time", "20", timeout=180)
    finally:
        recorder.send_signal(signal.SIGINT)
        out, err = recorder.communicate(timeout=60)
    assert recorder.returncode == 0, f"{out}\n{err}"
    expected = [(s.key.replace("lunar/w1/", "lunar/w2/", 1), s.payload) for s in read_samples(recording)]
    assert len(expected) > 100 and any(k.endswith("/world/clock") for k, _ in expected)

    received: list[tuple[str, bytes]] = []
    lock = threading.Lock()

    def on_sample(sample: zenoh.Sample) -> None:
        with lock:
            received.append((str(sample.key_expr), sample.payload.to_bytes()))

    session = zenoh.open(build_config(connect=[router]))
    subscriber = session.declare_subscriber("lunar/w2/**", zenoh.handlers.Callback(on_sample, indirect=False))
    replay = lunarsim("replay", str(recording), "--remap-world", "w2", "--rate", "20", "--clock", "--quiet",
                      "--start-paused", "--connect", router)
    try:
        # Started paused, so no sample can go out before its route to us exists; a resume starts it.
        resume = codec.encode(m.GroundCommand(command="resume"))
        wait_for(lambda: _line_seen(replay, "replaying"), 30, "the replay to start")

        def resumed() -> bool:
            session.put("lunar/w2/ground/command", resume)
            with lock:
                return any(k != "lunar/w2/ground/command" for k, _ in received)

        wait_for(resumed, 20, "the first replayed sample", interval=0.2)
        out, err = replay.communicate(timeout=120)

        def all_here() -> bool:
            with lock:
                return sum(not (k == "lunar/w2/ground/command" and p == resume) for k, p in received) >= len(expected)

        # The replay can end while its last samples are still on their way through the router to this process, and
        # a loaded machine may take a while to hand them over; the comparison below says what never came.
        with contextlib.suppress(AssertionError):
            wait_for(all_here, 30, f"the {len(expected)} replayed samples")
    finally:
        replay.kill()
        subscriber.undeclare()
        session.close()
    assert replay.returncode == 0, f"{out}\n{err}"
    assert f"replayed {len(expected)} samples" in out
    with lock:
        got = [(k, p) for k, p in received if not (k == "lunar/w2/ground/command" and p == resume)]
    # One publisher session, one router, one subscriber: Zenoh keeps the order across keys too here, so the
    # whole sequence is compared, not only each key's.
    assert [k for k, _ in got] == [k for k, _ in expected]
    assert got == expected


def _line_seen(proc: subprocess.Popen, text: str) -> bool:
    """Read one stdout line of ``proc`` (blocking until it comes) and say whether it contains ``text``."""
    if proc.poll() is not None:
        raise AssertionError(f"process exited {proc.returncode}: {proc.stderr.read() if proc.stderr else ''}")
    line = proc.stdout.readline() if proc.stdout else ""
    return text in line



def test_prefetch_yields_everything_in_order_passes_errors_on_and_stops_its_reader_when_closed():
    from sessions.replay import prefetch

    samples = [Sample(f"lunar/w/k{i}", b"x", i, i) for i in range(1000)]
    assert list(prefetch(iter(samples), size=7)) == samples

    def broken():
        yield samples[0]
        raise ValueError("chunk cut short")

    reader = prefetch(broken())
    assert next(reader) == samples[0]
    with pytest.raises(ValueError, match="cut short"):
        next(reader)
    partial = prefetch(iter(samples), size=3)
    assert next(partial) == samples[0]
    partial.close()  # a seek: the reader thread must not stay blocked on its full buffer
    wait_for(lambda: not any(t.name == "replay-read-ahead" for t in threading.enumerate()), 5,
             "the read-ahead thread to stop")


def test_prefetch_holds_at_most_its_bytes_ahead_and_passes_a_larger_sample_alone():
    from sessions.replay import prefetch

    pulled = [0]

    def source():
        for i in range(100):
            pulled[0] += 1
            yield Sample(f"lunar/w/k{i}", bytes(5000 if i == 50 else 100), i, i)

    reader = prefetch(source(), size=1000, max_bytes=1000)
    assert next(reader).log_time_ns == 0
    wait_for(lambda: pulled[0] >= 11, 5, "the reader to fill its 1,000 bytes")
    deadline = time.monotonic() + 0.3  # nothing marks a reader that stays put: watch it, bounded
    while time.monotonic() < deadline:
        assert pulled[0] <= 12  # ten held, one waiting for room, one consumed
        time.sleep(0.01)
    assert [len(s.payload) for s in reader][49] == 5000  # the large one came through, alone
    assert pulled[0] == 100


@USES_DEFAULT_PORT
def test_with_no_router_named_or_listening_a_replay_serves_as_the_router_on_the_default_endpoint(tmp_path):
    """The tour's order: a run (the world its router) ends, then a replay; a viewer left on the default endpoint
    finds the replay there."""
    from bus.zenoh_config import DEFAULT_ENDPOINT, DEFAULT_PORT, port_in_use

    assert not port_in_use("127.0.0.1", DEFAULT_PORT), "this test needs the default Zenoh port free"
    path = tmp_path / "run.mcap"
    writer = SessionWriter(path, {"world": "w1"})
    status = codec.encode(m.RoverStatus(stamp=0.0, state="waiting"))
    for i in range(50):
        writer.write(Sample("lunar/w1/rover/1/status", status, BASE_NS + i * 10**8, BASE_NS + i * 10**8))
    writer.close()
    replay = lunarsim("replay", str(path), "--start-paused", "--quiet")
    received: list[str] = []
    try:
        wait_for(lambda: port_in_use("127.0.0.1", DEFAULT_PORT), 20, "the replay listening on the default port")
        with zenoh.open(build_config(connect=[DEFAULT_ENDPOINT])) as session:
            session.declare_subscriber("lunar/w1/rover/**", lambda sample: received.append(str(sample.key_expr)))
            resume = codec.encode(m.GroundCommand(command="resume"))

            def heard() -> bool:
                session.put("lunar/w1/ground/command", resume)
                return bool(received)

            wait_for(heard, 20, "replayed samples through the replay's own router", interval=0.2)
        _, err = replay.communicate(timeout=60)
    finally:
        replay.kill()
    assert replay.returncode == 0, err
    assert f"no router at {DEFAULT_ENDPOINT}; serving as the router there" in err
