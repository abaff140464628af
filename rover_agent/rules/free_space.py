"""Where a rover's body can go, from one perception scan: the free distance along a direction, and the directions
to try (nearest the goal first, right before left as the report turns right). Pure geometry on the hits."""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Iterator

from rover_agent.decisions import Hit
from schemas.params import BehaviourParams, PerceptionParams, RoverParams

SOLID_KINDS = frozenset({"rover", "obstacle", "lander", "terrain"})
OBSTACLE_MARGIN = 0.6
"""Metres kept between the rover's body and a perceived obstacle; rays are sparse, so stay a bit wide."""
ROVER_GAP_CLOSE = 0.5
"""Metres kept between bodies in close quarters, where rovers step 2 m at a time among others standing
still: on a crater rim, and near the rover's station at a waypoint."""


def candidates(to_goal: float, window: float, scan: float, rejected: Iterable[float]) -> Iterator[float]:
    """Directions to try, nearest the goal first, right before left, leaving out those the world refused.

    Lazily: a rover with its way ahead clear takes the first, and building the whole fan for every decision was
    about a third of a decision's time under cProfile. The refused directions are taken as they stand now."""
    return _fan(to_goal, window, scan, tuple(rejected))


def _fan(to_goal: float, window: float, scan: float, refused: tuple[float, ...]) -> Iterator[float]:
    half = scan / 2
    for k in range(int(2 * window / scan) + 2):
        for a in ((to_goal,) if k == 0 else (to_goal + k * scan, to_goal - k * scan)):
            if abs(a) <= window and all(abs(a - r) > half for r in refused):
                yield a


def free_distance(angle: float, hits: tuple[Hit, ...], params: RoverParams, rover_gap: float) -> float:
    """How far the rover's body can go along ``angle`` before coming too close to a perceived thing.

    A rock seen on a ray may reach almost to the next ray, which missed it, and rays spread with distance (a
    ray step apart, 0.6 m at 8 m by default): so the margin kept from a hit grows by that spread. With a fixed
    margin a move passed a rock 8 m off by a hair on the side where no ray touched it, and hit it. A rover's
    size is known, and its centre fitted, so rovers keep their gap."""
    b = params.behaviour
    free = 0.9 * params.perception.perception_radius
    spread = math.radians(params.perception.ray_step_deg)
    for h in hits:
        if h.kind not in SOLID_KINDS:
            continue
        clearance = b.rover_radius + (b.rover_radius + rover_gap if h.kind == "rover"
                                      else OBSTACLE_MARGIN + h.distance_m * spread)
        delta = math.radians(h.angle_deg - angle)
        along, across = h.distance_m * math.cos(delta), abs(h.distance_m * math.sin(delta))
        if across < clearance and along > 0:
            free = min(free, along - math.sqrt(clearance * clearance - across * across))
    return max(free, 0.0)


def in_the_way(hits: tuple[Hit, ...], kinds: frozenset[str], radius: float, remaining_m: float) -> bool:
    """Whether a thing of ``kinds`` seen now lies across the rest of a move under way: the rover's body, going
    straight on for ``remaining_m``, would touch it. A move is planned clear of what was in view where it began;
    a rock just beyond view then, or one that slip and heading error turned the rover towards, comes into view on
    the way."""
    for h in hits:
        if h.kind not in kinds:
            continue
        rad = math.radians(h.angle_deg)
        along, across = h.distance_m * math.cos(rad), abs(h.distance_m * math.sin(rad))
        if across < radius and along > 0 and along - math.sqrt(radius * radius - across * across) < remaining_m:
            return True
    return False


def ray_angles(fov_deg: float, count: int) -> list[float]:
    """The perception's ray angles, as the world casts them (evenly over the field of view)."""
    return [-fov_deg / 2 + fov_deg * i / (count - 1) for i in range(count)]


@functools.lru_cache(maxsize=8)
def _keyed_rays(fov_deg: float, count: int) -> tuple[tuple[float, float], ...]:
    """Each ray's angle with the key a hit on it is matched by; the same for every scan of a rover, and computing
    them was a third of a decision's time."""
    return tuple((a, round(a, 3)) for a in ray_angles(fov_deg, count))


def free_rays(hits: Iterable[Hit], perception: PerceptionParams) -> list[float]:
    """The angles of the rays that hit nothing within the perception radius: free ground for the rover's map."""
    seen = {round(h.angle_deg, 3) for h in hits}
    rays = _keyed_rays(perception.field_of_view_degrees, perception.perception_granularity)
    return [a for a, key in rays if key not in seen]


def rover_near(hits: Iterable[Hit], behaviour: BehaviourParams, step_m: float) -> bool:
    """A rover within ``collision_danger_dist`` of anywhere along a step of ``step_m``: two rovers stepping into
    one gap at full speed close by more between two scans than a close-quarters stop leaves, so the move goes
    slowly. On any side: rovers at close quarters turn before they step, so one beside or behind may be stepping
    into the same gap. Along the step: two rovers climbing a rim 4.5 m apart stepped 2 m each, head on, at full
    speed, and met."""
    return any(h.kind == "rover" and h.distance_m < behaviour.collision_danger_dist + step_m for h in hits)
