"""The lander's archive of crater photos: what reached it over the radio, on disk for the mission's owners.

A photo's label comes from a rover, and a rover may be buggy or taken over, so the label is data: it goes into
``index.jsonl`` (escaped as JSON) and never into a file name. Files are named by the lander: the sender's id and a
count of that rover's photos. Each rover may fill at most ``MAX_PHOTOS_PER_ROVER`` files, so no sender fills the disk.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

from schemas import radio

log = logging.getLogger("lunarsim.lander")

MAX_PHOTOS_PER_ROVER = 10_000
"""Far more than a mission's crater goals ask for (12 photos a crater at the report's 30 degrees a photo)."""
INDEX_FILE = "index.jsonl"


class PhotoArchive:
    """PNG files per rover (``rover<id>/<n>.png``) plus ``index.jsonl``, one line per photo with its label."""

    def __init__(self, folder: Path | None) -> None:
        self.folder = folder
        self.received: set[tuple[int, str]] = set()
        self.per_rover: dict[int, int] = {}
        self.refused = 0  # photos over a rover's share, not archived

    def store(self, rover_id: int, report: radio.PhotoReport) -> bool:
        """Archive a photo; False when it is refused (over the rover's share). A resend whose ack was lost is
        already in: True, and nothing written twice."""
        if (rover_id, report.label) in self.received:
            return True
        n = self.per_rover.get(rover_id, 0)
        if n >= MAX_PHOTOS_PER_ROVER:
            self.refused += 1
            return False
        self.received.add((rover_id, report.label))
        self.per_rover[rover_id] = n + 1
        if self.folder is not None:
            self._write(rover_id, n + 1, report)
        return True

    def _write(self, rover_id: int, n: int, report: radio.PhotoReport) -> None:
        path = self.folder / f"rover{rover_id}" / f"{n:05d}.png"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(report.png)
        entry = {"rover": rover_id, "goal_index": report.goal_index, "label": report.label,
                 "stamp": report.stamp, "file": path.relative_to(self.folder).as_posix()}
        with open(self.folder / INDEX_FILE, "a", encoding="utf-8") as index:
            index.write(json.dumps(entry) + "\n")
