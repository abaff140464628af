"""How a rover agent resumes after a restart: the state it saves with every action (``saved_state``), and what it
does with it on the first clock of a run.

A mixin of ``RoverAgent`` (its state: ``run``, ``saved``, ``pose``, ``in_flight``, ``ids``...), kept apart so the
agent's own module stays about its inputs and decisions.
"""

from __future__ import annotations

import logging

from bus.world_watch import JOINED_LATE_S
from rover_agent.in_flight import ActionIds, InFlight
from rover_agent.saved_state import STATE_WRITER, SavedState
from schemas import messages as m

log = logging.getLogger("lunarsim.rover")



class Resuming:
    def _join(self, clock: m.Clock) -> None:
        """The first clock of a run: resume the saved state if it is this run's; a restart without one is lost, and
        so is an agent under which the world began a new run (a world restarted without its saved state: it put
        every rover back at its start, and what the agent knew of its place belongs to the run that ended)."""
        earlier, self.run = self.run, clock.run
        first = earlier is None
        self.contact.heard_at = clock.sim_time  # silence is counted from the first clock of a run
        saved, self.saved = self.saved, None
        if saved is not None and saved.run == clock.run:
            self._resume_estimate(saved.pose, saved.cov)
            self.ids = ActionIds(saved.next_action)
            if saved.flight is not None:
                self.in_flight = InFlight.resumed(saved.flight, self.now)
            log.info("rover %d: resumed at %s from %s", self.id, self.pose, self.state_file)
        elif first and clock.sim_time > JOINED_LATE_S:
            self._lose("restarted without a saved pose of this run")
            log.error("rover %d: joined a mission %.0f s under way with no saved pose of this run (%s): it does not "
                      "know where it is, so it will not drive; start it with the --state it ran with", self.id,
                      clock.sim_time, self.state_file or "no --state")
        elif not first and self.pose is not None:
            self._lose("the world began a new run under it")
            log.error("rover %d: the world began a new run (%s) while this agent ran in %s: it does not know where it "
                      "is, so it will not drive; restart the world with the state it saved to resume", self.id,
                      clock.run, earlier)
        elif saved is not None:
            log.info("rover %d: the saved state in %s is from another run; starting afresh", self.id, self.state_file)

    def _lose(self, why: str) -> None:
        self.lost, self.lost_why = True, why
        self.in_flight = None

    def _save(self) -> None:
        """Pose, action in flight and next id, written in the background: what a restart resumes from."""
        if self.state_file is None or self.pose is None or not self.run:
            return
        flight = self.in_flight.saved() if self.in_flight is not None else None
        STATE_WRITER.save(self.state_file, SavedState(self.run, self.pose, flight, self.ids.next_id,
                                                      self.localisation.cov))
