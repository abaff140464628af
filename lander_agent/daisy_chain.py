"""The daisy chain (report 6.5.1, the optimised version): relays in a straight line from the lander.

When the lander's radio cannot reach where the rovers are going, some rovers stop on the way and hold
position, each within radio range of the one before, so every rover keeps a route to the lander
(need N3). The optimised chain uses the fewest relays the distance needs: spots evenly spaced on the
line from the lander to the goal, no farther apart than ``SPACING`` of the radio range, which leaves a
margin for dead-reckoning drift. Pure logic: the lander's plan asks for a chain per goal.

The rovers nearest the goal relay, the nearest taking the spot farthest out, and the others go on to the
goal behind them: the chain forms ahead of the rovers that pass it, so none of them outruns the last relay
(a relay held up by a rock or by traffic would otherwise leave the rovers ahead of it out of reach). Rovers
the radio can reach where they set out come first (``in_radio_reach``): a rover set down out of everyone's
range cannot be told to hold a spot until it has found the radio again, and a spot it would hold meanwhile
stands empty, while it could have walked on to the goal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

SPACING = 0.87
"""Relay spacing as a share of the radio range."""


@dataclass(frozen=True)
class Chain:
    spots: dict[int, tuple[float, float]]  # rover id -> relay spot, in the lander's frame

    @property
    def relays(self) -> list[int]:
        """Relay rovers from the lander outwards."""
        return sorted(self.spots, key=lambda rid: math.hypot(*self.spots[rid]))


def in_radio_reach(places: dict[int, tuple[float, float]], lander_range: float, comm_range: float) -> set[int]:
    """The rovers with a radio route to the lander (at the origin) from ``places``, by range alone: the lander's
    best guess of who hears it, from where it set each rover down."""
    reached, frontier = set(), [(0.0, 0.0, lander_range)]
    while frontier:
        x, z, reach = frontier.pop()
        for rid, (px, pz) in places.items():
            if rid not in reached and math.hypot(px - x, pz - z) <= reach:
                reached.add(rid)
                frontier.append((px, pz, comm_range))
    return reached


def relays_needed(reach_m: float, lander_range: float, comm_range: float) -> int:
    """Fewest relays that bridge ``reach_m`` from the lander, with the spacing margin."""
    if reach_m <= SPACING * lander_range:
        return 0
    return math.ceil((reach_m - SPACING * lander_range) / (SPACING * comm_range))


def plan_chain(goal_xz: tuple[float, float], reach_m: float, rover_ids: list[int], lander_range: float,
               comm_range: float) -> Chain:
    """Relay spots toward a goal whose nearest useful point is ``reach_m`` from the lander.

    ``rover_ids`` come in the order to relay in (the mission plan puts those in radio reach first, then nearest
    the goal first): the first ones relay, the first farthest out. At least one
    rover always goes on to the goal, so a team too small for the distance gets as long a chain as it can
    form.
    """
    count = min(relays_needed(reach_m, lander_range, comm_range), max(len(rover_ids) - 1, 0))
    if count == 0:
        return Chain({})
    gx, gz = goal_xz
    length = math.hypot(gx, gz)
    step = reach_m / (count + 1)  # even spacing: lander, relays and the goal's reach alike
    outward = list(reversed(rover_ids[:count]))
    return Chain({rid: (round(gx / length * step * (i + 1), 3), round(gz / length * step * (i + 1), 3))
                  for i, rid in enumerate(outward)})
