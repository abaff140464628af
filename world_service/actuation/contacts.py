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


def contacts(moved: list[nav.RoverBody], bodies: list[nav.RoverBody], scene: Scene, radius: float) -> Contacts:
    """Contacts of the rovers in ``moved`` with the scene and with any of ``bodies`` (every rover)."""
    if not moved:
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
