"""Sunlight, power and heat for every rover, stepped with the world: the glue of ``sun``,
``shadows``, ``battery`` and ``thermal``, and the three sensors it publishes.

The world holds one ``Energy`` only when the scenario has a ``sun`` block; without it nothing here runs and
nothing is published. Each tick: which panels are lit (re-traced every ``light_period`` ticks: a rover
covers under a metre in that time), solar input by incidence, draw by what each body does, battery and
temperature. A rover whose battery empties or which gets too cold is off: the world cancels its action and
refuses new ones until it is back. Sensors go out at ``publish_frequency`` and at once on a change (lit or
not, off or back on), so an agent hears of a shadow or a shutdown within a tick.
"""

from __future__ import annotations

import numpy as np

from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.scenario import Scenario
from world_service.actuation import navigation as nav
from world_service.power import battery
from world_service.power.shadows import Occluders, ShadowCache
from world_service.power.sun import Sun
from world_service.power.thermal import Thermal
from world_service.scene import Scene
from world_service.terrain.heightmap import Heightmap


def activity(body: nav.RoverBody) -> int:
    action = body.action
    if isinstance(action, nav.Move):
        return battery.TURNING if action.turning else battery.MOVING
    return battery.TURNING if isinstance(action, nav.Rotate) else battery.IDLE


class Energy:
    def __init__(self, scenario: Scenario, terrain: Heightmap, scene: Scene, keys: ks.Keyspace, dt: float,
                 ids: list[int], light_period: int, publish_period: int) -> None:
        if scenario.sun is None:
            raise ValueError("the energy model needs the scenario's sun block")
        p = scenario.rover_params
        self.params, self.keys, self.dt, self.terrain = p.power, keys, dt, terrain
        self.sun = Sun(scenario.sun)
        self.shadows = ShadowCache(terrain, Occluders.from_scene(scene, terrain), p.power.panel_height_m,
                                   scenario.sun.max_shadow_m)
        self.ids = list(ids)
        self.index = {rid: i for i, rid in enumerate(self.ids)}
        self.batteries = battery.Batteries(p.power, len(self.ids))
        self.thermal = Thermal(p.thermal, len(self.ids))
        self.lit = np.zeros(len(self.ids), bool)
        self.solar = np.zeros(len(self.ids))
        self.light_period, self.publish_period = light_period, publish_period

    # ---- what the world asks ----

    def off(self, rid: int) -> bool:
        i = self.index[rid]
        return bool(self.batteries.empty[i] or self.thermal.cold[i])

    def refusal(self, rid: int) -> tuple[str, str] | None:
        """Why a rover may not act now, if it may not."""
        i = self.index[rid]
        if self.batteries.empty[i]:
            return "no_power", "the battery is empty; the rover is off until its panel has recharged it"
        if self.thermal.cold[i]:
            return "too_cold", f"below the operating minimum of {self.thermal.params.min_operating_c:g} C"
        return None

    def spend(self, rid: int, joules: float) -> None:
        self.batteries.spend(self.index[rid], joules)

    def truth(self, rid: int) -> dict:
        """The rover's power state for ``RoverTruth``."""
        i = self.index[rid]
        b = self.batteries
        return {"battery_wh": round(float(b.charge_wh[i]), 6),
                "temperature_c": round(float(self.thermal.celsius[i]), 3), "sunlit": bool(self.lit[i]),
                "energy_used_wh": round(float(b.used_wh[i]), 6),
                "powered": not self.off(rid)}

    def counters(self) -> dict:
        return {"power_shutdowns": self.batteries.shutdowns, "cold_shutdowns": self.thermal.shutdowns}

    # ---- time ----

    def step(self, tick: int, sim_time: float, bodies: list[nav.RoverBody]) -> tuple[list[Out], list[int]]:
        """Advance one tick. Returns the sensor samples to publish and the ids of rovers that just went off."""
        changed_light = self._light(tick, sim_time, bodies) if tick % self.light_period == 1 % self.light_period \
            else np.zeros(len(bodies), bool)
        was_off = self.batteries.empty | self.thermal.cold
        acts = np.array([activity(b) for b in bodies], int)
        levels = np.array([b.speed_level for b in bodies], int)
        draw = battery.draw_w(self.params, acts, levels)
        self.batteries.step(draw, self.solar, ~self.thermal.cold, self.dt)
        self.thermal.step(self.lit, self.dt)
        now_off = self.batteries.empty | self.thermal.cold
        switched = now_off != was_off
        every = tick % self.publish_period == 1 % self.publish_period
        out: list[Out] = []
        for i, body in enumerate(bodies):
            if every or switched[i]:
                out += self._power_sensors(i, body.id, sim_time)
            if every or changed_light[i]:
                out.append((self.keys.rover(body.id, ks.SUN), m.Sunlight(stamp=sim_time, lit=bool(self.lit[i]))))
        return out, [b.id for i, b in enumerate(bodies) if now_off[i] and not was_off[i]]

    def _light(self, tick: int, sim_time: float, bodies: list[nav.RoverBody]) -> np.ndarray:
        """Trace the panels' light; returns which rovers' lit state changed."""
        sun = self.sun.at(sim_time)
        xs, zs = np.array([b.x for b in bodies]), np.array([b.z for b in bodies])
        lit = self.shadows.lit(sun, xs, zs)
        gx, gz = self.terrain.gradient(xs, zs)
        self.solar = battery.solar_w(self.params, lit, battery.incidence_cos(self.params, sun, gx, gz))
        changed = (lit != self.lit) if tick > 1 else np.zeros(len(bodies), bool)
        self.lit = lit
        return changed

    def _power_sensors(self, i: int, rid: int, stamp: float) -> list[Out]:
        b, t = self.batteries, self.thermal
        battery = m.Battery(stamp=stamp, charge_wh=round(float(b.charge_wh[i]), 6), capacity_wh=self.params.capacity_wh,
                            solar_w=round(float(self.solar[i]), 4), empty=bool(b.empty[i]))
        temperature = m.Temperature(stamp=stamp, celsius=round(float(t.celsius[i]), 3), shutdown=bool(t.cold[i]))
        return [(self.keys.rover(rid, ks.BATTERY), battery), (self.keys.rover(rid, ks.TEMPERATURE), temperature)]
