"""How a rover agent resumes after a restart: the state it saves with every action (``saved_state``), and what it
makes of it on the first clock of a run."""

from __future__ import annotations

import logging
from pathlib import Path

from bus.world_watch import JOINED_LATE_S
from rover_agent.restarts.saved_state import STATE_WRITER, SavedFlight, SavedState, load_state
from schemas import messages as m
from shared.pose import Pose

log = logging.getLogger("lunarsim.rover")


class Restarts:
    def __init__(self, rover_id: int, state_file: Path | None) -> None:
        self.rover_id = rover_id
        self.state_file = state_file
        self.saved: SavedState | None = load_state(state_file) if state_file else None
        self.run: str | None = None
        """The world's run (``Clock.run``; "" from a clock that names none), once heard."""
        self.lost = False
        """Restarted mid-mission with no saved state of this run: it does not know where it is."""
        self.lost_why = ""

    def join(self, clock: m.Clock, placed: bool) -> SavedState | None:
        """The first clock of a run: the saved state to resume, if it is this run's. A restart without one is lost,
        and so is an agent under which the world began a new run (a world restarted without its saved state: it put
        every rover back at its start, and what the agent knew of its place belongs to the run that ended).
        ``placed``: the agent knew where it stood."""
        earlier, self.run = self.run, clock.run
        first = earlier is None
        saved, self.saved = self.saved, None
        if saved is not None and saved.run == clock.run:
            log.info("rover %d: resumed at %s from %s", self.rover_id, saved.pose, self.state_file)
            return saved
        if first and clock.sim_time > JOINED_LATE_S:
            self._lose("restarted without a saved pose of this run")
            log.error("rover %d: joined a mission %.0f s under way with no saved pose of this run (%s): it does not "
                      "know where it is, so it will not drive; start it with the --state it ran with", self.rover_id,
                      clock.sim_time, self.state_file or "no --state")
        elif not first and placed:
            self._lose("the world began a new run under it")
            log.error("rover %d: the world began a new run (%s) while this agent ran in %s: it does not know where it "
                      "is, so it will not drive; restart the world with the state it saved to resume", self.rover_id,
                      clock.run, earlier)
        elif saved is not None:
            log.info("rover %d: the saved state in %s is from another run; starting afresh", self.rover_id,
                     self.state_file)
        return None

    def _lose(self, why: str) -> None:
        self.lost, self.lost_why = True, why

    def save(self, pose: Pose | None, cov: list[list[float]] | None, flight: SavedFlight | None,
             next_action: int) -> None:
        """Pose, action in flight and next id, written in the background: what a restart resumes from."""
        if self.state_file is None or pose is None or not self.run:
            return
        STATE_WRITER.save(self.state_file, SavedState(self.run, pose, flight, next_action, cov))
