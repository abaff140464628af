"""The ground's hold on the simulation clock: pause, resume, and step one tick at a time (the web view's
controls and ``lunarsim command pause|resume|step``). The world service asks ``held()`` before every tick."""

from __future__ import annotations

import logging

from schemas import messages as m

log = logging.getLogger("lunarsim.world")


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
