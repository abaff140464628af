"""The driver bridge: one real rover on exactly the keys the world service uses for a simulated one.

``Bridge`` turns the agent's samples into driver calls and polls the driver into messages, with the world's
semantics (``world_service.sim``): perception and navigation status at 5 Hz, the gyroscope at 20 Hz,
comm_partners at 1 Hz; a status with the remaining distance when an action is accepted, a last one with
remaining 0 and the outcome when it ends, then a CancelResult if it ended early; a move or rotate while one
runs is refused with ``action_in_progress``, a cancel with nothing running with ``no_action``; only the lander
may send on the radio's mission_direction and calibration channels. It also publishes the driver's own
pose estimate on ``telemetry`` for the world's twin mode, and stops the rover when its agent's liveliness
token goes away (the world's watchdog). Like ``RoverAgent`` it returns (key, message) pairs and does no I/O,
so its Zenoh loop (``hardware.runtime``) only moves bytes.

A driver that fails (``DriverError``) is logged and counted, never fatal; an action whose status the driver
cannot give for ``ACTION_LOST_S`` is cancelled and ended, so the agent never waits for nothing. Sensors are
published only while the clock runs (agents act on a running clock only); telemetry always. A photo is taken
in line: the loop waits for it, up to the driver's ``photo_timeout_s``.
"""

from __future__ import annotations

import logging
import time
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from typing import ClassVar, TypeVar

from bus.rejections import Rejections
from hardware.clock import MissionClock
from hardware.driver import ActionRefused, ActionStatus, Driver, DriverError, Transmission
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out

log = logging.getLogger("lunarsim.bridge")

T = TypeVar("T")
M = TypeVar("M", bound=m.Message)

GYROSCOPE_PERIOD_S = 1 / 20
PERCEPTION_PERIOD_S = 1 / 5
STATUS_PERIOD_S = 1 / 5
WATCH_PERIOD_S = 1 / 20
"""How often a running action's status is read, so its end is published within 50 ms."""
TELEMETRY_PERIOD_S = 1 / 5
RADIO_PERIOD_S = 1 / 10
PARTNERS_PERIOD_S = 1.0
CLOCK_PERIOD_S = 1 / 20
ACTION_LOST_S = 3.0
ERRORS_LOGGED = 10
AGENT_TOPICS = (ks.MOVE_ACTION, ks.ROTATE_ACTION, ks.CANCEL_ACTION, ks.SPEED_ACTION, ks.PHOTO_ACTION)


@dataclass
class Flight:
    """The action the driver is carrying out for the agent."""

    action_id: int
    kind: str
    last: ActionStatus | None = None
    last_published: float = 0.0
    failing_since: float | None = None


class Periodic:
    """Due times of the bridge's periodic jobs."""

    def __init__(self, periods: dict[str, float], now: float) -> None:
        self.periods = periods
        self.due = dict.fromkeys(periods, now)

    def take(self, name: str, now: float) -> bool:
        if now < self.due[name]:
            return False
        self.due[name] = max(self.due[name] + self.periods[name], now - self.periods[name])
        return True

    def next_due(self) -> float:
        return min(self.due.values())


class Bridge:
    def __init__(self, driver: Driver, keys: ks.Keyspace, rover_id: int, clock: MissionClock,
                 monotonic: Callable[[], float] = time.monotonic) -> None:
        self.driver, self.keys, self.id, self.clock, self.monotonic = driver, keys, rover_id, clock, monotonic
        periods = {"gyroscope": GYROSCOPE_PERIOD_S, "perception": PERCEPTION_PERIOD_S, "watch": WATCH_PERIOD_S,
                   "telemetry": TELEMETRY_PERIOD_S}
        if driver.radio is not None:
            periods |= {"radio": RADIO_PERIOD_S, "partners": PARTNERS_PERIOD_S}
        if clock.own:
            periods["clock"] = CLOCK_PERIOD_S
        self.periodic = Periodic(periods, monotonic())
        self.flight: Flight | None = None
        self.pitch = 0.0
        self.last_stamp: dict[str, float] = {}
        self.errors: Counter[str] = Counter()
        self.rejected = Rejections(log, f"rover {rover_id}")
        self.agent_present = False

    @property
    def input_topics(self) -> tuple[str, ...]:
        """The rover keys the bridge listens to, as the world does for a simulated rover."""
        return (*AGENT_TOPICS, ks.COMM_OUT) if self.driver.radio is not None else AGENT_TOPICS

    def key(self, topic: str) -> str:
        return self.keys.rover(self.id, topic)

    # ---- from the agent ----

    def handle(self, topic: str, payload: bytes) -> list[Out]:
        """One sample on an input key; a bad one is logged and counted and answered with nothing."""
        handler = self._handlers.get(topic)
        try:
            if handler is None:
                raise ValueError(f"topic {topic!r} is not an input of the bridge")
            return handler(self, codec.decode(m.TOPIC_MODELS[topic], payload))
        except (codec.DecodeError, ValueError) as exc:
            self.rejected.count(topic, exc)
            return []

    def _on_move(self, msg: m.MoveAction) -> list[Out]:
        return self._start("move", lambda: self.driver.move(msg.x, msg.z), abs(complex(msg.x, msg.z)))

    def _on_rotate(self, msg: m.RotateAction) -> list[Out]:
        return self._start("rotate", lambda: self.driver.rotate(msg.degrees), abs(msg.degrees))

    def _start(self, kind: str, start: Callable[[], int], remaining: float) -> list[Out]:
        if self.flight is not None:
            return [self._reject(kind, "action_in_progress", "a move or rotate is still running")]
        try:
            action_id = start()
        except ActionRefused as exc:
            return [self._reject(kind, exc.reason, exc.detail)]
        except DriverError as exc:
            self._driver_failed(kind, exc)
            return [self._reject(kind, "blocked", f"the driver failed: {exc}")]
        self.flight = Flight(action_id, kind, last_published=self.monotonic())
        return [self._status(kind, remaining)]

    def _on_cancel_action(self, msg: m.CancelAction) -> list[Out]:
        if self.flight is None:
            return [self._reject("cancel", "no_action", "nothing to cancel")]
        self._call("cancel", self.driver.cancel)
        return []

    def _on_speed(self, msg: m.SpeedAction) -> list[Out]:
        self._call("speed", lambda: self.driver.set_speed(msg.level))
        return []

    def _on_photo(self, msg: m.PhotoAction) -> list[Out]:
        try:
            png = self.driver.photo()
        except DriverError as exc:
            self._driver_failed("photo", exc)
            return [self._reject("photo", "blocked", f"no photo: {exc}")]
        photo = self._checked("photo", lambda: m.Photo(stamp=self.clock.now(), label=msg.label, png=png))
        if photo is None:
            return [self._reject("photo", "blocked", "the driver's photo is not a PNG the interface allows")]
        return [(self.key(ks.PHOTO), photo)]

    def _on_comm_out(self, msg: m.OutboundComm) -> list[Out]:
        if msg.channel != "comm_in":
            raise ValueError(f"only the lander may transmit on channel {msg.channel!r}")
        self._call("radio send", lambda: self.driver.radio.send(list(msg.targets), msg.channel, msg.payload))
        return []

    _handlers: ClassVar[dict[str, Callable]] = {
        ks.MOVE_ACTION: _on_move,
        ks.ROTATE_ACTION: _on_rotate,
        ks.CANCEL_ACTION: _on_cancel_action,
        ks.SPEED_ACTION: _on_speed,
        ks.PHOTO_ACTION: _on_photo,
        ks.COMM_OUT: _on_comm_out,
    }

    def agent_alive(self, alive: bool) -> None:
        """Watchdog: the agent's token went away, so its rover stops where it is (as the world does)."""
        if self.agent_present and not alive and self.flight is not None:
            log.warning("rover %d: the agent is gone; stopping the rover", self.id)
            self._call("cancel", self.driver.cancel)
        self.agent_present = alive

    # ---- from the driver ----

    def poll(self) -> list[Out]:
        """Do the periodic jobs that are due; returns what to publish."""
        now, out = self.monotonic(), []
        if self.periodic.take("watch", now) and self.flight is not None:
            out += self._watch(now)
        running = self.clock.running()
        if self.periodic.take("gyroscope", now) and running:
            out += self._gyroscope()
        if self.periodic.take("perception", now) and running:
            out += self._perception()
        if self.periodic.take("telemetry", now):
            out += self._telemetry()
        if "radio" in self.periodic.due and self.periodic.take("radio", now):
            out += self._radio_in()
        if "partners" in self.periodic.due and self.periodic.take("partners", now) and running:
            ids = self._call("radio partners", self.driver.radio.partners)
            partners = None if ids is None else self._checked("radio partners", lambda: m.CommPartners(ids=ids))
            out += [] if partners is None else [(self.key(ks.COMM_PARTNERS), partners)]
        if "clock" in self.periodic.due and self.periodic.take("clock", now):
            out.append((self.keys.clock, self.clock.next_tick()))
        return out

    def seconds_to_next(self) -> float:
        return max(0.0, self.periodic.next_due() - self.monotonic())

    def _fresh(self, name: str, stamp: float) -> bool:
        """A reading not seen before; a driver whose stamps go backwards is counted as failing."""
        last = self.last_stamp.get(name)
        if last is not None and stamp <= last:
            if stamp < last:
                self._driver_failed(name, DriverError(f"stamp went back from {last} to {stamp}"))
            return False
        self.last_stamp[name] = stamp
        return True

    def _gyroscope(self) -> list[Out]:
        imu = self._call("gyroscope", self.driver.imu)
        if imu is None or not self._fresh("gyroscope", imu.stamp):
            return []
        msg = self._checked("gyroscope", lambda: m.Gyroscope(stamp=self.clock.now(), pitch_deg=imu.pitch_deg))
        if msg is None:
            return []
        self.pitch = imu.pitch_deg
        return [(self.key(ks.GYROSCOPE), msg)]

    def _perception(self) -> list[Out]:
        scan = self._call("perception", self.driver.perception)
        if scan is None or not self._fresh("perception", scan.stamp):
            return []
        msg = self._checked("perception", lambda: m.Perception(
            stamp=self.clock.now(), angles_deg=[h.angle_deg for h in scan.hits],
            distances_m=[h.distance_m for h in scan.hits], kinds=[h.kind for h in scan.hits]))
        return [] if msg is None else [(self.key(ks.PERCEPTION), msg)]

    def _telemetry(self) -> list[Out]:
        odo = self._call("odometry", self.driver.odometry)
        if odo is None or not self._fresh("odometry", odo.stamp):
            return []
        msg = self._checked("odometry", lambda: m.Telemetry(stamp=self.clock.now(), x=odo.x, z=odo.z,
                                                            heading_deg=odo.heading_deg, pitch_deg=self.pitch,
                                                            moving=odo.moving))
        return [] if msg is None else [(self.key(ks.TELEMETRY), msg)]

    def _radio_in(self) -> list[Out]:
        received = self._call("radio receive", self.driver.radio.receive) or []
        return [out for t in received for out in self._delivery(t)]

    def _delivery(self, t: Transmission) -> list[Out]:
        """Where the world would deliver a transmission: comm_in as InboundComm, the lander's channels as is."""
        try:
            if t.channel == "comm_in":
                return [(self.key(ks.COMM_IN), codec.checked(m.InboundComm(sender=t.sender, payload=t.payload)))]
            if t.sender != ks.LANDER_ID:
                raise ValueError(f"rover {t.sender} may not send on channel {t.channel!r}")
            return [(self.key(t.channel), codec.decode(m.RADIO_CHANNEL_MODELS[t.channel], t.payload))]
        except (codec.DecodeError, ValueError, KeyError) as exc:
            self.rejected.count(f"radio {t.channel}", exc)
            return []

    # ---- the action in flight ----

    def _watch(self, now: float) -> list[Out]:
        flight = self.flight
        try:
            status = self.driver.action_status()
        except DriverError as exc:
            self._driver_failed("navigation status", exc)
            flight.failing_since = flight.failing_since or now
            return self._lost("its status cannot be read") if now - flight.failing_since > ACTION_LOST_S else []
        flight.failing_since = None
        if status is None or status.action_id != flight.action_id:
            return self._lost(f"the driver reports {'no action' if status is None else 'another action'}")
        flight.last = status
        if status.outcome != "running":
            return self._ended(status.outcome, status)
        if now - flight.last_published >= STATUS_PERIOD_S:
            flight.last_published = now
            return [self._status(flight.kind, status.remaining)]
        return []

    def _lost(self, why: str) -> list[Out]:
        log.error("rover %d: lost track of %s %d (%s); stopping it and ending it as cancelled", self.id,
                  self.flight.kind, self.flight.action_id, why)
        self._call("cancel", self.driver.cancel)
        return self._ended("cancelled", self.flight.last)

    def _ended(self, outcome: str, status: ActionStatus | None) -> list[Out]:
        kind = self.flight.kind
        self.flight = None
        out: list[Out] = [(self.key(ks.NAVIGATION_STATUS), m.NavigationStatus(
            stamp=self.clock.now(), action=kind, remaining=0.0, outcome=outcome))]
        if outcome != "completed":
            x, z, angle = (status.x, status.z, status.angle_deg) if status is not None else (0.0, 0.0, 0.0)
            out.append((self.key(ks.CANCEL_RESULT), m.CancelResult(x=x, z=z, angle_deg=angle, reason=outcome)))
        return out

    def _status(self, kind: str, remaining: float) -> Out:
        return self.key(ks.NAVIGATION_STATUS), m.NavigationStatus(stamp=self.clock.now(), action=kind,
                                                                  remaining=round(max(0.0, remaining), 4))

    def _reject(self, action: str, reason: str, detail: str) -> Out:
        return self.key(ks.ACTION_REJECTED), m.ActionRejected(action=action, reason=reason, detail=detail)

    # ---- driver failures ----

    def _call(self, what: str, fn: Callable[[], T]) -> T | None:
        try:
            return fn()
        except DriverError as exc:
            self._driver_failed(what, exc)
            return None

    def _checked(self, what: str, build: Callable[[], M]) -> M | None:
        """The message ``build`` makes of the driver's values, checked as a receiver would (a Struct does not check
        its bounds when built): a kind or number the interface does not allow is the driver's failure, not a
        sample."""
        try:
            return codec.checked(build())
        except ValueError as exc:  # codec.DecodeError, or a message's own cross-field rule
            self._driver_failed(what, DriverError(f"invalid {what}: {exc}"))
            return None

    def _driver_failed(self, what: str, exc: Exception) -> None:
        """Count every failure; log the first few of each kind, then every hundredth."""
        self.errors[what] += 1
        n = self.errors[what]
        if n <= ERRORS_LOGGED or n % 100 == 0:
            log.warning("rover %d: driver failed (%s, #%d): %s", self.id, what, n, exc)
