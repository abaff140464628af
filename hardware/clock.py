"""Mission time for a bridged rover: the world's clock (twin mode), or the bridge's own (``--clock``, a bench).

Rover agents compare stamps with the clock's ``sim_time`` (a perception counts only if taken after the last
action settled), so everything the bridge publishes is stamped on one time base: the last clock sample seen,
moved on by the wall time since it arrived, and never going backwards.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

from schemas import messages as m

log = logging.getLogger("lunarsim.bridge")

STALE_AFTER_S = 2.0
"""A world clock not heard from for this long is taken as stopped: the bridge then holds its sensors back."""


class MissionClock:
    def __init__(self, own: bool, monotonic: Callable[[], float] = time.monotonic) -> None:
        self.own = own
        self.monotonic = monotonic
        self.started = monotonic()
        self.tick = 0
        self._sample: m.Clock | None = None
        self._received = 0.0
        self._last = 0.0
        self._warned_lockstep = False

    def on_clock(self, clock: m.Clock) -> None:
        """A ``world/clock`` sample (ignored with ``own``: the bridge is then the clock)."""
        if self.own:
            return
        if clock.lockstep and not self._warned_lockstep:
            log.warning("the world runs in lockstep; a real rover cannot wait for ticks, so its data is stamped "
                        "with the world's time as it comes")
            self._warned_lockstep = True
        self._sample, self._received = clock, self.monotonic()

    def running(self) -> bool:
        """Whether agents are acting now: always with our own clock, else while the world's clock runs."""
        if self.own:
            return True
        return (self._sample is not None and self._sample.running
                and self.monotonic() - self._received < STALE_AFTER_S)

    def now(self) -> float:
        """Mission seconds for a stamp."""
        if self.own:
            t = self.monotonic() - self.started
        elif self._sample is None:
            t = 0.0
        else:
            s = self._sample
            scale = s.time_scale if s.running and s.time_scale > 0 else 0.0
            t = s.sim_time + (self.monotonic() - self._received) * scale
        self._last = max(self._last, t)
        return self._last

    def next_tick(self) -> m.Clock:
        """Our own clock's next sample (real time, never lockstep)."""
        self.tick += 1
        return m.Clock(tick=self.tick, sim_time=round(self.now(), 4), time_scale=1.0, running=True)
