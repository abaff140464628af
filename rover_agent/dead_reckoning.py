"""Dead reckoning: the rover's pose in the lander's frame, from its own completed actions only.

The rover never receives ground truth (design doc). It starts from the pose the lander deployed it at
(the Calibration message) and adds what its actions did: a completed move ends on its goal facing along
it, a completed rotate adds its angle, and a move that ended early lands where its CancelResult says.
"""

from __future__ import annotations

import json
import logging
import math
import os
import threading
from dataclasses import asdict, dataclass
from pathlib import Path

from schemas.frames import bearing_deg, to_world

log = logging.getLogger("lunarsim.rover")


@dataclass(frozen=True)
class Pose:
    x: float
    z: float
    heading: float

    def after_move(self, rel_x: float, rel_z: float) -> Pose:
        x, z = to_world(self.x, self.z, self.heading, rel_x, rel_z)
        moved = math.hypot(rel_x, rel_z) > 1e-9
        return Pose(x, z, bearing_deg(x - self.x, z - self.z) if moved else self.heading)

    def after_rotate(self, degrees: float) -> Pose:
        return Pose(self.x, self.z, (self.heading + degrees) % 360.0)

    def after_partial(self, rel_x: float, rel_z: float, angle_deg: float) -> Pose:
        """Where an action that started at this pose actually stopped (CancelResult)."""
        x, z = to_world(self.x, self.z, self.heading, rel_x, rel_z)
        return Pose(x, z, (self.heading + angle_deg) % 360.0)


def save_pose(path: Path, pose: Pose) -> None:
    """Keep the pose across a restart, as a flight computer keeps it in non-volatile memory (atomic write)."""
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(json.dumps(asdict(pose)))
    os.replace(tmp, path)


class PoseWriter:
    """Saves poses on a thread of its own, the latest pose per file, so an agent never waits for storage.

    A write and rename take milliseconds on an SD card or an overlay file system, and an agent settles after
    every action: written inline, that delays every answer it sends (and every lockstep tick). One writer
    serves every agent of the process; ``flush`` writes what is left when the agent stops.
    """

    def __init__(self) -> None:
        self._pending: dict[Path, Pose] = {}
        self._wake = threading.Condition()
        self._writing = threading.Lock()  # a flush must not overtake a write of an older pose
        self._thread: threading.Thread | None = None

    def save(self, path: Path, pose: Pose) -> None:
        with self._wake:
            self._pending[path] = pose
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="pose-writer", daemon=True)
                self._thread.start()
            self._wake.notify()

    def flush(self) -> None:
        self._write_pending()

    def _write_pending(self) -> None:
        with self._writing:
            with self._wake:
                taken, self._pending = list(self._pending.items()), {}
            for path, pose in taken:
                try:
                    save_pose(path, pose)
                except OSError as exc:
                    log.warning("could not save the pose to %s: %s", path, exc)

    def _run(self) -> None:
        while True:
            with self._wake:
                self._wake.wait_for(lambda: self._pending)
            self._write_pending()


POSE_WRITER = PoseWriter()


def load_pose(path: Path) -> Pose | None:
    """The saved pose, or None when there is none or it cannot be read (then the lander's calibration is used)."""
    try:
        data = json.loads(path.read_text())
        return Pose(float(data["x"]), float(data["z"]), float(data["heading"]))
    except (OSError, ValueError, KeyError, TypeError):
        return None
