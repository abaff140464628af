"""Collisions: which rovers that moved this tick now touch a rock, a wall, the lander or another rover."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from world_service.actuation import navigation as nav
from world_service.scene import Scene, circle_pairs


@dataclass
class Contacts:
    """The movers that touch something, and the contacts counted: each rover-obstacle contact of a mover, and each
    pair of rovers once."""

    hit: list[nav.RoverBody]
    obstacle: int = 0
    rover_pairs: int = 0


PLAIN_PAIRS = 256
"""Up to this many (mover, circle) pairs, the movers are first cleared in plain Python (``_clear``); more, and
NumPy's test is the cheaper."""
SLACK = 1e-6
"""Relative room the plain test leaves round each contact distance: far above a sum of squares' rounding."""


def contacts(moved: list[nav.RoverBody], bodies: list[nav.RoverBody], scene: Scene, radius: float) -> Contacts:
    """Contacts of the rovers in ``moved`` with the scene and with any of ``bodies`` (every rover)."""
    if not moved or _clear(moved, bodies, scene, radius):
        return Contacts([])
    mx, mz = np.array([b.x for b in moved]), np.array([b.z for b in moved])
    static = scene.contacts(mx, mz, radius)
    xs, zs = np.array([b.x for b in bodies]), np.array([b.z for b in bodies])
    index = {b.id: i for i, b in enumerate(bodies)}
    mover, other = circle_pairs(mx, mz, xs, zs, np.full(len(xs), radius), radius, 4 * radius)
    own = np.array([index[moved[i].id] for i in mover], int)
    touching = (other != own) & (np.hypot(xs[other] - mx[mover], zs[other] - mz[mover]) < 2 * radius)
    pairs = {tuple(sorted((int(own[k]), int(other[k])))) for k in np.nonzero(touching)[0]}
    hit = {moved[i].id for i in np.nonzero(static)[0]} | {bodies[i].id for pair in pairs for i in pair}
    return Contacts([b for b in moved if b.id in hit], int(static.sum()), len(pairs))


def _clear(moved: list[nav.RoverBody], bodies: list[nav.RoverBody], scene: Scene, radius: float) -> bool:
    """Whether no mover comes near a rock, the lander or another rover, by squared distances in plain Python: with
    a handful of rovers NumPy's cost per call is most of the exact test's, and nearly every tick nothing is near.
    The test leaves ``SLACK`` of room, so it clears no mover the exact test would find touching; a mover it does
    not clear goes to the exact test. Walls are left to the exact test."""
    if len(scene.edges) or len(moved) * (len(scene.circle_x) + len(bodies)) > PLAIN_PAIRS:
        return False
    room = 1.0 + SLACK
    fixed = [(x, z, ((r + radius) * room) ** 2) for x, z, r in
             zip(scene.circle_x.tolist(), scene.circle_z.tolist(), scene.circle_r.tolist(), strict=True)]
    rover_reach = (2 * radius * room) ** 2
    for b in moved:
        if any((x - b.x) ** 2 + (z - b.z) ** 2 < reach for x, z, reach in fixed):
            return False
        if any(o is not b and (o.x - b.x) ** 2 + (o.z - b.z) ** 2 < rover_reach for o in bodies):
            return False
    return True
