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
import threading
from dataclasses import asdict, dataclass
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
        return json.dumps(asdict(self))

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


def save_state(path: Path, state: SavedState) -> None:
    """Atomic: a process killed mid-write leaves the previous state, never half a file."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(state.to_json())
    os.replace(tmp, path)


def load_state(path: Path) -> SavedState | None:
    """The saved state, or None when there is none; one that cannot be read is reported and not used."""
    try:
        return SavedState.from_json(path.read_text())
    except FileNotFoundError:
        return None
    except (OSError, ValueError, KeyError, TypeError) as exc:
        log.warning("ignoring the saved rover state in %s: %s", path, exc)
        return None


class StateWriter:
    """Saves states on a thread of its own, the latest state per file, so an agent never waits for storage.

    A write and rename take milliseconds on an SD card or an overlay file system, and an agent saves with every
    action: written inline, that delays every answer it sends (and every lockstep tick). One writer serves every
    agent of the process; ``flush`` writes what is left when the agent stops.
    """

    def __init__(self) -> None:
        self._pending: dict[Path, SavedState] = {}
        self._wake = threading.Condition()
        self._writing = threading.Lock()  # a flush must not overtake a write of an older state
        self._thread: threading.Thread | None = None

    def save(self, path: Path, state: SavedState) -> None:
        with self._wake:
            self._pending[path] = state
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="state-writer", daemon=True)
                self._thread.start()
            self._wake.notify()

    def flush(self) -> None:
        self._write_pending()

    def _write_pending(self) -> None:
        with self._writing:
            with self._wake:
                taken, self._pending = list(self._pending.items()), {}
            for path, state in taken:
                try:
                    save_state(path, state)
                except OSError as exc:
                    log.warning("could not save the rover state to %s: %s", path, exc)

    def _run(self) -> None:
        while True:
            with self._wake:
                self._wake.wait_for(lambda: self._pending)
            self._write_pending()


STATE_WRITER = StateWriter()
