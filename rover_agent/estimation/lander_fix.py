"""Going by the lander to fix the pose estimate before a waypoint that drift would otherwise miss.

The lander is the one landmark whose place every rover knows exactly: it is the origin of the frame the rover
navigates in. Seen in perception from a few places, it brings the estimate's uncertainty down to about the
sighting's (``pose_filter``). When a waypoint goal comes, the rover asks its filter how unsure it
would be on arriving there by the direct way, from its own noise parameters. If that is more than ``FIX_STD_M``,
and going by the lander leaves it surer at the goal (``WORTH``) for a way at most ``MAX_DETOUR`` longer than the
direct one, it heads for the lander first; it goes on to its goal once the estimate is sure again
(``FIXED_STD_M``). Where it thought the lander was, not seeing it, it turns round to look, then searches round
that place on rings of spots reaching as far as its estimate's error says the lander may be (``search_spots``);
then, or if it can get no closer, it goes on whatever it saw.
Returns to the start, as the report's crater_and_return, usually pass near the lander, so they gain most.

The report's remedy for drifting estimates (7.2.1), with what a Lunar Zebro has: its noise model and the mission
plan's lander. Crater goals need no such fix: the rim is found by pitch, wherever the estimate puts it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rover_agent.decisions import Goal
from rover_agent.estimation.pose_filter import Localisation
from schemas.params import RoverParams
from shared.pose import Pose

LANDER_GOAL = Goal(index=0, total=1, kind="waypoint", x=0.0, z=0.0)
"""The lander as a goal: at the origin of the lander frame every rover navigates in."""

FIX_STD_M = 1.5
"""A waypoint the estimate would reach more unsure than this (1 sigma, metres) is worth a fix first: at a waypoint
the team shares, the rover's own station is up to 8.5 m from it (20 rovers), which leaves little of the perception
radius, within which the rover is at the waypoint, for drift."""
FIXED_STD_M = 1.0
"""The estimate is fixed once its 1-sigma position error is down to this."""
FIXED_HEADING_STD_DEG = 2.0
"""What a fix leaves of the heading's error (1 sigma), to judge the way on from the lander: a 1.5 m lander seen
within 10 m from a few places gives its bearing to a degree or two."""
WORTH = 0.75
"""Going by the lander must leave the estimate at the goal at most this share as unsure as the direct way."""
MAX_DETOUR = 1.0
"""The way by the lander may be at most this share longer than the direct way to the goal."""
DETAIL = "going by the lander to fix its position estimate"
UNSURE_SHARE = 0.5
"""A rover done at its goal says how unsure its estimate is once its 1-sigma position error is above this share of
the perception radius: a waypoint counts as reached within that radius, so at two sigmas it may have missed it."""


RING_SPACING = 1.5
"""The search's rings, and the spots along each, are this many perception radii apart: walking from spot to spot
the rover's wide view (210 degrees in the report) sweeps a band a perception radius deep on either side of its
way, so neighbouring rings' bands overlap, with room for the drift of the walk."""
SEARCH_SIGMAS = 3.0
"""The search reaches out until its views cover this many 1-sigma position errors (``Localisation.position_std``)
round the lander's estimated place. Two would do 98 times in 100 for an error alike in every direction, on paper;
on the development seeds a rover stood 2.7 of its own errors off, an estimate fused with teammates' being rougher
than the filter's ideal."""
SHARPENED = 0.5
"""A search is begun again from the lander's estimated place once the estimate's error is down to this share of
what the search was planned for: each new start needs the error halved, so a search cannot start for ever."""
MAX_RINGS = 2
"""A search ends after this many rings (its views 34 m out with the report's 10 m perception radius, some 240 m
of walking). A third ring would more than double the walk, and keep the rover from its goal for longer than the
world's watchdog waits for progress before counting it stuck (``WatchdogParams.stall_after_s``, 300 s)."""


@dataclass
class LanderFix:
    decided: int | None = None  # the goal index the decision was taken for (once a goal)
    active: bool = False
    looked: bool = False  # turned round at the lander's estimated place
    spots: list[tuple[float, float]] | None = None  # the search's spots still to go to, once searching
    planned_std: float = 0.0  # the position error the search was planned for

    @property
    def goal(self) -> Goal | None:
        """What the rover walks to while it goes by the lander (None: its own goal)."""
        if not self.active:
            return None
        if not self.spots:
            return LANDER_GOAL
        x, z = self.spots[0]
        return Goal(LANDER_GOAL.index, LANDER_GOAL.total, "waypoint", x, z)

    def arrived(self, outcome: str, here: tuple[float, float], radius: float, position_std: float = 0.0) -> str:
        """What the rover does where a leg of the way by the lander ends without a fix: "look" (turn round at the
        lander's estimated place), "search" (on to the next spot round it; past a spot it could not reach) or
        "over" (on to its own goal; also when it could get no closer to the lander's estimated place)."""
        if self.spots is None and outcome != "reached":
            return "over"
        if not self.looked:
            self.looked = True
            return "look"
        if self.spots is None:
            self.spots, self.planned_std = search_spots(radius, position_std, here), position_std
            return "search"
        self.spots.pop(0)
        return "search" if self.spots else "over"

    def consider(self, goal: Goal, loc: Localisation, params: RoverParams) -> bool:
        """At a goal's first decision: whether to go by the lander first (sets ``active``)."""
        if self.decided == goal.index:
            return False
        self.decided = goal.index
        if goal.kind != "waypoint" or loc.exact:
            return False
        step = 0.9 * params.perception.perception_radius
        target, here = goal.target, (loc.pose.x, loc.pose.z)
        direct = loc.predicted_std(target, step)
        if direct <= FIX_STD_M or not math.isfinite(direct):  # a way past reckoning: no fix makes it any surer
            return False
        heading_std = math.radians(FIXED_HEADING_STD_DEG)
        fixed = Localisation(Pose(0.0, 0.0, loc.pose.heading), loc.noise,
                             [[FIXED_STD_M ** 2 / 2, 0.0, 0.0], [0.0, FIXED_STD_M ** 2 / 2, 0.0],
                              [0.0, 0.0, heading_std ** 2]])
        via = fixed.predicted_std(target, step)
        straight = math.dist(here, target)
        detour = math.hypot(*here) + math.hypot(*target) - straight
        self.active = via <= WORTH * direct and detour <= MAX_DETOUR * straight
        self.looked, self.spots = False, None
        return self.active

    def sharpened(self, loc: Localisation) -> bool:
        """Searching, the estimate has become much surer than the search was planned for (a teammate seen on the
        way, say), so where the lander should be has moved with it: go and look there again (sets the goal)."""
        if not self.active or self.spots is None or loc.position_std > SHARPENED * self.planned_std:
            return False
        self.looked, self.spots = False, None
        return True

    def fixed(self, loc: Localisation) -> bool:
        """Sure again: the detour is over."""
        return self.active and loc.position_std <= FIXED_STD_M


def search_spots(radius: float, position_std: float, here: tuple[float, float]) -> list[tuple[float, float]]:
    """Spots round the lander's estimated place (the origin) to look for it from: rings ``RING_SPACING``
    perception radii apart, the first a perception radius out, each walked all the way round from the spot
    nearest the rover, its spots no farther apart than the rings are; as many rings as it takes for the views
    to reach ``SEARCH_SIGMAS`` position errors out, at most ``MAX_RINGS``."""
    step = RING_SPACING * radius
    spots: list[tuple[float, float]] = []
    for k in range(MAX_RINGS):
        ring = radius + k * step
        count = max(4, math.ceil(math.pi / math.asin(min(1.0, step / (2.0 * ring)))))
        round_ = [(ring * math.sin(2.0 * math.pi * i / count), ring * math.cos(2.0 * math.pi * i / count))
                  for i in range(count)]
        start = min(range(count), key=lambda i: math.dist(round_[i], spots[-1] if spots else here))
        spots += [*round_[start:], *round_[:start], round_[start]]
        seen_to = ring * math.cos(math.pi / count) + radius  # the nearest its walk round comes, and a view's depth
        if seen_to >= SEARCH_SIGMAS * position_std:
            break
    return spots


def unsure_detail(loc: Localisation | None, radius: float) -> str:
    """What a done rover's status says of its estimate, so the ground knows which rovers may stand off their goal:
    nothing while it is sure enough (``UNSURE_SHARE``)."""
    if loc is None or loc.position_std <= UNSURE_SHARE * radius:
        return ""
    return f"at its goal by its own estimate, which may be {loc.position_std:.0f} m off (1 sigma)"
