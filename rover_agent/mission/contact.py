"""Lost radio: what a rover does while it waits for the lander's word and none comes.

A rover waits for the lander before each goal (its mission direction), and at the start for its calibration, the
origin of its dead reckoning. Both come by radio, sent again every second while the rover can be reached, directly
or through other rovers (the daisy chain). A rover that starts in a crater, behind a ridge or beyond every radio's
range hears nothing, and would wait there for ever in silence.

After ``CONTACT_WAIT_S`` of silence it goes looking for contact instead:
- with no calibration, it takes its planned dispatch pose from its mission file (``dispatch``: where the lander
  was to set it down, the same figures the calibration carries), when its ``--params`` is the mission's scenario
  (``lunarsim run`` passes it; a flight computer given one is loaded with its mission before launch). Without
  one it cannot know where it is, and says so;
- it walks towards the lander (the origin of its frame), where the radio reaches it if anywhere, avoiding
  obstacles as towards any waypoint, and stops there. On the way it usually meets the lander's range or another
  rover's first, and the first mission direction that arrives ends the search.

Nothing here reads ground truth: the silence is the rover's own (no mission direction heard), the target its own
dead-reckoned estimate of the lander.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

from rover_agent.decisions import Goal
from rover_agent.estimation.lander_fix import LANDER_GOAL
from schemas import messages as m

log = logging.getLogger("lunarsim.rover")

CONTACT_WAIT_S = 15.0
"""Simulated seconds without a word from the lander before a waiting rover goes looking for it: many times the
lander's 1 s resend period, so a few lost samples never set it off."""


@dataclass
class ContactSearch:
    rover_id: int
    dispatch: m.Calibration | None = None
    heard_at: float = 0.0
    """When the lander's word last came (a mission direction; 0 is the clock's start)."""
    seeking: bool = False
    arrived: float | None = None
    """When the search got to the lander's estimated spot, or could get no further, with still no word: it waits
    there, and sets off again after another ``CONTACT_WAIT_S`` (a jam clears, an estimate was off)."""
    blocked: bool = False
    said_blind: bool = False

    @property
    def goal(self) -> Goal | None:
        """What the rover walks to while it searches (None: its own mission goal, if any)."""
        return LANDER_GOAL if self.seeking and self.arrived is None else None

    @property
    def detail(self) -> str:
        """For the rover's status while it searches."""
        if self.arrived is None:
            return "no word from the lander: heading for it to regain radio contact"
        if self.blocked:
            return "no word from the lander: blocked on the way to it; trying again"
        return "no word from the lander: waiting at its estimated position"

    def heard(self, now: float) -> None:
        if self.seeking:
            log.info("rover %d: the lander's word has come again; search over", self.rover_id)
        self.heard_at, self.seeking, self.arrived = now, False, None

    def arrive(self, now: float, blocked: bool = False) -> None:
        log.warning("rover %d: %s with no word from the lander; waiting there", self.rover_id,
                    "blocked on the way to the lander" if blocked else "at the lander's estimated position")
        self.arrived, self.blocked = now, blocked

    def silent(self, now: float) -> bool:
        return now - self.heard_at >= CONTACT_WAIT_S

    def assumed_pose(self, now: float) -> m.Calibration | None:
        """The planned dispatch pose, for a rover that has heard no calibration in ``CONTACT_WAIT_S``."""
        if not self.silent(now):
            return None
        if self.dispatch is None:
            if not self.said_blind:
                self.said_blind = True
                log.error("rover %d: no calibration from the lander after %.0f s and no dispatch pose in its "
                          "mission file: it does not know where it is, so it waits", self.rover_id, now)
            return None
        log.warning("rover %d: no calibration from the lander after %.0f s; starting from the planned dispatch "
                    "pose (%.1f, %.1f) of its mission file", self.rover_id, now, self.dispatch.x, self.dispatch.z)
        return self.dispatch

    def target(self, now: float, waiting: bool) -> Goal | None:
        """The lander as a goal while a rover that waits for its word has heard nothing for ``CONTACT_WAIT_S``."""
        if not (waiting and self.silent(now)):
            return None
        if self.arrived is not None:
            if now - self.arrived < CONTACT_WAIT_S:
                return None
            self.arrived = None  # set off again
        if not self.seeking:
            self.seeking = True
            log.warning("rover %d: no word from the lander for %.0f s; heading for it to regain radio contact",
                        self.rover_id, now - self.heard_at)
        return LANDER_GOAL
