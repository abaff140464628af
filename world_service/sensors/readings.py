"""What the rovers' own sensors read each tick and the world publishes to each agent: perception scans
(``perception``), staggered over the perception period, and the gyroscope's pitch with its seeded noise (with a sun
sensor, the heading too, with its own seeded noise: the true heading goes no further than this module).
"""

from __future__ import annotations

import numpy as np

from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.params import RoverParams
from world_service.actuation import navigation as nav
from world_service.clock import Clock
from world_service.scene import Scene
from world_service.sensors.perception import Perceiver
from world_service.terrain.heightmap import Heightmap
from world_service.terrain.pitch import RoverPitch

KIND_NAMES = np.array(m.HIT_KINDS)


class Sensors:
    """``rng`` is the world's own generator, shared with actuation: the order of all draws is part of a run."""

    def __init__(self, scene: Scene, terrain: Heightmap, params: RoverParams, keys: ks.Keyspace, clock: Clock,
                 rng: np.random.Generator, pitch: RoverPitch) -> None:
        self.terrain, self.params, self.keys, self.clock, self.rng = terrain, params, keys, clock, rng
        self.pitch = pitch
        self.perceiver = Perceiver(scene, terrain, params)
        self.perception_period = clock.period(params.perception.publish_frequency)
        self.gyroscope_period = clock.period(params.perception.gyroscope_frequency)

    def read(self, bodies: list[nav.RoverBody]) -> list[Out]:
        """This tick's perception scans, then, at their rate, the gyroscopes."""
        xs, zs, hs = (np.array([getattr(b, a) for b in bodies]) for a in ("x", "z", "heading"))
        out = self._perceptions(bodies, xs, zs, hs)
        if self.clock.tick % self.gyroscope_period == 0:
            out += self._gyroscopes(bodies, xs, zs, hs)
        return out

    def _perceptions(self, bodies, xs, zs, hs) -> list[Out]:
        """Each rover scans once per perception period, the rovers staggered over the period's ticks.

        Staggered in lockstep too, though scanning all on one tick would leave more ticks waiting for nobody:
        rovers that decide on the same tick meet each other's right of way symmetrically, and in the daisy chain
        scenario that cost a rover its goal. Independent rovers do not share a clock phase either."""
        tick, stamp = self.clock.tick, self.clock.sim_time
        which = np.array([i for i, b in enumerate(bodies) if (tick + b.id) % self.perception_period == 0], int)
        scans = self.perceiver.scans(xs, zs, hs, which)
        angles, distances = scans.angles_deg.round(3).tolist(), scans.distances_m.round(3).tolist()
        kinds = KIND_NAMES[scans.kinds].tolist()
        return [(self.keys.rover(bodies[i].id, ks.PERCEPTION),
                 m.Perception(stamp=stamp, angles_deg=angles[a:b], distances_m=distances[a:b], kinds=kinds[a:b]))
                for i, (a, b) in zip(which.tolist(), scans.spans(), strict=True)]

    def _gyroscopes(self, bodies, xs, zs, hs) -> list[Out]:
        pitch = self.pitch.pitch_deg([b.id for b in bodies], xs, zs, hs)
        noise = self.params.perception.gyroscope_noise_std_deg
        if noise > 0:
            pitch = pitch + self.rng.normal(0.0, noise, len(pitch))
        stamp = self.clock.sim_time
        headings = self._sun_headings(hs)
        return [(self.keys.rover(b.id, ks.GYROSCOPE), m.Gyroscope(stamp=stamp, pitch_deg=p, heading_deg=h))
                for b, p, h in zip(bodies, pitch.round(4).tolist(), headings, strict=True)]

    def _sun_headings(self, hs: np.ndarray) -> list[float | None]:
        """Each rover's sun sensor reading: its true heading with the sensor's noise (drawn after the pitch's, only
        when the rovers carry one, so worlds without it draw as before), in [0, 360); None without a sensor."""
        p = self.params.perception
        if not p.sun_sensor:
            return [None] * len(hs)
        noisy = hs + self.rng.normal(0.0, p.sun_sensor_noise_std_deg, len(hs)) if p.sun_sensor_noise_std_deg > 0 else hs
        return np.round(np.mod(noisy, 360.0), 4).tolist()
