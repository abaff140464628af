"""Playing a recording back: when each sample is due, and the pause/step/seek controls, apart from Zenoh.

The ``Player`` only knows samples, a ``publish(key, payload)`` callable, a clock and a ``wait``: the
command line gives it Zenoh and the real clock, tests give it a list and a fake clock, so the timing is
tested exactly and without sleeping. Controls may come from any thread (keyboard, Zenoh callback): they
are queued and carried out by the playing thread between samples, so the playback state has one owner.

Timing: a sample is due at ``anchor_wall + (log_time - anchor_log) / rate``. The anchor is set when
playback starts, resumes, seeks or loops, so a pause does not make the samples after it late.
"""

from __future__ import annotations

import bisect
import queue
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass

from schemas.keyspace import REPLAY_STATES, ROOT, Keyspace
from sessions.format import Sample

Source = Callable[[int | None], Iterable[Sample]]
"""Samples in log-time order from a log time on (None: from the first); called again to seek or loop."""

CLOCK_SUFFIX = "/world/clock"
CLOCK_GLOB = f"{ROOT}/*{CLOCK_SUFFIX}"
"""Left out by default: a replayed clock beside a live world would drive its agents."""

NS = 1_000_000_000


@dataclass(frozen=True)
class Control:
    """One playback command: pause, resume, toggle, step, seek (with ``seconds``) or quit."""

    name: str
    seconds: float = 0.0


def list_source(samples: Sequence[Sample]) -> Source:
    """A source over samples already in memory (tests, short recordings): seeking is a binary search."""
    times = [s.log_time_ns for s in samples]

    def source(start_ns: int | None) -> Iterable[Sample]:
        return samples[bisect.bisect_left(times, start_ns) if start_ns is not None else 0:]

    return source


def world_remapper(recorded: str, target: str) -> Callable[[str], str]:
    """``lunar/<recorded>/...`` -> ``lunar/<target>/...``; keys of other worlds pass unchanged (none are
    recorded by ``lunarsim record``, which subscribes to one world)."""
    source, dest = Keyspace(recorded), Keyspace(target)

    def remap(key: str) -> str:
        return source.remap(key, dest) if key.startswith(source.prefix + "/") else key

    return remap


READ_AHEAD_BYTES = 64 * 2**20
"""Payload bytes ``prefetch`` holds at most (one sample larger than this alone still passes): a world state may be
1.75 MB, and 20,000 of them read ahead would hold 35 GB."""


def prefetch(samples: Iterable[Sample], size: int = 20_000, max_bytes: int = READ_AHEAD_BYTES) -> Iterator[Sample]:
    """Read ahead on a thread, up to ``size`` samples and ``max_bytes`` of payload: decompressing and parsing a
    dense recording costs more per sample than the gaps between samples, so reading in line with playback made
    replays run late. Closing the iterator (a seek or the end) stops the reader."""
    ahead: deque[object] = deque()
    held = [0]  # payload bytes in ``ahead``
    room = threading.Condition()
    stop = threading.Event()
    done = object()

    def put(item: object) -> bool:
        """Wait for room (an empty buffer always has it), unless the consumer has gone; False once it has."""
        n = len(item.payload) if isinstance(item, Sample) else 0
        with room:
            while ahead and (len(ahead) >= size or held[0] + n > max_bytes):
                if stop.is_set():
                    return False
                room.wait(0.1)
            if stop.is_set():
                return False
            ahead.append(item)
            held[0] += n
            room.notify_all()
        return True

    def read() -> None:
        try:
            for sample in samples:
                if not put(sample):
                    return
            item: object = done
        except Exception as exc:  # handed to the consumer, which raises it where it reads
            item = exc
        put(item)

    def take() -> object:
        with room:
            while not ahead:
                room.wait()
            item = ahead.popleft()
            held[0] -= len(item.payload) if isinstance(item, Sample) else 0
            room.notify_all()
            return item

    threading.Thread(target=read, name="replay-read-ahead", daemon=True).start()
    try:
        while (item := take()) is not done:
            if isinstance(item, Exception):
                raise item
            yield item
    finally:
        stop.set()


class ReplayToken:
    """Says on the target world's keyspace that a replay publishes there, and whether it is paused: a liveliness
    token (``Keyspace.alive_replay``) swapped when the state changes, so a viewer shows "replay" rather than "live"
    and tells a paused replay from a stopped world. ``declare(key)`` returns a token with ``undeclare()``."""

    def __init__(self, declare: Callable[[str], object], keys: Keyspace) -> None:
        self.declare, self.keys = declare, keys
        self.state: str | None = None
        self._token: object | None = None

    def show(self, paused: bool) -> None:
        state = REPLAY_STATES[1] if paused else REPLAY_STATES[0]
        if state == self.state:
            return
        old, self._token, self.state = self._token, self.declare(self.keys.alive_replay(state)), state
        if old is not None:  # the new token first: a viewer never sees the replay gone between the two
            old.undeclare()

    def close(self) -> None:
        if self._token is not None:
            self._token.undeclare()
        self._token = self.state = None


class RealWaiter:
    """The real ``wait``: sleeps up to ``timeout`` seconds but wakes at once when a control arrives."""

    def __init__(self) -> None:
        self._event = threading.Event()

    def __call__(self, timeout: float | None) -> None:
        self._event.wait(timeout)
        self._event.clear()

    def wake(self) -> None:
        self._event.set()


class Player:
    """Republishes samples with their recorded timing, scaled by ``rate``.

    ``first_ns``/``last_ns`` bound the recording (seek and the progress are relative to ``first_ns``);
    by default they are the first and last sample's log times, which needs a list-like ``samples``.
    """

    def __init__(self, samples: Sequence[Sample] | Source, publish: Callable[[str, bytes], None], *,
                 rate: float = 1.0, loop: bool = False, start_offset_s: float = 0.0, paused: bool = False,
                 remap: Callable[[str], str] | None = None, first_ns: int | None = None,
                 last_ns: int | None = None, clock: Callable[[], float] = time.monotonic,
                 wait: Callable[[float | None], None] | None = None) -> None:
        if rate <= 0:
            raise ValueError(f"the rate must be positive, got {rate}")
        if start_offset_s < 0:
            raise ValueError(f"the start offset must not be negative, got {start_offset_s}")
        self.source: Source = samples if callable(samples) else list_source(samples)
        if first_ns is None or last_ns is None:
            if callable(samples):
                raise ValueError("give first_ns and last_ns with a source function")
            first_ns = samples[0].log_time_ns if samples else 0
            last_ns = samples[-1].log_time_ns if samples else 0
        self.first_ns, self.last_ns = first_ns, last_ns
        self.publish_raw, self.remap = publish, remap or (lambda key: key)
        self.rate, self.loop, self.paused = rate, loop, paused
        self.start_ns = first_ns + round(start_offset_s * NS)
        self.clock = clock
        self._waiter = RealWaiter() if wait is None else None
        self.wait = wait or self._waiter
        self._controls: queue.SimpleQueue[Control] = queue.SimpleQueue()
        self.published = 0
        self.loops = 0
        self.cursor_ns = self.start_ns  # log time of the playback position
        self._iter: Iterator[Sample] = iter(())
        self._pending: Sample | None = None
        self._anchor_wall = 0.0
        self._anchor_log = self.start_ns
        self._quit = False

    # Controls: thread-safe, carried out by the thread in run().

    def control(self, name: str, seconds: float = 0.0) -> None:
        self._controls.put(Control(name, seconds))
        if self._waiter is not None:
            self._waiter.wake()

    def pause(self) -> None:
        self.control("pause")

    def resume(self) -> None:
        self.control("resume")

    def toggle(self) -> None:
        self.control("toggle")

    def step(self) -> None:
        """Pause (if playing) and publish the next sample."""
        self.control("step")

    def seek(self, seconds: float) -> None:
        """Jump to ``seconds`` after the start of the recording (clamped to it)."""
        self.control("seek", seconds)

    def quit(self) -> None:
        self.control("quit")

    # Where the playback is.

    @property
    def duration_s(self) -> float:
        return (self.last_ns - self.first_ns) / NS

    @property
    def position_s(self) -> float:
        """Seconds into the recording: the last published sample, or the running clock while playing."""
        cursor = self.cursor_ns
        if not self.paused and self._pending is not None:
            running = self._anchor_log + (self.clock() - self._anchor_wall) * self.rate * NS
            cursor = max(cursor, min(int(running), self._pending.log_time_ns))
        return min(max(cursor - self.first_ns, 0) / NS, self.duration_s)

    # Playing.

    def run(self) -> int:
        """Play until the end (never with ``loop``) or ``quit``; returns the number of samples published."""
        self._open(self.start_ns)
        while not self._quit:
            self._apply_controls()
            if self._quit:
                break
            if self._pending is None and not self._restart():
                break
            if self.paused:
                self.wait(None)
                continue
            delay = self._due(self._pending) - self.clock()
            if delay > 0:
                self.wait(delay)
                continue
            self._emit()
        self._close()
        return self.published

    def _due(self, sample: Sample) -> float:
        return self._anchor_wall + (sample.log_time_ns - self._anchor_log) / NS / self.rate

    def _emit(self) -> None:
        sample = self._pending
        assert sample is not None
        self.publish_raw(self.remap(sample.key), sample.payload)
        self.published += 1
        self.cursor_ns = sample.log_time_ns
        self._pending = next(self._iter, None)

    def _open(self, start_ns: int) -> None:
        """Read on from ``start_ns``; the samples at that time are due now."""
        self._close()
        self._iter = iter(self.source(start_ns if start_ns > self.first_ns else None))
        self._pending = next(self._iter, None)
        self.cursor_ns = start_ns
        self._anchor()

    def _anchor(self) -> None:
        self._anchor_wall = self.clock()
        self._anchor_log = self.cursor_ns

    def _restart(self) -> bool:
        """At the end: start again from the start offset with ``loop``, else stop."""
        if not self.loop:
            return False
        self.loops += 1
        self._open(self.start_ns)
        return self._pending is not None

    def _close(self) -> None:
        close = getattr(self._iter, "close", None)
        if close is not None:
            close()  # a file-reading generator closes its file now, not at garbage collection

    def _apply_controls(self) -> None:
        while True:
            try:
                control = self._controls.get_nowait()
            except queue.Empty:
                return
            self._apply(control)

    def _apply(self, control: Control) -> None:
        name = control.name
        if name == "toggle":
            name = "resume" if self.paused else "pause"
        if name == "pause":
            self.cursor_ns = self.first_ns + round(self.position_s * NS)
            self.paused = True
        elif name == "resume" and self.paused:
            self.paused = False
            self._anchor()
        elif name == "step":
            self.paused = True
            if self._pending is None and not self._restart():
                return
            self._emit()
        elif name == "seek":
            self._open(self.first_ns + round(max(control.seconds, 0.0) * NS))
        elif name == "quit":
            self._quit = True
