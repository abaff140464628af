"""Recording Zenoh traffic: a subscriber that only enqueues, and a writer thread that drains to MCAP.

The Zenoh callback copies the payload and stamps it, nothing more, so the receiving thread never waits on disk or
compression; the writer takes what has arrived every ``DRAIN_S``. The inbox is bounded: if the writer ever falls
that far behind, samples are dropped and counted per key (and written into the file's metadata), rather than memory
growing without limit. In snapshot mode the writer keeps only a rolling window of the last N seconds and writes it
on a trigger.

What a recorder cut off from its router misses never reaches the queue, so it is counted apart: ``RouterWatch``
polls the session for its router, and the writer thread shows every world clock (also one the filters leave out)
to a ``GapTracker``, which says how long each outage lasted in wall and simulated seconds.

``record`` is ``lunarsim record``: a recorder on a world's keys until stopped, with the metadata that says how to
reproduce the session (``session_metadata``).
"""

from __future__ import annotations

import json
import logging
import shlex
import signal
import sys
import threading
import time
from collections import Counter, deque
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING

import msgspec
import zenoh

from bus import process
from bus.bus import zenoh_callback
from schemas import codec
from schemas import messages as m
from sessions.format import Sample, TopicFilter
from sessions.gaps import ClockMark, Gap, GapTracker
from sessions.writer import SessionWriter, SplittingWriter

if TYPE_CHECKING:
    from schemas.keyspace import Keyspace

log = logging.getLogger("lunarsim.record")
QUEUE_SAMPLES = 200_000
DRAIN_S = 0.02
"""Seconds between the writer's turns at what has arrived. Woken for every sample instead, the writer thread took
the GIL back from Zenoh's thread for each: about a quarter of the recorder's CPU in a lockstep mission, which
sends a dozen samples every few milliseconds."""
FLUSH_S = 1.0
"""Seconds between chunk flushes while samples arrive: at most this much of a recording dies with a SIGKILL."""


class Recorder:
    """Subscribes to ``key_expr`` and hands every sample that passes ``keep`` to ``sink`` on its own thread; with
    ``gaps``, the world clocks on ``clock_key`` go to the tracker too."""

    def __init__(self, session: zenoh.Session, key_expr: str, sink: Callable[[Sample], None],
                 keep: TopicFilter | None = None, queue_samples: int = QUEUE_SAMPLES,
                 flush: Callable[[], None] | None = None, flush_s: float = FLUSH_S,
                 clock_key: str | None = None, gaps: GapTracker | None = None) -> None:
        self.keep = keep or TopicFilter()
        self.sink, self.flush, self.flush_s = sink, flush, flush_s
        self.clock_key, self.gaps = (clock_key, gaps) if gaps is not None else (None, None)
        self.drops: Counter[str] = Counter()
        self.received = 0
        self._limit = queue_samples
        self._arrived: deque[tuple[Sample, bool]] = deque()  # appended by Zenoh's thread, taken by the writer's
        self._stopping = threading.Event()
        self._thread = threading.Thread(target=self._drain, name="recorder-writer", daemon=True)
        self._thread.start()
        self._subscriber = session.declare_subscriber(key_expr, zenoh_callback(self._on_sample))

    def _on_sample(self, sample: zenoh.Sample) -> None:
        now = time.time_ns()
        key = str(sample.key_expr)
        kept = self.keep(key)
        if not kept and key != self.clock_key:
            return
        stamp = sample.timestamp
        published = stamp.get_time_as_ntp64().as_nanos() if stamp is not None else now  # HLC: Unix epoch
        if len(self._arrived) >= self._limit:
            if kept:
                self.drops[key] += 1
            return
        self._arrived.append((Sample(key, sample.payload.to_bytes(), now, published), kept))
        if kept:
            self.received += 1

    def _drain(self) -> None:
        pending, last_flush = False, time.monotonic()
        while True:
            stopping = self._stopping.wait(DRAIN_S)
            while self._arrived:
                sample, kept = self._arrived.popleft()
                if sample.key == self.clock_key:
                    self._clock(sample)
                if kept:
                    pending = self._write(sample) or pending
            if stopping:
                return
            if pending and self.flush is not None and time.monotonic() - last_flush >= self.flush_s:
                self._flush()
                pending, last_flush = False, time.monotonic()

    def _write(self, sample: Sample) -> bool:
        try:
            self.sink(sample)
            return True
        except Exception:  # a bad sample must not stop the recording of the good ones
            log.exception("could not write a sample of %s", sample.key)
            return False

    def _clock(self, sample: Sample) -> None:
        try:
            clock = codec.decode(m.Clock, sample.payload)
        except codec.DecodeError:
            return  # recorded as it came, if kept; it bounds no gap
        assert self.gaps is not None
        self.gaps.clock(ClockMark(sample.log_time_ns, clock.tick, clock.sim_time, clock.run))

    def _flush(self) -> None:
        try:
            self.flush()
        except OSError as exc:  # a full disk: keep receiving, the next flush may succeed
            log.error("could not flush the recording: %s", exc)

    def stop(self) -> None:
        """Stop receiving, then write everything already received."""
        self._subscriber.undeclare()
        self._stopping.set()
        self._thread.join()


class RouterWatch:
    """Whether the session still reaches a router (or, in peer mode, a peer), polled from the recorder's main loop;
    each change goes to the gap tracker and is said on stdout as it happens."""

    def __init__(self, session: zenoh.Session, gaps: GapTracker, say: Callable[[str], None] | None = None) -> None:
        self.session, self.gaps = session, gaps
        self.say = say or (lambda text: print(text, flush=True))

    def poll(self) -> Gap | None:
        info = self.session.info
        connected = any(True for _ in info.routers_zid()) or any(True for _ in info.peers_zid())
        gap = self.gaps.connection(connected, time.time_ns())
        if gap is not None and gap.back_ns is None:
            self.say("lost the router: samples published until it is back are missing (counted as a gap)")
        elif gap is not None:
            self.say(f"router back after {gap.wall_s:.1f} s: counted as a gap")
        return gap


class RollingBuffer:
    """The last ``seconds`` of samples, written to a new file on ``snapshot()`` (SIGUSR1, ground command)."""

    def __init__(self, seconds: float, base: Path, session: dict[str, str] | None, compression: str,
                 gaps: GapTracker | None = None) -> None:
        self.window_ns = int(seconds * 1e9)
        self.base, self.session, self.compression, self.gaps = base, session, compression, gaps
        self.samples: deque[Sample] = deque()
        self.snapshots: list[Path] = []
        self._lock = threading.Lock()

    def __call__(self, sample: Sample) -> None:
        with self._lock:
            self.samples.append(sample)
            while self.samples and sample.log_time_ns - self.samples[0].log_time_ns > self.window_ns:
                self.samples.popleft()

    def snapshot(self) -> Path:
        with self._lock:
            samples = list(self.samples)
        path = self.base.with_name(f"{self.base.stem}-snapshot-{len(self.snapshots):03d}{self.base.suffix}")
        writer = SessionWriter(path, self.session, self.compression)
        for sample in samples:
            writer.write(sample)
        since = samples[0].log_time_ns if samples else None
        writer.close(gaps=self.gaps.metadata(since) if self.gaps is not None else None)
        self.snapshots.append(path)
        return path


@dataclass(frozen=True)
class RecordSpec:
    """What ``lunarsim record`` writes (its ``--help`` says what each option does)."""

    output: Path
    compression: str = "zstd"
    topics: list[str] | None = None
    exclude: list[str] | None = None
    split_size: int | None = None
    split_duration: float | None = None
    snapshot: float | None = None
    duration: float | None = None


def session_metadata(world: str, scenario_file: Path | None) -> dict[str, str]:
    """What a recording needs to say how to reproduce itself."""
    info = {"world": world, "software": "lunarsim", "command_line": shlex.join(sys.argv),
            "recorded_at": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
    try:
        info["version"] = metadata.version("lunarsim")
    except metadata.PackageNotFoundError:
        info["version"] = "unknown"
    if scenario_file is not None:
        from schemas.scenario import load_scenario

        scenario = load_scenario(scenario_file)  # validated: a broken scenario is named now, not at replay
        info["scenario"] = scenario_file.read_text(encoding="utf-8")
        info["scenario_name"] = scenario.name
        info["seed"] = str(scenario.seed)
        info["rover_params"] = json.dumps(msgspec.to_builtins(scenario.rover_params))
    return info


def record(session: zenoh.Session, keys: Keyspace, spec: RecordSpec, info: dict[str, str]) -> None:
    """Record the world's keys until SIGINT or SIGTERM (or ``spec.duration``), then say what was written, dropped
    and missed. In snapshot mode, SIGUSR1 or a ``snapshot`` ground command writes the last seconds."""
    gaps = GapTracker()
    if spec.snapshot is not None:
        sink = RollingBuffer(spec.snapshot, spec.output, info, spec.compression, gaps)
    else:
        sink = SplittingWriter(spec.output, info, spec.compression, spec.split_size, spec.split_duration)
    keep = TopicFilter(spec.topics, spec.exclude)
    with process.stop_on_signals() as stop:
        flush = sink.flush if isinstance(sink, SplittingWriter) else None
        recorder = Recorder(session, keys.all, _with_triggers(sink, keys), keep, flush=flush, clock_key=keys.clock,
                            gaps=gaps)
        watch = RouterWatch(session, gaps)
        watch.poll()
        if isinstance(sink, RollingBuffer):
            signal.signal(signal.SIGUSR1, lambda *_: _snapshot(sink))
        print(f"recording {keys.all} to {spec.output}", flush=True)
        deadline = time.monotonic() + spec.duration if spec.duration else None
        while not stop.wait(0.2):
            watch.poll()
            if deadline is not None and time.monotonic() >= deadline:
                break
        recorder.stop()
        gaps.close(time.time_ns())
    if isinstance(sink, SplittingWriter):
        sink.close(recorder.drops, gaps.metadata())
        files = ", ".join(map(str, sink.files))
        print(f"recorded {sink.count} samples to {files}; dropped {sum(recorder.drops.values())}"
              + (f" ({dict(recorder.drops)})" if recorder.drops else "") + f"; {gaps.summary()}", flush=True)
    else:
        print(f"snapshots written: {len(sink.snapshots)}; {gaps.summary()}", flush=True)


def _with_triggers(sink, keys):
    """A sink that also watches ground commands for a ``snapshot`` trigger (snapshot mode only)."""
    if not isinstance(sink, RollingBuffer):
        return sink.write

    def write(sample) -> None:
        sink(sample)
        if sample.key == keys.ground_command:
            try:
                command = codec.decode(m.GroundCommand, sample.payload)
            except codec.DecodeError as exc:
                print(f"ignored a malformed ground command: {exc}", file=sys.stderr, flush=True)
                return
            if command.command == "snapshot":
                _snapshot(sink)

    return write


def _snapshot(sink) -> None:
    path = sink.snapshot()
    print(f"snapshot written to {path}", flush=True)
