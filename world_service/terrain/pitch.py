"""The rovers' pitch on the terrain, remembered per rover while it stands where it was last asked about.

Two parts of a tick read it: the actuator, for the slope factors of the rovers it moves (where they stood before
the step), and the gyroscopes, for every rover (where they stand after it). At the gyroscopes' rate of one sample a
tick, each step asks again what the last tick's gyroscopes just computed. A call whose rovers all stand where they
stood gets the numbers already computed (a rover's pitch is a pure function of its pose, element by element); any
other call is computed whole as before.
"""

from __future__ import annotations

import numpy as np

from world_service.terrain.heightmap import Heightmap


class RoverPitch:
    def __init__(self, terrain: Heightmap) -> None:
        self.terrain = terrain
        self.known: dict[int, tuple[float, float, float, float]] = {}  # rover -> (x, z, heading, pitch)

    def pitch_deg(self, ids: list[int], xs: np.ndarray, zs: np.ndarray, hs: np.ndarray) -> np.ndarray:
        """``Heightmap.pitch_deg`` of the rovers ``ids`` at the poses (xs, zs, hs)."""
        poses = list(zip(xs.tolist(), zs.tolist(), hs.tolist(), strict=True))
        known = [self.known.get(rid) for rid in ids]
        if all(k is not None and k[:3] == pose for k, pose in zip(known, poses, strict=True)):
            return np.array([k[3] for k in known])
        pitch = self.terrain.pitch_deg(xs, zs, hs)
        self.known.update((rid, (*pose, p)) for rid, pose, p in zip(ids, poses, pitch.tolist(), strict=True))
        return pitch
