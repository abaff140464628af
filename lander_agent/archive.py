"""The lander's archive of crater photos: what reached it over the radio, on disk for the mission's owners.

A photo's label comes from a rover, and a rover may be buggy or taken over, so the label is data: it goes into
``index.jsonl`` (escaped as JSON) and never into a file name. Files are named by the lander: the sender's id and a
count of that rover's photos. Each rover may fill at most ``MAX_PHOTOS_PER_ROVER`` files of ``MAX_BYTES_PER_ROVER``
in all, so no sender fills the disk.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

from schemas import radio

log = logging.getLogger("lunarsim.lander")

MAX_PHOTOS_PER_ROVER = 10_000
"""Far more than a mission's crater goals ask for (12 photos a crater at the report's 30 degrees a photo)."""
MAX_BYTES_PER_ROVER = 1 << 30
"""A GiB a rover: thousands of photos of the default camera, a hundred or more of the largest (a photo may be 48 MiB
on the wire). Counted from the files in the rover's folder, so a restarted lander counts what it kept before."""
INDEX_FILE = "index.jsonl"


class PhotoArchive:
    """PNG files per rover (``rover<id>/<n>.png``) plus ``index.jsonl``, one line per photo with its label."""

    def __init__(self, folder: Path | None) -> None:
        self.folder = folder
        self.received: set[tuple[int, str]] = set()
        self.per_rover: dict[int, int] = {}
        self.bytes: dict[int, int] = {}  # rover -> bytes of its files (from the folder at its first photo)
        self.refused = 0  # photos over a rover's share, not archived

    def store(self, rover_id: int, report: radio.PhotoReport) -> bool:
        """Archive a photo; False when it is refused (over the rover's share). A resend whose ack was lost is
        already in: True, and nothing written twice."""
        if (rover_id, report.label) in self.received:
            return True
        if rover_id not in self.bytes:  # its first photo here: what its folder holds already counts
            files, self.bytes[rover_id] = self._on_disk(rover_id)
            self.per_rover[rover_id] = max(self.per_rover.get(rover_id, 0), files)
        n, used = self.per_rover[rover_id], self.bytes[rover_id]
        if n >= MAX_PHOTOS_PER_ROVER or used + len(report.png) > MAX_BYTES_PER_ROVER:
            self.refused += 1
            return False
        self.received.add((rover_id, report.label))
        self.per_rover[rover_id] = n + 1
        self.bytes[rover_id] = used + len(report.png)
        if self.folder is not None:
            self._write(rover_id, n + 1, report)
        return True

    def _on_disk(self, rover_id: int) -> tuple[int, int]:
        """Files and bytes in the rover's folder: a lander started again on it numbers on from them."""
        if self.folder is None:
            return 0, 0
        sizes = [path.stat().st_size for path in self._folder_of(rover_id).glob("*.png")]
        return len(sizes), sum(sizes)

    def _folder_of(self, rover_id: int) -> Path:
        return self.folder / f"rover{rover_id}"

    def _write(self, rover_id: int, n: int, report: radio.PhotoReport) -> None:
        path = self._folder_of(rover_id) / f"{n:05d}.png"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(report.png)
        entry = {"rover": rover_id, "goal_index": report.goal_index, "label": report.label,
                 "stamp": report.stamp, "file": path.relative_to(self.folder).as_posix()}
        with open(self.folder / INDEX_FILE, "a", encoding="utf-8") as index:
            index.write(json.dumps(entry) + "\n")
