"""The world's simulated time: the tick count and its length, how the clock is announced, and the ground's hold on
it (pause, resume, and step one tick at a time: the web view's controls and ``lunarsim command pause|resume|step``).

Both the simulated world and the hardware twin keep one ``Clock``; the world service advances it and asks
``hold.held()`` before every tick.
"""

from __future__ import annotations

import logging
import uuid
from dataclasses import dataclass, field

from schemas import messages as m
from schemas.params import RoverParams

log = logging.getLogger("lunarsim.world")

CLOCK_HZ = 5.0
"""How often the clock is published in real time. Agents learn the time from every sample's stamp; the clock
drives their own timers, the shortest of which is a second, and tells them the world is there. At the tick rate
(20 Hz) it would be 40% of what every agent receives. In lockstep it goes out on every tick that waits for an ack."""


def tick_length(params: RoverParams) -> float:
    """The world's tick: the period of its fastest publication, so every rate is a whole number of ticks."""
    p = params
    return 1.0 / max(p.perception.publish_frequency, p.perception.gyroscope_frequency, p.navigation.publish_frequency)


def ticks_per_period(rate_hz: float, dt: float) -> int:
    return max(1, round(1.0 / (rate_hz * dt)))


class ClockHold:
    def __init__(self) -> None:
        self.paused = False
        self.steps_granted = 0  # ticks asked for one at a time while paused

    def command(self, command: m.GroundCommand) -> None:
        """Logged when the hold changes: a paused clock stops every rover until the ground resumes it, so the
        world's log must say who holds it (any client allowed on the ground command key may)."""
        was = self.paused
        if command.command == "pause":
            self.paused = True
        elif command.command == "resume":
            self.paused, self.steps_granted = False, 0
        elif command.command == "step":
            self.paused, self.steps_granted = True, self.steps_granted + 1
        else:
            return
        if self.paused != was:
            log.warning("clock %s by a ground command (request %r)%s", "paused" if self.paused else "resumed",
                        command.request_id, ": nothing moves until 'lunarsim command resume'" if self.paused else "")

    @property
    def waiting(self) -> bool:
        """Paused with no step to take: nothing but the ground can release it."""
        return self.paused and not self.steps_granted

    def held(self) -> bool:
        """Whether the clock must not advance now (taking one granted step if there is one)."""
        if not self.paused:
            return False
        if self.steps_granted:
            self.steps_granted -= 1
            return False
        return True


@dataclass
class Clock:
    """Simulated time, one tick of ``dt`` seconds at a time, and what the clock sample says of it.

    ``time_scale`` and ``lockstep`` are what the clock announces (the service paces the ticks); ``run_id`` names
    the run, not the seed: two runs of one seed are still two runs.
    """

    dt: float
    tick: int = 0
    time_scale: float = 1.0
    lockstep: bool = False
    run_id: str = field(default_factory=lambda: uuid.uuid4().hex[:12])
    hold: ClockHold = field(default_factory=lambda: ClockHold())

    @property
    def sim_time(self) -> float:
        return self.tick * self.dt

    def period(self, rate_hz: float) -> int:
        """Ticks between two samples of something published at ``rate_hz``."""
        return ticks_per_period(rate_hz, self.dt)

    def announced(self) -> bool:
        """Whether the clock sample of this tick goes out in real time: at ``CLOCK_HZ``, and on every tick the
        ground grants one at a time."""
        return self.tick % self.period(CLOCK_HZ) == 0 or self.hold.paused

    def message(self, running: bool = True) -> m.Clock:
        return m.Clock(tick=self.tick, sim_time=self.sim_time, time_scale=self.time_scale, running=running,
                       lockstep=self.lockstep, run=self.run_id)
