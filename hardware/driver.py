"""The hardware driver interface: what one real rover must offer for the unchanged rover agent to run on it.

The bridge (``hardware.bridge``) is the only caller. It calls a driver from one thread, one call
at a time, and turns what it returns into the messages of report section 10 on the rover's keys. So a
driver stays a thin translation of a device's own protocol; it never sees Zenoh, clocks or message models.

Frames and units are those of the rest of LunarSim (``schemas.frames``): metres, degrees; rover-relative
points have +z straight ahead and +x to the right; angles are negative to the left, positive to the right;
headings grow to the right. Pose and action positions are relative to where the driver (or the action)
started: the driver knows nothing of the map.

Timing the bridge relies on:

- every call returns within ``Driver.call_timeout_s`` (``photo`` within ``photo_timeout_s``) or raises
  ``DriverTimeout``: the bridge polls the gyroscope at 20 Hz and the rest at 5 Hz in one loop;
- ``move``/``rotate`` return as soon as the device has accepted (or refused) the action, not when it ends;
- a reading's ``stamp`` is seconds on the driver's own monotonic clock (any origin, one clock for all
  readings); a reading with the stamp of the previous one is the same reading, and is not published again.

A driver is chosen by URL (``hardware.drivers.load_driver``): ``serial:///dev/ttyUSB0?baud=115200&timeout=0.5`` for the
reference serial driver, or ``package.module:Class?key=value`` for any other. Such a class is built with
``Class.from_params(query)`` if it defines it, else ``Class(**query)`` (values are strings).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Literal

from schemas.errors import LunarSimError
from shared.hit import Hit

ActionKind = Literal["move", "rotate"]
Outcome = Literal["running", "completed", "cancelled", "collided"]
RefusalReason = Literal["out_of_view", "out_of_range", "blocked", "action_in_progress", "no_action"]
RadioChannel = Literal["comm_in", "mission_direction", "calibration"]


class DriverError(LunarSimError, RuntimeError):
    """The device failed to do what was asked (not answering, I/O error, an answer that makes no sense)."""


class DriverTimeout(DriverError):
    """The device did not answer within the driver's timeout."""


class ActionRefused(DriverError):
    """The rover will not carry out this action; ``reason`` is the world's ``action_rejected`` reason."""

    def __init__(self, reason: RefusalReason, detail: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason
        self.detail = detail


class InvalidCommand(DriverError, ValueError):
    """A value the interface does not allow (a speed level outside 1..3, a NaN distance)."""


class NotSupported(DriverError):
    """This rover has no such part (no camera, no radio)."""


@dataclass(frozen=True)
class Scan:
    """One perception scan (report 10.1): every hit the rover's vision found in its field of view."""

    stamp: float
    hits: tuple[Hit, ...]


@dataclass(frozen=True)
class Imu:
    """The gyroscope (report 10.3): pitch in degrees, positive nose up."""

    stamp: float
    pitch_deg: float


@dataclass(frozen=True)
class Odometry:
    """The driver's own pose estimate (wheel odometry, IMU heading) relative to where the driver started."""

    stamp: float
    x: float
    z: float
    heading_deg: float
    moving: bool


@dataclass(frozen=True)
class ActionStatus:
    """The latest action (report 10.2): how far it still has to go, and where the rover is relative to its start.

    ``remaining`` is metres (move) or degrees (rotate) still to go and must be 0 once ``outcome`` is not
    ``running``. ``x, z, angle_deg`` are the rover's position and heading change in the frame of the pose
    the action started from: for an action that ended early, this is the report's CancelResult.
    """

    stamp: float
    action_id: int
    action: ActionKind
    outcome: Outcome
    remaining: float
    x: float = 0.0
    z: float = 0.0
    angle_deg: float = 0.0


@dataclass(frozen=True)
class Transmission:
    """A radio transmission received: who sent it, on which channel, and the opaque payload."""

    sender: int
    channel: RadioChannel
    payload: bytes


class Radio(ABC):
    """The rover's radio (report 10.4): send to ids, collect what arrived, say who is in direct range.

    Routing between rovers is the radio's business (the report assumes transitive delivery); 0 is the lander.
    """

    @abstractmethod
    def send(self, targets: list[int], channel: RadioChannel, payload: bytes) -> None:
        """Transmit ``payload`` to every id in ``targets``; delivery is best effort."""

    @abstractmethod
    def receive(self) -> list[Transmission]:
        """Everything received since the last call, oldest first (empty when nothing came)."""

    @abstractmethod
    def partners(self) -> list[int]:
        """Ids in direct range and line of sight now (CommPartners)."""


class Driver(ABC):
    """One real rover. Subclasses talk to a device; see the module docstring for frames and timing."""

    call_timeout_s: float = 1.0
    photo_timeout_s: float = 10.0
    field_of_view_deg: float = 210.0
    """Moves to points outside this view are refused with ``out_of_view`` (report 10.2.1)."""
    radio: Radio | None = None
    """The rover's radio, or None when the radio is not this driver's (the world's radio model serves it)."""

    @abstractmethod
    def perception(self) -> Scan:
        """The latest scan."""

    @abstractmethod
    def imu(self) -> Imu:
        """The latest gyroscope reading."""

    @abstractmethod
    def odometry(self) -> Odometry:
        """The latest pose estimate."""

    @abstractmethod
    def move(self, x: float, z: float) -> int:
        """Start walking to (x, z) relative to the rover; returns the action id.

        Raises ``ActionRefused`` with ``out_of_view``, ``out_of_range``, ``blocked`` or, while another action
        runs, ``action_in_progress``.
        """

    @abstractmethod
    def rotate(self, degrees: float) -> int:
        """Start rotating in place (negative left); returns the action id. Refuses ``action_in_progress``."""

    @abstractmethod
    def cancel(self) -> None:
        """Brake the running action to a stop; its status then ends ``cancelled``. Refuses ``no_action``."""

    @abstractmethod
    def set_speed(self, level: int) -> None:
        """Speed level 1 (slowest) to 3; any other level raises ``InvalidCommand``."""

    @abstractmethod
    def action_status(self) -> ActionStatus | None:
        """Status of the latest action (running or ended), None before the first."""

    def photo(self) -> bytes:
        """A PNG of the forward camera's view (report 10.5); ``NotSupported`` without a camera."""
        raise NotSupported("this driver has no camera")

    def close(self) -> None:  # noqa: B027 - optional: a driver with nothing to release need not define it
        """Release the device; the rover should stop."""


def check_finite(**values: float) -> None:
    """Refuse NaN and infinities before they reach a motor controller."""
    for name, value in values.items():
        if not math.isfinite(value):
            raise InvalidCommand(f"{name} must be a finite number, got {value!r}")
