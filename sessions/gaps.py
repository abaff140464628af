"""Gaps in a recording: spans the recorder knows it missed because it had lost its router.

A recorder cut off from its router hears nothing, so nothing reaches its queue and nothing counts as dropped: the
loss has to be noticed apart. The recorder tells ``GapTracker`` when its session loses and regains its last router
or peer, and shows it every world clock it hears (recorded or filtered out). Each outage becomes a gap bounded by the
last clock heard before it and the first heard after it, so it is said in simulated seconds and world ticks as well
as in wall seconds. The gaps go into the recording's metadata (``lunarsim.gaps``), where ``lunarsim report`` and
``lunarsim replay`` read them back as the untrusted text any file holds.

Pure: no Zenoh, no clock of its own; the caller passes receive times (Unix ns).
"""

from __future__ import annotations

import json
import math
import threading
from dataclasses import dataclass

from schemas.wire_limits import COUNT_LIMIT, SECONDS_LIMIT

MAX_GAPS_KEPT = 100
"""Gaps written out one by one; more are still counted and summed (a flapping link must not grow the metadata)."""


@dataclass(frozen=True)
class ClockMark:
    """One world clock as the recorder heard it."""

    log_ns: int
    tick: int
    sim_time: float
    run: str


@dataclass
class Gap:
    """One outage: from when the router was lost to when it was back (None: not back when the recording ended)."""

    lost_ns: int
    back_ns: int | None = None
    ended_ns: int | None = None
    before: ClockMark | None = None
    after: ClockMark | None = None

    @property
    def end_ns(self) -> int | None:
        return self.back_ns if self.back_ns is not None else self.ended_ns

    @property
    def wall_s(self) -> float:
        end = self.end_ns
        return max(0, (end if end is not None else self.lost_ns) - self.lost_ns) / 1e9

    @property
    def sim_s(self) -> float | None:
        """Simulated seconds between the clocks heard on either side; None if either is missing or the world
        restarted in between (a new run starts its time again)."""
        before, after = self.before, self.after
        if before is None or after is None or before.run != after.run or after.sim_time < before.sim_time:
            return None
        return after.sim_time - before.sim_time

    def as_dict(self) -> dict[str, object]:
        out: dict[str, object] = {"lost_ns": self.lost_ns, "back_ns": self.back_ns, "wall_s": round(self.wall_s, 3),
                                  "sim_s": None if self.sim_s is None else round(self.sim_s, 3)}
        if self.before is not None:
            out |= {"sim_from": self.before.sim_time, "tick_from": self.before.tick}
        if self.after is not None:
            out |= {"sim_to": self.after.sim_time, "tick_to": self.after.tick}
        return out


class GapTracker:
    """Router outages and the clocks around them. Thread-safe: the connection is polled on one thread and clocks
    arrive on the recorder's writer thread."""

    def __init__(self) -> None:
        self.gaps: list[Gap] = []
        self.count = 0
        self.connected: bool | None = None
        self._open: list[Gap] = []  # gaps still waiting for their clock after
        self._last: ClockMark | None = None
        self._lock = threading.Lock()

    def connection(self, connected: bool, now_ns: int) -> Gap | None:
        """The session's state now; returns the gap it opens or closes, if it changed. Only a loss after a connection
        counts: a recorder waiting for its first router has recorded nothing yet to be missing from."""
        with self._lock:
            previous, self.connected = self.connected, connected
            if previous is True and not connected:
                gap = Gap(lost_ns=now_ns, before=self._last)
                self.count += 1
                self._open.append(gap)
                if len(self.gaps) < MAX_GAPS_KEPT:
                    self.gaps.append(gap)
                return gap
            if previous is False and connected and self._open and self._open[-1].back_ns is None:
                gap = self._open[-1]
                gap.back_ns = now_ns
                if gap.after is not None:
                    self._open.remove(gap)
                return gap
            return None

    def clock(self, mark: ClockMark) -> None:
        """A clock the recorder heard. Clocks come in receive order, but may be handled after a loss already seen:
        each is placed by its receive time, not by when it is handled. One received after the loss was seen came
        through a connection that is back, though the next poll may not have seen it yet: it is the gap's first
        clock after, whichever of the two is noticed first."""
        with self._lock:
            self._last = mark
            for gap in list(self._open):
                if mark.log_ns < gap.lost_ns:
                    gap.before = mark
                elif gap.after is None:
                    gap.after = mark
                if gap.after is not None and gap.back_ns is not None:
                    self._open.remove(gap)

    def close(self, now_ns: int) -> None:
        """The recording ends: a gap still open ends here."""
        with self._lock:
            for gap in self._open:
                if gap.back_ns is None:
                    gap.ended_ns = now_ns
            self._open.clear()

    def metadata(self, since_ns: int | None = None) -> dict[str, str]:
        """The ``lunarsim.gaps`` record: how many, their wall and simulated seconds summed, then each gap (the first
        ``MAX_GAPS_KEPT``). With ``since_ns`` (a snapshot's window), only the gaps that end after it, or have not."""
        with self._lock:
            gaps = [g for g in self.gaps if since_ns is None or g.end_ns is None or g.end_ns >= since_ns]
            count = self.count if since_ns is None else len(gaps)
            known = [g.sim_s for g in gaps if g.sim_s is not None]
            return {"count": str(count), "router_lost_s": f"{sum(g.wall_s for g in gaps):.3f}",
                    "sim_s_missed": f"{sum(known):.3f}" if known else "",
                    "gaps": json.dumps([g.as_dict() for g in gaps])}

    def summary(self) -> str:
        """For the recorder's last line: ``no gaps`` or how many and how long."""
        return describe(self.metadata()) or "no gaps"


def describe(record: dict[str, str] | None) -> str | None:
    """One line on a ``lunarsim.gaps`` record read from a file; None when it says there was no gap. The record is
    untrusted: a field out of bounds is said to be unreadable, never raised."""
    if not record:
        return None
    count = _number(record.get("count"), int, COUNT_LIMIT)
    if count == 0:
        return None
    wall = _number(record.get("router_lost_s"), float, SECONDS_LIMIT)
    sim = _number(record.get("sim_s_missed"), float, SECONDS_LIMIT)
    if count is None or wall is None:
        return "a gap record that cannot be read (lunarsim.gaps): it may have gaps"
    plural = "gap" if count == 1 else "gaps"
    missed = (f"{sim:.1f} simulated s not recorded" if sim is not None
              else "simulated time missed unknown (no world clock heard on both sides)")
    return f"{count} {plural}: the recorder lost its router for {wall:.1f} s; {missed}"


def _number(text: str | None, kind: type[int] | type[float], limit: float) -> int | float | None:
    if not text or len(text) > 32:
        return None
    try:
        value = kind(text)
    except ValueError:
        return None
    return value if math.isfinite(value) and 0 <= value <= limit else None
