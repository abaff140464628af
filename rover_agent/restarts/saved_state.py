"""What a rover agent keeps across a restart, as a flight computer keeps it in non-volatile memory.

The pose estimate (its mean and covariance) alone is not enough: an agent killed while a move runs would come
back at the move's start, and the world finishes the move without it. So the file also holds the action in flight
(its id and what it asked), and the run it belongs to (``Clock.run``): a restarted agent asks the world how that
action ended (the world answers a repeated id with its end) and resumes where the rover really is, and a file left
by another run is never taken for this one.
"""

from __future__ import annotations

import json
import logging
import math
import os
import resource
import stat
import threading
from dataclasses import dataclass
from pathlib import Path

from shared.pose import Pose

log = logging.getLogger("lunarsim.rover")


@dataclass(frozen=True)
class SavedFlight:
    """The action in flight: ``kind`` is move or rotate; ``x``/``z`` the move's goal, ``degrees`` the rotation."""

    action_id: int
    kind: str
    start: Pose
    x: float = 0.0
    z: float = 0.0
    degrees: float = 0.0


@dataclass(frozen=True)
class SavedState:
    run: str
    pose: Pose
    flight: SavedFlight | None = None
    next_action: int = 0  # the id the agent's next action takes
    cov: list[list[float]] | None = None  # the pose estimate's covariance (``estimation.pose_filter``)

    def to_json(self) -> str:
        flight = self.flight
        return json.dumps({
            "run": self.run, "pose": _pose(self.pose), "next_action": self.next_action, "cov": self.cov,
            "flight": None if flight is None else {"action_id": flight.action_id, "kind": flight.kind,
                                                   "start": _pose(flight.start), "x": flight.x, "z": flight.z,
                                                   "degrees": flight.degrees}})

    @classmethod
    def from_json(cls, text: str) -> SavedState:
        data = json.loads(text)
        flight = data.get("flight")
        if flight is not None:
            flight = SavedFlight(int(flight["action_id"]), str(flight["kind"]), Pose(**flight["start"]),
                                 float(flight["x"]), float(flight["z"]), float(flight["degrees"]))
            if flight.kind not in ("move", "rotate"):
                raise ValueError(f"unknown action kind {flight.kind!r}")
        pose, cov = data["pose"], data.get("cov")
        if cov is not None:
            cov = [[float(v) for v in row] for row in cov]
            if len(cov) != 3 or any(len(row) != 3 for row in cov):
                raise ValueError("cov: expected a 3 x 3 matrix")
            if not _a_covariance(cov):  # the pose is still good: resumed as from a file without a covariance
                log.warning("ignoring a saved pose covariance that is none: %s", cov)
                cov = None
        return cls(str(data["run"]), Pose(float(pose["x"]), float(pose["z"]), float(pose["heading"])), flight,
                   int(data.get("next_action", 0)), cov)


def _a_covariance(cov: list[list[float]]) -> bool:
    """Finite, symmetric and positive semi-definite (every principal minor, a little slack for round-off): json
    reads NaN and Infinity, and a variance that is none would be fused and told on (a NaN one crashed the agent)."""
    if not all(math.isfinite(v) for row in cov for v in row):
        return False
    scale = max(1.0, *(abs(cov[i][i]) for i in range(3)))
    if any(abs(cov[i][j] - cov[j][i]) > 1e-9 * scale for i in range(3) for j in range(i)):
        return False
    pairs = [cov[i][i] * cov[j][j] - cov[i][j] * cov[i][j] for i in range(3) for j in range(i)]
    det = (cov[0][0] * pairs[2] - cov[0][1] * (cov[1][0] * cov[2][2] - cov[1][2] * cov[2][0])
           + cov[0][2] * (cov[1][0] * cov[2][1] - cov[1][1] * cov[2][0]))
    return (all(cov[i][i] >= 0.0 for i in range(3)) and all(p >= -1e-9 * scale ** 2 for p in pairs)
            and det >= -1e-9 * scale ** 3)


def _pose(pose: Pose) -> dict[str, float]:
    return {"x": pose.x, "z": pose.z, "heading": pose.heading}


RECORD_BYTES = 4096
"""A state is written with one ``pwrite`` at the file's start, within one page: Linux checks for a fatal signal
between the pages of a write, never within one, so a process killed mid-write leaves the previous state or the new
one, never half of each. A state is far smaller (every string in it is a bounded wire label)."""
MAX_OPEN_FILES = max(16, min(1024, resource.getrlimit(resource.RLIMIT_NOFILE)[0] // 4))
"""State files a process holds open at once, a quarter of what it may open (Zenoh and the rest keep theirs); one
with more agents opens the others for each write."""


class StateFile:
    """One agent's state file, held open and overwritten in place.

    A write and rename per save (the usual atomic replace) cost about a millisecond here and more on an SD card,
    with every action of every agent; one ``pwrite`` costs microseconds. The text is padded with blanks to the
    longest state the file has held, which JSON reads past, so the file never needs truncating."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        self.size = os.fstat(self.fd).st_size
        if self.size > RECORD_BYTES:  # no state of ours: what lies past the record would follow it in the file
            os.ftruncate(self.fd, 0)
            self.size = 0

    def write(self, state: SavedState) -> None:
        data = state.to_json().encode()
        if len(data) > RECORD_BYTES:
            raise ValueError(f"a saved state of {len(data)} bytes is over {RECORD_BYTES}")
        padded = data.ljust(self.size)  # the file never holds more than a page (truncated on opening if it did)
        os.pwrite(self.fd, padded, 0)
        self.size = len(padded)

    def still_there(self) -> bool:
        """Whether the path still names this file (not removed or replaced since it was opened)."""
        try:
            return os.stat(self.path).st_ino == os.fstat(self.fd).st_ino
        except OSError:
            return False

    def close(self) -> None:
        os.close(self.fd)


def save_state(path: Path, state: SavedState) -> None:
    """One state written to ``path`` (tests, tools); agents save through ``StateWriter``, which keeps files open."""
    file = StateFile(path)
    try:
        file.write(state)
    finally:
        file.close()


def load_state(path: Path) -> SavedState | None:
    """The saved state, or None when there is none; one that cannot be read is reported and not used. Only a
    regular file is opened (a FIFO would block the agent's start), and only its first ``RECORD_BYTES`` are
    read: a state is at most that, and a path to something endless (``/dev/zero``) filled the memory."""
    try:
        with open(path, "rb", opener=lambda name, flags: os.open(name, flags | os.O_NONBLOCK)) as f:
            if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
                raise ValueError("not a regular file")
            text = f.read(RECORD_BYTES + 1)
        if len(text) > RECORD_BYTES:
            raise ValueError(f"more than {RECORD_BYTES} bytes")
        return SavedState.from_json(text.decode())
    except FileNotFoundError:
        return None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        log.warning("ignoring the saved rover state in %s: %s", path, exc)
        return None


class _Held:
    """``StateWriter.held``'s block."""

    __slots__ = ("writer",)

    def __init__(self, writer: StateWriter) -> None:
        self.writer = writer

    def __enter__(self) -> None:
        self.writer._hold()

    def __exit__(self, *exc: object) -> None:
        self.writer._release()


class StateWriter:
    """Saves states on a thread of its own, the latest state per file, so an agent never waits for storage.

    An agent saves with every action, and a process may run hundreds of agents: each file stays open
    (``StateFile``, up to ``MAX_OPEN_FILES``) and is overwritten in place. One writer serves every agent of the
    process; ``flush`` writes what is left when the agent stops.
    """

    def __init__(self) -> None:
        self._pending: dict[Path, SavedState] = {}
        self._files: dict[Path, StateFile] = {}
        self._wake = threading.Condition()
        self._writing = threading.Lock()  # a flush must not overtake a write of an older state
        self._thread: threading.Thread | None = None
        self._holds = 0
        self._held = _Held(self)  # one object for every sample's block: it is on every sample's path

    def save(self, path: Path, state: SavedState) -> None:
        with self._wake:
            self._pending[path] = state
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="state-writer", daemon=True)
                self._thread.start()
            if not self._holds:
                self._wake.notify()

    @property
    def holding(self) -> bool:
        """Whether saves wait for a block under ``held`` to end."""
        return self._holds > 0

    def held(self) -> _Held:
        """Saves made inside the block are written once it is over. An agent saves as it starts an action, before
        the action is published: woken then, the writer took the interpreter's lock to serialise the state while
        the action waited to be encoded and sent (a tenth of a millisecond on the control loop, measured)."""
        return self._held

    def _hold(self) -> None:
        with self._wake:
            self._holds += 1

    def _release(self) -> None:
        with self._wake:
            self._holds -= 1
            if not self._holds and self._pending:
                self._wake.notify()

    def flush(self) -> None:
        self._write_pending()

    def _write_pending(self) -> None:
        with self._writing:
            with self._wake:
                taken, self._pending = list(self._pending.items()), {}
            for path, state in taken:
                try:
                    self._file(path).write(state)
                except (OSError, ValueError) as exc:
                    self._forget(path)
                    log.warning("could not save the rover state to %s: %s", path, exc)

    def _file(self, path: Path) -> StateFile:
        """The open file of ``path``; opened again when someone removed or replaced it meanwhile."""
        file = self._files.get(path)
        if file is not None and not file.still_there():
            self._forget(path)
            file = None
        if file is None:
            if len(self._files) >= MAX_OPEN_FILES:
                self._forget(next(iter(self._files)))
            file = self._files[path] = StateFile(path)
        return file

    def _forget(self, path: Path) -> None:
        file = self._files.pop(path, None)
        if file is not None:
            file.close()

    def _run(self) -> None:
        while True:
            with self._wake:
                self._wake.wait_for(lambda: self._pending and not self._holds)
            self._write_pending()


STATE_WRITER = StateWriter()
