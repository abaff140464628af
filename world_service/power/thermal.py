"""Rover temperatures (the report's need N9): warm in sunlight, cool in shadow, off when too cold.

Newton's law per rover: the temperature tends to ``sun_c`` while the rover is lit and to ``shadow_c`` while it
is not, with time constant ``heat_time_constant_s`` or ``cool_time_constant_s``. Each tick applies the exact
solution for a constant surrounding, T <- T_env + (T - T_env) exp(-dt / tau), so the curve matches the closed
form T(t) = T_env + (T0 - T_env) exp(-t / tau) whatever the tick. Below ``min_operating_c`` the rover shuts
down (the event is counted); it starts again above ``resume_c``. The rover's own electronics' heat and a
survival heater are not modelled (assumptions: small against the surroundings' pull, and a heater would draw
the battery this model already drains).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from schemas.params import ThermalParams


def relax(temperature: np.ndarray, lit: np.ndarray, params: ThermalParams, dt: float) -> np.ndarray:
    """Temperatures after ``dt`` seconds towards the lit or the shadowed surroundings."""
    env = np.where(lit, params.sun_c, params.shadow_c)
    tau = np.where(lit, params.heat_time_constant_s, params.cool_time_constant_s)
    return env + (np.asarray(temperature, float) - env) * np.exp(-dt / tau)


@dataclass
class Thermal:
    """Every rover's temperature, and which are shut down by cold."""

    params: ThermalParams
    count: int
    celsius: np.ndarray = field(init=False)
    cold: np.ndarray = field(init=False)
    shutdowns: int = 0

    def __post_init__(self) -> None:
        self.celsius = np.full(self.count, self.params.initial_c)
        self.cold = self.celsius < self.params.min_operating_c

    def step(self, lit: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """Advance by ``dt`` s. Returns (shut down by cold now, warm enough again now)."""
        p = self.params
        self.celsius = relax(self.celsius, lit, p, dt)
        froze = ~self.cold & (self.celsius < p.min_operating_c)
        thawed = self.cold & (self.celsius >= p.resume_c)
        self.cold = (self.cold | froze) & ~thawed
        self.shutdowns += int(froze.sum())
        return froze, thawed
