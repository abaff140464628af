"""What the emulated device simulates: a differential-drive base with an IMU, a ray scanner and a few rocks.

Pure state updates in the base's own frame (it starts at (0, 0) facing +z), with the report's defaults:
speeds 1.5/2.5/3.5 m/s, 120 deg/s turning towards a move goal, 2 rad/s rotating in place, 20 m/s^2 braking,
a 210 degree, 10 m field of view. A move turns to face its goal, then drives there; a cancel brakes to a
stop; touching a rock stops the base (``collided``). Its odometry is exact: the emulator tests drivers and
bridges, not dead reckoning.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from schemas.errors import LunarSimError
from schemas.frames import to_relative, to_world, wrap_deg

STEP_S = 0.01


@dataclass(frozen=True)
class Rock:
    x: float
    z: float
    radius: float
    kind: str = "obstacle"


DEFAULT_ROCKS = (Rock(4.0, 5.0, 0.5), Rock(-5.0, 8.0, 0.7), Rock(1.0, -6.0, 0.8))
"""Off the straight line ahead, so a walk forwards passes them and the scanner still sees them."""


@dataclass(frozen=True)
class BaseParams:
    speeds: tuple[float, float, float] = (1.5, 2.5, 3.5)
    turn_speed_deg: float = 120.0
    rotation_speed_deg: float = math.degrees(2.0)
    acceleration: float = 20.0
    fov_deg: float = 210.0
    range_m: float = 10.0
    rays: int = 43
    radius: float = 0.5
    slope_deg: float = 0.0
    """The ground rises towards +z (the start heading) at this angle; the IMU's pitch follows the heading."""


class Refused(LunarSimError):
    """An action the device refuses; ``code`` is the protocol's error code."""

    def __init__(self, code: str, detail: str) -> None:
        super().__init__(detail)
        self.code, self.detail = code, detail


@dataclass
class Action:
    id: int
    kind: str  # move | rotate
    start: tuple[float, float, float]
    goal: tuple[float, float] = (0.0, 0.0)
    turn_left: float = 0.0  # degrees still to rotate (rotate), signed
    turning: bool = True
    cancelling: bool = False
    outcome: str = "running"


@dataclass
class DeviceModel:
    params: BaseParams = field(default_factory=BaseParams)
    rocks: tuple[Rock, ...] = DEFAULT_ROCKS
    x: float = 0.0
    z: float = 0.0
    heading: float = 0.0
    velocity: float = 0.0
    speed_level: int = 3
    action: Action | None = None
    time: float = 0.0
    next_id: int = 1

    # ---- commands ----

    def move(self, x: float, z: float) -> int:
        self._idle_or_refuse()
        p = self.params
        bearing = math.degrees(math.atan2(x, z))
        if abs(bearing) > p.fov_deg / 2:
            raise Refused("out_of_view", f"({x:.2f}, {z:.2f}) is {bearing:.0f} degrees off, outside the view")
        if math.hypot(x, z) > p.range_m * 1.1:
            raise Refused("out_of_range", f"{math.hypot(x, z):.2f} m is beyond the {p.range_m:g} m range")
        gx, gz = to_world(self.x, self.z, self.heading, x, z)
        if any(_segment_distance(r.x, r.z, self.x, self.z, gx, gz) < r.radius for r in self.rocks):
            raise Refused("blocked", "a rock is in the way")
        return self._start(Action(self.next_id, "move", self.pose(), goal=(gx, gz)))

    def rotate(self, degrees: float) -> int:
        self._idle_or_refuse()
        return self._start(Action(self.next_id, "rotate", self.pose(), turn_left=degrees))

    def cancel(self) -> None:
        if not self.busy:
            raise Refused("no_action", "nothing to cancel")
        self.action.cancelling = True

    def set_speed(self, level: int) -> None:
        if level not in (1, 2, 3):
            raise Refused("bad_value", f"speed level {level} is not 1, 2 or 3")
        self.speed_level = level

    def _idle_or_refuse(self) -> None:
        if self.busy:
            raise Refused("busy", f"action {self.action.id} is still running")

    def _start(self, action: Action) -> int:
        self.action, self.next_id = action, self.next_id + 1
        return action.id

    # ---- readings ----

    @property
    def busy(self) -> bool:
        return self.action is not None and self.action.outcome == "running"

    def pose(self) -> tuple[float, float, float]:
        return self.x, self.z, self.heading

    def status(self) -> tuple[int, str, str, float, float, float, float] | None:
        """(id, kind, outcome, remaining, x, z, angle relative to the action's start) of the latest action."""
        a = self.action
        if a is None:
            return None
        sx, sz, sh = a.start
        rx, rz = to_relative(sx, sz, sh, self.x, self.z)
        return a.id, a.kind, a.outcome, self._remaining(a), rx, rz, wrap_deg(self.heading - sh)

    def _remaining(self, a: Action) -> float:
        if a.outcome != "running":
            return 0.0
        return math.hypot(a.goal[0] - self.x, a.goal[1] - self.z) if a.kind == "move" else abs(a.turn_left)

    def pitch(self) -> float:
        return self.params.slope_deg * math.cos(math.radians(self.heading))

    def scan(self) -> list[tuple[float, float, str]]:
        """(angle, distance, kind) of the nearest rock along each ray of the field of view."""
        p = self.params
        hits = []
        for i in range(p.rays):
            angle = -p.fov_deg / 2 + i * p.fov_deg / (p.rays - 1)
            hit = self.first_rock(self.heading + angle, p.range_m)
            if hit is not None:
                hits.append((angle, hit[0], hit[1].kind))
        return hits

    def first_rock(self, bearing_deg: float, reach: float) -> tuple[float, Rock] | None:
        dx, dz = math.sin(math.radians(bearing_deg)), math.cos(math.radians(bearing_deg))
        best = None
        for rock in self.rocks:
            t = _ray_circle(self.x, self.z, dx, dz, rock)
            if t is not None and t <= reach and (best is None or t < best[0]):
                best = (t, rock)
        return best

    # ---- time ----

    def advance(self, now: float) -> None:
        """Simulate up to ``now`` (seconds) in small steps."""
        while self.time + STEP_S <= now:
            self.time += STEP_S
            self._step(STEP_S)

    def _step(self, dt: float) -> None:
        a = self.action
        if a is None or a.outcome != "running":
            return
        if a.kind == "rotate":
            self._step_rotate(a, dt)
        elif a.turning:
            self._step_turn(a, dt)
        else:
            self._step_drive(a, dt)

    def _step_rotate(self, a: Action, dt: float) -> None:
        if a.cancelling:
            a.outcome = "cancelled"
            return
        turn = max(-self.params.rotation_speed_deg * dt, min(self.params.rotation_speed_deg * dt, a.turn_left))
        self.heading = (self.heading + turn) % 360.0
        a.turn_left -= turn
        if abs(a.turn_left) < 1e-9:
            a.outcome = "completed"

    def _step_turn(self, a: Action, dt: float) -> None:
        if a.cancelling:
            a.outcome = "cancelled"
            return
        far = math.hypot(a.goal[0] - self.x, a.goal[1] - self.z) > 1e-9
        bearing = math.degrees(math.atan2(a.goal[0] - self.x, a.goal[1] - self.z)) if far else self.heading
        diff = wrap_deg(bearing - self.heading)
        step = self.params.turn_speed_deg * dt
        self.heading = (self.heading + max(-step, min(step, diff))) % 360.0
        a.turning = abs(diff) > step

    def _step_drive(self, a: Action, dt: float) -> None:
        p = self.params
        dist = math.hypot(a.goal[0] - self.x, a.goal[1] - self.z)
        if a.cancelling:
            self.velocity = max(0.0, self.velocity - p.acceleration * dt)
        else:
            braking = math.sqrt(2 * p.acceleration * dist)
            self.velocity = min(self.velocity + p.acceleration * dt, p.speeds[self.speed_level - 1], braking)
        advance = min(self.velocity * dt, dist)
        if dist > 1e-9 and advance > 0:
            nx = self.x + advance * (a.goal[0] - self.x) / dist
            nz = self.z + advance * (a.goal[1] - self.z) / dist
            if any(math.hypot(nx - r.x, nz - r.z) < r.radius + p.radius for r in self.rocks):
                self.velocity, a.outcome = 0.0, "collided"
                return
            self.x, self.z = nx, nz
        if a.cancelling and self.velocity == 0.0:
            a.outcome = "cancelled"
        elif not a.cancelling and dist - advance < 1e-6:
            self.x, self.z, self.velocity, a.outcome = a.goal[0], a.goal[1], 0.0, "completed"


def _ray_circle(x: float, z: float, dx: float, dz: float, rock: Rock) -> float | None:
    """Distance along a unit ray to the circle's edge, None if it misses (or starts inside)."""
    ox, oz = x - rock.x, z - rock.z
    b = ox * dx + oz * dz
    c = ox * ox + oz * oz - rock.radius ** 2
    disc = b * b - c
    if disc < 0 or c < 0:
        return None
    t = -b - math.sqrt(disc)
    return t if t >= 0 else None


def _segment_distance(px: float, pz: float, x0: float, z0: float, x1: float, z1: float) -> float:
    dx, dz = x1 - x0, z1 - z0
    length2 = dx * dx + dz * dz
    f = 0.0 if length2 == 0 else max(0.0, min(1.0, ((px - x0) * dx + (pz - z0) * dz) / length2))
    return math.hypot(px - (x0 + f * dx), pz - (z0 + f * dz))
