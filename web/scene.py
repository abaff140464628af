"""A scenario as the JSON the page draws: terrain heights, craters, rocks, walls, lander and goals.

The terrain sampling and rock-field scattering are those of the Foxglove export
(``sessions.foxglove``, ``world_service.scene``), so the browser, Foxglove and the world agree on
where things are. Coordinates stay LunarSim's: x, z on the ground, height apart; the page maps them.
"""

from __future__ import annotations

import numpy as np

from schemas.scenario import Scenario
from sessions import foxglove as fx

TERRAIN_CELLS = 96
"""Terrain nodes along the longer side: enough to see craters, small enough to send to a browser at once."""


def _round(values: np.ndarray, digits: int = 2) -> list[float]:
    return [round(float(v), digits) for v in np.asarray(values).ravel()]


def scenario_scene(scenario: Scenario, cells: int = TERRAIN_CELLS) -> dict:
    """Everything static in a scenario, with heights so the page can set objects on the ground."""
    from world_service.scene import scatter_rock_fields

    grid = fx.sample_terrain(scenario, cells=cells)

    def ground(x: float, z: float) -> float:
        return round(float(grid.height_at(x, z)), 2)

    rocks = list(scenario.obstacles.rocks) + scatter_rock_fields(scenario)
    return {
        "name": scenario.name,
        "terrain": {"x0": float(grid.xs[0]), "z0": float(grid.zs[0]), "x1": float(grid.xs[-1]),
                    "z1": float(grid.zs[-1]), "nx": len(grid.xs), "nz": len(grid.zs),
                    "heights": _round(grid.heights)},
        "craters": [{"x": c.x, "z": c.z, "r": c.radius_m, "h": ground(c.x, c.z + c.radius_m)}
                    for c in scenario.craters],
        "rocks": [{"x": r.x, "z": r.z, "r": r.radius_m, "h": ground(r.x, r.z)} for r in rocks],
        "walls": [{"points": [list(p) for p in w.points], "thickness": w.thickness_m, "height": w.height_m,
                   "h": ground(*w.points[0])} for w in scenario.obstacles.walls],
        "lander": {"x": scenario.lander.x, "z": scenario.lander.z, "r": scenario.lander.radius_m,
                   "h": ground(scenario.lander.x, scenario.lander.z)},
        "goals": [{"x": g.x, "z": g.z, "kind": g.kind, "h": ground(g.x, g.z)} for g in scenario.mission],
        "spawns": [{"x": r.x, "z": r.z} for r in scenario.rovers],  # where the page's camera looks at the start
        **sun_and_power(scenario),
    }


def sun_and_power(scenario: Scenario) -> dict:
    """The sun where it stands at the start (it moves 0.5 degrees an hour, so the page does not follow it) and
    the battery capacity the page divides by; both None without a ``sun`` block (no power model)."""
    from world_service.power.sun import Sun

    if scenario.sun is None:
        return {"sun": None, "power": None}
    pos = Sun(scenario.sun).exact(0.0)
    return {"sun": {"azimuth_deg": round(pos.azimuth_deg, 3), "elevation_deg": round(pos.elevation_deg, 3)},
            "power": {"capacity_wh": scenario.rover_params.power.capacity_wh}}


def empty_scene() -> dict:
    """No scenario known yet (``lunarsim view`` without ``--scenario``): the page sizes a flat ground to the rovers."""
    return {"name": "", "terrain": None, "craters": [], "rocks": [], "walls": [], "lander": None, "goals": [],
            "spawns": [], "sun": None, "power": None}
