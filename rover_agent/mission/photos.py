"""Photos on their way to the lander: each kept until the lander acknowledges it, and sent again until then (store
and forward: a rover out of the lander's reach still takes its photos)."""

from __future__ import annotations

import math

from schemas import radio

PHOTO_RETRY_S = 5.0
"""Photos not yet acknowledged by the lander are sent again this often."""


class PhotoOutbox:
    def __init__(self) -> None:
        self.reports: dict[str, radio.PhotoReport] = {}
        self.sent_at = -math.inf

    @property
    def pending(self) -> int:
        return len(self.reports)

    def add(self, label: str, report: radio.PhotoReport) -> None:
        self.reports[label] = report

    def ack(self, labels: list[str]) -> bool:
        """Drop what the lander has; whether anything was dropped."""
        pending = len(self.reports)
        for label in labels:
            self.reports.pop(label, None)
        return len(self.reports) != pending

    def due(self, now: float) -> bool:
        return bool(self.reports) and now - self.sent_at >= PHOTO_RETRY_S

    def send(self, now: float) -> list[radio.PhotoReport]:
        """Every photo the lander has not acknowledged yet."""
        self.sent_at = now
        return list(self.reports.values())

    def timers(self) -> list[float]:
        return [self.sent_at + PHOTO_RETRY_S] if self.reports else []
