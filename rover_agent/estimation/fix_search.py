"""A rover at its goal by an estimate it knows to be unsure does not stop there: it looks for a fix first.

At a waypoint a rover stops once its estimate says it is there. When that estimate's own 1-sigma error is large
(``SEARCH_STD_SHARE`` of the perception radius, within which a waypoint counts as reached) it may stand well off
the waypoint and know it. Before it reports the goal done it searches, in legs, for something that fixes its
estimate, with only what a real rover has (report 9.1): its own estimate and noise model, the estimates its
teammates tell by radio (``radio.PoseEstimate``) and the mission plan's lander at the origin of its frame.

- a teammate surer of its place (``SURER``) whose estimate was heard lately: walk to where it says it stands. Seen
  from there, the estimator fuses its estimate (``Estimator.localise``), and the rover is about as sure as it;
- else the lander, when it is near (``LANDER_NEAR_RADII``): seen, it fixes the estimate outright;
- else back to the last place its estimate was sure (``Estimator`` keeps it) when that is at most
  ``BACK_LEG_RADII`` perception radii away: where it last had a fix, a teammate or the lander is likely in view
  again. One farther back is not worth the walk: it comes back to its goal as unsure as it left.

Where a leg to a teammate or the lander ends with the estimate still unsure, the rover turns round once before the
next leg: it stands where its estimate puts what it walked to, so that is within its error of it in any direction,
and a perception's field of view leaves a sector behind it unseen (the lander fix turns round the same way).

The search ends as soon as the estimate is sure enough (``DONE_STD_SHARE``), after ``MAX_LEGS`` legs or after
``MAX_SEARCH_S`` of simulated time, whichever comes first; then the rover walks back to its goal and stops there
whatever its estimate says, so a mission still ends. One search a goal. Pure logic: the agent walks the legs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from rover_agent.decisions import Goal
from rover_agent.estimation.lander_fix import LANDER_GOAL
from rover_agent.estimation.pose_filter import Localisation
from rover_agent.estimation.sightings import Teammate
from schemas import radio

SEARCH_STD_SHARE = 0.4
"""A rover at a waypoint searches for a fix when its estimate's 1-sigma error is above this share of the
perception radius: at 2.5 sigmas it may be a radius off, out of reach of the waypoint."""
DONE_STD_SHARE = 0.25
"""The search is over once the error is down to this share of the perception radius."""
SURER = 0.5
"""A teammate is worth walking to when its own error is at most this share of the rover's: fused, the rover's
error comes down to about the teammate's."""
TEAMMATE_MAX_AGE_S = 10.0
"""A teammate's estimate is walked to only when heard this lately (a teammate that stands still, done or on a
relay spot, keeps its estimate)."""
TEAMMATE_MAX_RADII = 6.0
"""A teammate farther than this many perception radii (by the two estimates) is not walked to."""
LANDER_NEAR_RADII = 4.0
"""The lander is walked to when its estimated place is within this many perception radii."""
BACK_LEG_RADII = 3.0
"""How far back to its last sure place the rover walks, in perception radii, at most."""
MAX_LEGS = 2
MAX_SEARCH_S = 150.0
"""The search's bound in simulated time: half the world's watchdog's stall time (300 s), so a searching rover is
never counted stuck, and a mission still ends."""


@dataclass
class FixSearch:
    searched: set[int] = field(default_factory=set)
    """Goal indexes searched at already: one search a goal."""
    leg: Goal | None = None
    """Where the rover walks now, while it searches."""
    why: str = ""
    """What the leg is, for the rover's status."""
    began: float = 0.0
    legs: int = 0
    std_at_start: float = 0.0
    look_due: bool = False
    """The leg walks to something to see (a teammate, the lander): turn round at its end before the next leg."""

    @property
    def active(self) -> bool:
        return self.leg is not None

    @property
    def goal(self) -> Goal | None:
        return self.leg

    @property
    def detail(self) -> str:
        return f"unsure of its position at the goal ({self.std_at_start:.0f} m, 1 sigma): {self.why}"

    def wanted(self, goal: Goal, loc: Localisation | None, radius: float) -> bool:
        """Whether a rover done at ``goal`` by its estimate searches for a fix first."""
        return (goal.kind == "waypoint" and goal.index not in self.searched and loc is not None
                and loc.position_std > SEARCH_STD_SHARE * radius)

    def begin(self, goal: Goal, loc: Localisation, now: float, teammates: dict[int, Teammate],
              sure_at: tuple[float, float] | None, radius: float) -> bool:
        """Start a search at ``goal``; False: nothing to search with (the rover stops as it was)."""
        self.searched.add(goal.index)
        self.began, self.legs, self.std_at_start = now, 0, loc.position_std
        return self.next_leg(goal, loc, now, teammates, sure_at, radius)

    def next_leg(self, goal: Goal, loc: Localisation, now: float, teammates: dict[int, Teammate],
                 sure_at: tuple[float, float] | None, radius: float) -> bool:
        """The next leg (sets ``leg``); False: the search is over."""
        self.leg, self.look_due = None, False
        if self.legs >= MAX_LEGS or now - self.began >= MAX_SEARCH_S or self.sure(loc, radius):
            return False
        here, std = (loc.pose.x, loc.pose.z), loc.position_std
        mate = surest_teammate(teammates, here, std, now, radius)
        if mate is not None:
            ((x, z), self.why), self.look_due = mate, True
        elif math.hypot(*here) <= LANDER_NEAR_RADII * radius:
            (x, z), self.why = (LANDER_GOAL.x, LANDER_GOAL.z), "going to the lander to fix it"
            self.look_due = True
        elif sure_at is not None and radius < math.dist(here, sure_at) <= BACK_LEG_RADII * radius:
            (x, z), self.why = sure_at, "walking back to where it was last sure"
        else:
            return False
        self.leg, self.legs = Goal(goal.index, goal.total, "waypoint", x, z), self.legs + 1
        return True

    def look_round(self) -> bool:
        """At a leg's end, still unsure: whether to turn round first (once a leg), rather than take the next."""
        due, self.look_due = self.look_due, False
        return due

    def sure(self, loc: Localisation, radius: float) -> bool:
        return loc.position_std <= DONE_STD_SHARE * radius

    def over(self, loc: Localisation | None, now: float, radius: float) -> bool:
        """Searching, and sure again or out of time: back to the goal."""
        return self.active and (loc is None or self.sure(loc, radius) or now - self.began >= MAX_SEARCH_S)

    def end(self) -> None:
        self.leg, self.look_due = None, False


def surest_teammate(teammates: dict[int, Teammate], here: tuple[float, float], std: float, now: float,
                    radius: float) -> tuple[tuple[float, float], str] | None:
    """A leg to the surest teammate worth walking to (``SURER``, ``TEAMMATE_MAX_AGE_S``, ``TEAMMATE_MAX_RADII``)."""
    best: tuple[float, int, radio.PoseEstimate] | None = None
    for rid, mate in teammates.items():
        e = mate.estimate
        mate_std = math.sqrt(max(0.0, e.cov_xx + e.cov_zz))
        far = math.dist(here, (e.x, e.z))
        if (e.moving or now - e.stamp > TEAMMATE_MAX_AGE_S or mate_std > SURER * std
                or far > TEAMMATE_MAX_RADII * radius):
            continue
        if best is None or mate_std < best[0]:
            best = (mate_std, rid, e)
    if best is None:
        return None
    _, rid, e = best
    return (e.x, e.z), f"walking to rover {rid}, which is surer of its place"

