"""Rover navigation (report 10.2) as pure state updates: move, rotate, cancel and speed.

A move first turns the rover towards its goal at ``angular_speed`` and then drives the straight line the
move check validated, accelerating and braking at ``acceleration``; so a completed move leaves the
rover on its goal facing along the move, which is what the agent's dead reckoning assumes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from schemas.frames import to_relative, to_world, wrap_deg
from schemas.params import NavigationParams


@dataclass
class Move:
    goal_x: float  # where the rover really ends (slip included)
    goal_z: float
    start: tuple[float, float, float]  # x, z, heading at acceptance
    face_x: float  # the commanded goal: the rover turns to face it, slip displaces but does not rotate
    face_z: float
    turning: bool = True
    cancelling: bool = False
    final_turn: float = 0.0  # heading error added on arrival (noise)


@dataclass
class Rotate:
    remaining_deg: float
    start: tuple[float, float, float]
    cancelling: bool = False


@dataclass
class Ended:
    """How an action finished this tick: what the world answers on navigation_status / cancel_result."""

    action: str  # "move" | "rotate"
    outcome: str  # "completed" | "cancelled" | "collided"
    start: tuple[float, float, float] | None = None


@dataclass
class RoverBody:
    id: int
    x: float
    z: float
    heading: float
    speed_level: int = 3
    velocity: float = 0.0
    action: Move | Rotate | None = None
    distance_covered: float = 0.0

    @property
    def busy(self) -> bool:
        return self.action is not None

    def remaining(self) -> float:
        """What navigation_status reports: metres to the move goal, or degrees still to turn."""
        if isinstance(self.action, Move):
            return math.hypot(self.action.goal_x - self.x, self.action.goal_z - self.z)
        if isinstance(self.action, Rotate):
            return abs(self.action.remaining_deg)
        return 0.0

    def start_move(self, rel_x: float, rel_z: float, slip: tuple[float, float] = (0.0, 0.0),
                   final_turn: float = 0.0) -> None:
        """Move to a rover-relative point; ``slip`` (rover-relative metres) is how far off the ground takes it."""
        fx, fz = to_world(self.x, self.z, self.heading, rel_x, rel_z)
        gx, gz = to_world(self.x, self.z, self.heading, rel_x + slip[0], rel_z + slip[1])
        self.action = Move(gx, gz, (self.x, self.z, self.heading), fx, fz, final_turn=final_turn)

    def start_rotate(self, degrees: float) -> None:
        self.action = Rotate(degrees, (self.x, self.z, self.heading))

    def cancel(self) -> None:
        if self.action is not None:
            self.action.cancelling = True

    def relative_to_start(self, start: tuple[float, float, float]) -> tuple[float, float, float]:
        """(x, z, angle) of the rover in the frame of where an action started: the CancelResult."""
        sx, sz, sh = start
        rx, rz = to_relative(sx, sz, sh, self.x, self.z)
        return rx, rz, wrap_deg(self.heading - sh)


def slope_factor(pitch_deg, params: NavigationParams):
    """Share of the set speed a rover keeps climbing at ``pitch_deg`` (downhill and flat: all of it)."""
    climb = np.clip(np.asarray(pitch_deg, float) / params.max_slope_deg, 0.0, 1.0)
    return 1.0 - params.slope_slowdown * climb


def step(body: RoverBody, dt: float, params: NavigationParams, speed_factor: float = 1.0) -> Ended | None:
    """Advance one rover by ``dt`` seconds; returns how its action ended, if it did."""
    action = body.action
    if isinstance(action, Rotate):
        return _step_rotate(body, action, dt, params)
    if isinstance(action, Move):
        return _step_move(body, action, dt, params, speed_factor)
    return None


def _step_rotate(body: RoverBody, action: Rotate, dt: float, params: NavigationParams) -> Ended | None:
    if action.cancelling:
        body.action = None
        return Ended("rotate", "cancelled", action.start)
    turn = math.degrees(params.in_place_rotation_speed) * dt
    delta = max(-turn, min(turn, action.remaining_deg))
    body.heading = (body.heading + delta) % 360.0
    action.remaining_deg -= delta
    if abs(action.remaining_deg) < 1e-9:
        body.action = None
        return Ended("rotate", "completed", action.start)
    return None


def _step_move(body: RoverBody, move: Move, dt: float, params: NavigationParams, speed_factor: float) -> Ended | None:
    dist = math.hypot(move.goal_x - body.x, move.goal_z - body.z)
    if move.turning:
        if move.cancelling:
            return _end_move(body, move, "cancelled")
        ahead = math.hypot(move.face_x - body.x, move.face_z - body.z) > 1e-9
        bearing = math.degrees(math.atan2(move.face_x - body.x, move.face_z - body.z)) if ahead else body.heading
        diff = wrap_deg(bearing - body.heading)
        turn = params.angular_speed * dt
        body.heading = (body.heading + max(-turn, min(turn, diff))) % 360.0
        if abs(diff) > turn:
            return None
        move.turning = False
    accel = params.acceleration
    if move.cancelling:
        body.velocity = max(0.0, body.velocity - accel * dt)
        if body.velocity == 0.0:
            return _end_move(body, move, "cancelled")
    else:
        braking = math.sqrt(2 * accel * dist)
        body.velocity = min(body.velocity + accel * dt, params.speed(body.speed_level) * speed_factor, braking)
    advance = min(body.velocity * dt, dist)
    if dist > 1e-9 and advance > 0:  # along the line to where the rover really ends, heading unchanged
        body.x += advance * (move.goal_x - body.x) / dist
        body.z += advance * (move.goal_z - body.z) / dist
        body.distance_covered += advance
    if not move.cancelling and (dist - advance) < 1e-6:
        body.x, body.z = move.goal_x, move.goal_z
        body.heading = (body.heading + move.final_turn) % 360.0
        return _end_move(body, move, "completed")
    return None


def _end_move(body: RoverBody, move: Move, outcome: str) -> Ended:
    body.action = None
    body.velocity = 0.0
    return Ended("move", outcome, move.start)
