"""Whether a rover may do what its agent asks, and how the ground makes it go wrong: the checks a move passes
before it starts (field of view, range, a clear and climbable line) and the seeded noise of moves and rotations.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from schemas import messages as m
from schemas.params import NavigationParams, RoverParams
from world_service.actuation import navigation as nav
from world_service.scene import Scene, in_view
from world_service.terrain.heightmap import Heightmap

Others = Callable[[int], tuple[np.ndarray, np.ndarray]]
"""Every other rover's position (x, z arrays) than the one whose id it is given."""


def move_problem(body: nav.RoverBody, msg: m.MoveAction, params: RoverParams, scene: Scene, terrain: Heightmap,
                 others: Others) -> tuple[str, str] | None:
    """Why the move may not start (reason, detail), or None. Cheapest checks first: the others' positions and the
    ground are looked at only for a move in view and in range."""
    p = params
    if body.busy:
        return "action_in_progress", "a move or rotate is still running"
    if not in_view(msg.x, msg.z, p.perception.field_of_view_degrees):
        return "out_of_view", f"({msg.x:.2f}, {msg.z:.2f}) is outside the field of view"
    limit = p.perception.perception_radius * (1 + p.navigation.move_action_tolerance_factor)
    if math.hypot(msg.x, msg.z) > limit:
        return "out_of_range", f"{math.hypot(msg.x, msg.z):.2f} m is beyond the {limit:.2f} m perception range"
    gx, gz = nav.to_world(body.x, body.z, body.heading, msg.x, msg.z)
    radius = p.behaviour.rover_radius
    clearance = radius if p.navigation.strict_line_of_sight else 0.0
    ox, oz = others(body.id)
    if scene.line_blocked(body.x, body.z, gx, gz, clearance, ox, oz, radius):
        return "blocked", "the line to the goal is not clear"
    if too_steep(terrain, body.x, body.z, gx, gz, p.navigation.max_slope_deg):
        return "blocked", f"the ground on the way is steeper than {p.navigation.max_slope_deg:g} degrees"
    return None


def too_steep(terrain: Heightmap, x0: float, z0: float, x1: float, z1: float, max_slope_deg: float) -> bool:
    """Whether the ground along the line, every half metre, pitches a rover facing along it above the limit."""
    length = math.hypot(x1 - x0, z1 - z0)
    if length < 1e-9:
        return False
    f = np.linspace(0.0, 1.0, max(2, math.ceil(length / 0.5) + 1))
    pitch = terrain.pitch_deg(x0 + f * (x1 - x0), z0 + f * (z1 - z0), np.degrees(np.arctan2(x1 - x0, z1 - z0)))
    return bool(np.any(pitch > max_slope_deg))


def move_noise(rng: np.random.Generator, params: NavigationParams, x: float,
               z: float) -> tuple[tuple[float, float], float]:
    """How a move goes wrong (seeded): the ground slips it by a share of its length, the heading drifts. The draws'
    order is part of every run's result: the turn first, then the slip."""
    sigma = params.slip_std * math.hypot(x, z)
    turn = rng.normal(0.0, params.heading_noise_std_deg) if params.heading_noise_std_deg > 0 else 0.0
    slip = (rng.normal(0.0, sigma), rng.normal(0.0, sigma)) if sigma > 0 else (0.0, 0.0)
    return slip, turn


def rotation_noise(rng: np.random.Generator, params: NavigationParams) -> float:
    """Degrees a rotation turns beyond what was asked (seeded)."""
    noise = params.heading_noise_std_deg
    return rng.normal(0.0, noise) if noise > 0 else 0.0
