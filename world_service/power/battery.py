"""Rover batteries (the report's need N10): drain by what each rover does, solar charge in sunlight only.

Model, per rover and per tick of ``dt`` seconds, all rovers as arrays:

- draw (W) while on: ``idle_w + perception_w`` always, plus ``move_w[speed level]`` while walking or
  ``rotate_w`` while turning (a move's turn towards its goal counts as turning). Radio transmissions and
  photos cost a fixed energy each (``radio_transmit_j``, ``photo_j``), taken when they happen.
- solar (W) = ``solar_flux_w_m2 * panel_area_m2 * panel_efficiency * max(0, cos incidence)``, only while
  the panel is lit (``shadows``); the incidence is between the sun and the panel's normal (``incidence``).
- charge += (solar - draw) * dt, kept within [0, capacity]. A rover whose charge reaches 0 is off: it
  draws nothing, stops and refuses actions, and says so on its battery sensor; it comes back on once its
  panel has charged it above ``resume_fraction`` of capacity.

Closed forms the tests check: at constant solar S and draw D the charge is c0 + (S - D) t / 3600 Wh until a
bound; an empty rover in sun comes back after ``resume_fraction * capacity * 3600 / S`` seconds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from schemas.params import PowerParams
from world_service.power.sun import SunPosition

IDLE, MOVING, TURNING = 0, 1, 2
"""Activity codes of ``draw_w``."""


def draw_w(params: PowerParams, activity: np.ndarray, speed_level: np.ndarray) -> np.ndarray:
    """Power each rover draws while on, by activity (``IDLE``, ``MOVING``, ``TURNING``) and speed level."""
    move = np.asarray(params.move_w)[np.clip(np.asarray(speed_level, int), 1, 3) - 1]
    extra = np.where(activity == MOVING, move, np.where(activity == TURNING, params.rotate_w, 0.0))
    return params.idle_w + params.perception_w + extra


def incidence_cos(params: PowerParams, sun: SunPosition, slope_x: np.ndarray, slope_z: np.ndarray) -> np.ndarray:
    """cos of the angle between the sun and each panel, at least 0.

    The panel lies on the deck, which follows the ground (normal from the ground's gradient), tilted by
    ``panel_tilt_deg`` towards the sun's azimuth: a polar rover props its panel up towards the low sun.
    """
    gx, gz = np.asarray(slope_x, float), np.asarray(slope_z, float)
    n = np.stack([-gx, np.ones_like(gx), -gz], axis=-1)
    n /= np.linalg.norm(n, axis=-1, keepdims=True)
    tilt = math.radians(params.panel_tilt_deg)
    if tilt > 0:
        az = math.radians(sun.azimuth_deg)
        u = np.array([math.sin(az), 0.0, math.cos(az)])
        along = u - (n @ u)[..., None] * n  # the sun's azimuth within the deck's plane
        norm = np.linalg.norm(along, axis=-1, keepdims=True)
        along = np.divide(along, norm, out=np.zeros_like(along), where=norm > 1e-12)
        n = math.cos(tilt) * n + math.sin(tilt) * along
    return np.maximum(n @ sun.vector, 0.0)


def solar_w(params: PowerParams, lit: np.ndarray, cos_incidence: np.ndarray) -> np.ndarray:
    """Panel output: only while lit."""
    peak = params.solar_flux_w_m2 * params.panel_area_m2 * params.panel_efficiency
    return np.where(lit, peak * cos_incidence, 0.0)


@dataclass
class Batteries:
    """Charge of every rover's battery and what has flowed through it, with the empty/resumed events."""

    params: PowerParams
    count: int
    charge_wh: np.ndarray = field(init=False)
    empty: np.ndarray = field(init=False)
    used_wh: np.ndarray = field(init=False)
    harvested_wh: np.ndarray = field(init=False)
    shutdowns: int = 0

    def __post_init__(self) -> None:
        p = self.params
        self.charge_wh = np.full(self.count, p.capacity_wh * p.initial_charge_fraction)
        self.empty = self.charge_wh <= 0.0
        self.used_wh = np.zeros(self.count)
        self.harvested_wh = np.zeros(self.count)

    def spend(self, index: int, joules: float) -> None:
        """A one-off cost (a transmission, a photo), taken at once."""
        if self.empty[index] or joules <= 0:
            return
        wh = min(joules / 3600.0, self.charge_wh[index])
        self.charge_wh[index] -= wh
        self.used_wh[index] += wh

    def step(self, draw: np.ndarray, solar: np.ndarray, on: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Advance by ``dt`` s; ``on``: rovers running (not off for cold). Returns (became empty, came back)."""
        p = self.params
        draw = np.where(on & ~self.empty, draw, 0.0)
        before = self.charge_wh
        after = np.clip(before + (solar - draw) * dt / 3600.0, 0.0, p.capacity_wh)
        self.harvested_wh += solar * dt / 3600.0
        self.used_wh += np.minimum(draw * dt / 3600.0, before + solar * dt / 3600.0)
        self.charge_wh = after
        emptied = ~self.empty & (after <= 0.0)
        back = self.empty & (after >= p.resume_fraction * p.capacity_wh) & (after > 0.0)
        self.empty = (self.empty | emptied) & ~back
        self.shutdowns += int(emptied.sum())
        return emptied, back
