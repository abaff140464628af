"""Saying plainly when an agent waits for the world service: before its first clock sample, and when the
clock stops (the world or the router went away). An agent started before the world is then not mistaken
for a hung one, and one cut off says so. Kept light: the rover agent uses it."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable

WAIT_NOTICE_S = 3.0
"""Silence before the first notice: the world normally answers within a clock period."""
JOINED_LATE_S = 2.0
"""A process whose first clock of a run is later than this joined the run under way: a restart."""
LOST_AFTER_S = 5.0
"""The world publishes its clock at least twice a second, running or not: this long without it is an outage."""


class ClockWatch:
    def __init__(self, who: str, clock_key: str, now: Callable[[], float] = time.monotonic) -> None:
        self.who, self.clock_key, self.now = who, clock_key, now
        self.started = now()
        self.last_heard: float | None = None
        self.noticed = False  # a "waiting" or "lost" line is out and not yet answered by a "found" line

    def heard(self) -> None:
        if self.noticed:
            self._say(f"world service found (clock on {self.clock_key})")
            self.noticed = False
        self.last_heard = self.now()

    def check(self) -> None:
        if self.noticed:
            return
        now = self.now()
        if self.last_heard is None and now - self.started >= WAIT_NOTICE_S:
            self._say(f"waiting for the world service (no clock on {self.clock_key} yet)")
            self.noticed = True
        elif self.last_heard is not None and now - self.last_heard >= LOST_AFTER_S:
            self._say(f"lost the world service: no clock on {self.clock_key} for {now - self.last_heard:.0f} s; "
                      "waiting for it to come back")
            self.noticed = True

    def _say(self, text: str) -> None:
        print(f"{self.who}: {text}", file=sys.stderr, flush=True)
