"""The lander's saved state: its mission plan, traverse map and photo archive's index, for a restart to resume.

Without it a lander killed mid-mission begins again: every rover back on its first goal in the plan, and the map
forgets all that was mapped (a restarted lander's corridor fell from 98% to 44% known). So the lander saves them
(``bus.snapshot``) every ``SAVE_PERIOD_S`` simulated seconds, naming the world's run, and one started again with
the same ``--state`` resumes them on the first clock of that run. One that joins a run under way without them says
so in its log and status (``LanderStatus.map_lost``), and the report carries it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from pathlib import Path

from bus import snapshot
from bus.world_watch import JOINED_LATE_S
from lander_agent.archive import PhotoArchive
from lander_agent.mapping import TraverseMap
from lander_agent.mission import MissionPlan
from schemas import messages as m

log = logging.getLogger("lunarsim.lander")

SAVE_PERIOD_S = 1.0
FILE_NAME = "lander.state"


@dataclass
class Saved:
    run: str
    plan: MissionPlan
    map: TraverseMap
    received: set[tuple[int, str]] = field(default_factory=set)
    per_rover: dict[int, int] = field(default_factory=dict)


class LanderMemory:
    """Owns the state file: what was loaded at start, and when to save next."""

    def __init__(self, path: Path | None) -> None:
        self.path = path
        loaded = snapshot.load(path, log) if path is not None else None
        self.saved = loaded if isinstance(loaded, Saved) else None
        self.next_save = 0.0

    def join(self, clock: m.Clock, plan: MissionPlan, archive: PhotoArchive,
             first: bool) -> tuple[MissionPlan, TraverseMap | None, bool]:
        """On the first clock of a run: (the plan, the map if resumed, whether this run's map was lost)."""
        saved, self.saved = self.saved, None
        if saved is not None and saved.run == clock.run and saved.plan.scenario == plan.scenario:
            archive.received, archive.per_rover = saved.received, saved.per_rover
            log.warning("lander: resumed its plan and map of run %s from %s", clock.run, self.path)
            return saved.plan, saved.map, False
        if first and clock.sim_time > JOINED_LATE_S:
            log.error("lander: joined run %s %.0f s under way with no saved state of it (%s): its plan and map begin "
                      "again; start it with the --state it ran with", clock.run, clock.sim_time,
                      self.path or "no --state")
            return plan, None, True
        return plan, None, False

    def keep(self, run: str, now: float, plan: MissionPlan, traverse: TraverseMap, archive: PhotoArchive) -> None:
        if self.path is None or now < self.next_save or not run:
            return
        self.next_save = now + SAVE_PERIOD_S
        snapshot.save(Saved(run, plan, traverse, archive.received, archive.per_rover), self.path)
