"""Samples a process refused: counted by topic and logged sparingly, the one mechanism every process uses.

A refusal is never an exception that ends a loop and never silent: it is a count that reaches the process's status,
``report.json`` and the recording. A flood must not flood the log too, so each topic is logged for its first
``LOGGED`` refusals and then once every ``LOG_EVERY``.
"""

from __future__ import annotations

import logging
from collections import Counter

from schemas.wire_limits import saturate

LOGGED = 20
LOG_EVERY = 1000


class Rejections:
    def __init__(self, log: logging.Logger, who: str = "") -> None:
        self.log = log
        self.who = f"{who}: " if who else ""
        self.by_topic: Counter[str] = Counter()
        """Counted per topic, not per key: forged rover ids must not grow the table without end."""

    def count(self, topic: str, why: object, key: str = "") -> None:
        self.by_topic[topic] += 1
        n = self.by_topic[topic]
        if n <= LOGGED or n % LOG_EVERY == 0:
            self.log.warning("%srejected sample on %s: %s (%d on %s so far)", self.who, key or topic, why, n, topic)

    @property
    def total(self) -> int:
        return sum(self.by_topic.values())

    @property
    def reported(self) -> int:
        """The total as a status may carry it (``schemas.wire_limits.Count``)."""
        return saturate(self.total)
