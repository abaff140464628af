"""The driver contract checker: drive a hardware driver through the interface and list what it violates.

The rules are the driver interface's (``hardware.driver``), checked on the rover itself: readings
have valid values and increasing stamps; speed levels 1..3 are accepted and others refused; a move straight
ahead is accepted, refused while running, reports its remaining distance falling to exactly 0, and ends
where odometry says; level 1 is slower than level 3; a rotate turns by what was asked; a cancelled move ends
``cancelled`` where its status and odometry agree; a move behind is refused; the radio echoes (with
``--radio-echo ID``); the camera gives a PNG. Every call must return within the driver's time bound.
The rover walks about 5 m straight ahead and turns on the spot: give it clear ground.
Each violated rule is printed with what was seen (``hardware.commands.check_driver`` is the command line).
"""

from __future__ import annotations

import itertools
import math
import os
import struct
import time
from collections.abc import Callable
from typing import TypeVar

from hardware.driver import (
    ActionRefused,
    ActionStatus,
    Driver,
    DriverError,
    InvalidCommand,
    NotSupported,
    Odometry,
)
from schemas.errors import LunarSimError
from schemas.frames import to_relative, wrap_deg
from schemas.messages import HIT_KINDS

T = TypeVar("T")
MOVE_M = 1.5
CANCEL_MOVE_M = 4.0
TURN_DEG = 45.0
POSITION_TOLERANCE_M = 0.3
AGREEMENT_TOLERANCE_M = 0.2
ANGLE_TOLERANCE_DEG = 5.0
ACTION_TIMEOUT_S = 20.0
SLACK_S = 0.2
"""A call may overrun its bound by this much (scheduling) before it counts as too slow."""


class Violation(LunarSimError):
    """A rule broken badly enough that the rest of a step makes no sense."""


class Checker:
    def __init__(self, driver: Driver, radio_echo: int | None = None, say: Callable[[str], None] = print) -> None:
        self.driver, self.radio_echo, self.say = driver, radio_echo, say
        self.violations: list[str] = []
        self.passed = 0
        self.slow: set[str] = set()

    def rule(self, ok: bool, rule: str, saw: str = "") -> bool:
        if ok:
            self.passed += 1
        else:
            self.violations.append(f"{rule}: {saw}" if saw else rule)
            self.say(f"violation: {rule}" + (f": saw {saw}" if saw else ""))
        return ok

    def call(self, what: str, fn: Callable[[], T], bound: float | None = None) -> T:
        """Call the driver, checking its time bound."""
        limit = self.driver.call_timeout_s if bound is None else bound
        start = time.monotonic()
        try:
            return fn()
        finally:
            took = time.monotonic() - start
            if took > limit + SLACK_S and what not in self.slow:  # each slow call once, not every time
                self.slow.add(what)
                self.rule(False, f"{what} returns within {limit:g} s", f"{took:.2f} s")

    def run(self) -> list[str]:
        steps = [("gyroscope", self.check_gyroscope), ("perception", self.check_perception),
                 ("odometry", self.check_odometry), ("speed", self.check_speed), ("move", self.check_moves),
                 ("rotate", self.check_rotate), ("cancel", self.check_cancel), ("view", self.check_out_of_view),
                 ("radio", self.check_radio), ("camera", self.check_camera)]
        for name, step in steps:
            try:
                step()
            except Violation as exc:
                self.rule(False, f"{name}", str(exc))
            except DriverError as exc:
                self.rule(False, f"{name}: the driver fails", f"{type(exc).__name__}: {exc}")
        return self.violations

    # ---- readings ----

    def _stamps(self, what: str, stamps: list[float]) -> None:
        back = [(a, b) for a, b in itertools.pairwise(stamps) if b < a]
        self.rule(not back, f"{what} stamps never go back", f"{back[0][0]} then {back[0][1]}" if back else "")
        self.rule(stamps[-1] > stamps[0], f"{what} stamps increase over time", f"{stamps[0]} .. {stamps[-1]}")
        self.rule(all(math.isfinite(s) for s in stamps), f"{what} stamps are finite", str(stamps[:3]))

    def check_gyroscope(self) -> None:
        readings = []
        for _ in range(10):
            readings.append(self.call("imu", self.driver.imu))
            time.sleep(0.05)
        bad = [r.pitch_deg for r in readings if not (math.isfinite(r.pitch_deg) and -90 <= r.pitch_deg <= 90)]
        self.rule(not bad, "gyroscope pitch is a finite angle in [-90, 90] degrees", str(bad[:3]))
        self._stamps("gyroscope", [r.stamp for r in readings])

    def check_perception(self) -> None:
        scans = []
        for _ in range(5):
            scans.append(self.call("perception", self.driver.perception))
            time.sleep(0.2)
        hits = [h for s in scans for h in s.hits]
        half = self.driver.field_of_view_deg / 2 + 1.0
        self.rule(all(h.kind in HIT_KINDS for h in hits), f"perception kinds are among {', '.join(HIT_KINDS)}",
                  str(sorted({h.kind for h in hits} - set(HIT_KINDS))))
        wide = [h.angle_deg for h in hits if not (math.isfinite(h.angle_deg) and abs(h.angle_deg) <= half)]
        self.rule(not wide, f"perception angles lie in the {self.driver.field_of_view_deg:g} degree view",
                  str(wide[:3]))
        far = [h.distance_m for h in hits if not (math.isfinite(h.distance_m) and h.distance_m > 0)]
        self.rule(not far, "perception distances are positive metres", str(far[:3]))
        self._stamps("perception", [s.stamp for s in scans])

    def check_odometry(self) -> None:
        readings = []
        for _ in range(3):
            readings.append(self.call("odometry", self.driver.odometry))
            time.sleep(0.1)
        values = [v for r in readings for v in (r.x, r.z, r.heading_deg)]
        self.rule(all(math.isfinite(v) for v in values), "odometry is finite", str(values[:3]))
        self.rule(not readings[-1].moving, "odometry says not moving while idle", str(readings[-1]))
        self._stamps("odometry", [r.stamp for r in readings])
        status = self.call("action_status", self.driver.action_status)
        self.rule(status is None or status.outcome != "running", "no action runs before the first one",
                  str(status))

    def check_speed(self) -> None:
        for level in (1, 2, 3):
            try:
                self.call(f"set_speed({level})", lambda lv=level: self.driver.set_speed(lv))
                self.rule(True, f"speed level {level} is accepted")
            except DriverError as exc:
                self.rule(False, f"speed level {level} is accepted", f"{type(exc).__name__}: {exc}")
        for level in (0, 4):
            try:
                self.call(f"set_speed({level})", lambda lv=level: self.driver.set_speed(lv))
                self.rule(False, f"speed level {level} is refused with InvalidCommand", "accepted")
            except InvalidCommand:
                self.rule(True, f"speed level {level} is refused")
            except DriverError as exc:
                self.rule(False, f"speed level {level} is refused with InvalidCommand", f"{type(exc).__name__}")

    # ---- actions ----

    def _start(self, what: str, fn: Callable[[], int]) -> int:
        try:
            action_id = self.call(what, fn)
        except ActionRefused as exc:
            raise Violation(f"{what} was refused ({exc.reason}: {exc.detail}); the check needs clear ground") from None
        if not isinstance(action_id, int):
            raise Violation(f"{what} returned {action_id!r}, not an action id")
        return action_id

    def _follow(self, what: str, action_id: int, kind: str,
                on_status: Callable[[ActionStatus], None] | None = None) -> tuple[list[ActionStatus], list[Odometry]]:
        """Poll status and odometry until the action ends; returns both series."""
        statuses, odometry = [], []
        deadline = time.monotonic() + ACTION_TIMEOUT_S
        while time.monotonic() < deadline:
            status = self.call("action_status", self.driver.action_status)
            odometry.append(self.call("odometry", self.driver.odometry))
            if status is None or status.action_id != action_id or status.action != kind:
                raise Violation(f"{what}: status names {status}, expected {kind} {action_id}")
            statuses.append(status)
            if status.outcome != "running":
                return statuses, odometry
            if on_status is not None:
                on_status(status)
            time.sleep(0.05)
        raise Violation(f"{what}: still running after {ACTION_TIMEOUT_S:g} s (last status {statuses[-1]})")

    def _ended_at_zero(self, what: str, statuses: list[ActionStatus], outcome: str) -> ActionStatus:
        last = statuses[-1]
        self.rule(last.outcome == outcome, f"{what} ends {outcome}", last.outcome)
        self.rule(last.remaining == 0, f"{what}: the last status has remaining 0", f"{last.remaining}")
        return last

    def _agrees(self, what: str, start: Odometry, end: Odometry, status: ActionStatus, tolerance: float) -> None:
        """Odometry's displacement, in the action's start frame, against the status's position."""
        ox, oz = to_relative(start.x, start.z, start.heading_deg, end.x, end.z)
        off = math.hypot(ox - status.x, oz - status.z)
        self.rule(off <= tolerance, f"{what}: the status's end position agrees with odometry",
                  f"status ({status.x:.2f}, {status.z:.2f}), odometry ({ox:.2f}, {oz:.2f})")
        turn = wrap_deg(end.heading_deg - start.heading_deg)
        self.rule(abs(wrap_deg(turn - status.angle_deg)) <= ANGLE_TOLERANCE_DEG,
                  f"{what}: the status's angle agrees with odometry", f"status {status.angle_deg:.1f}, "
                  f"odometry {turn:.1f} degrees")

    def _move_ahead(self, level: int) -> float:
        """One move straight ahead at a speed level; returns how long it took."""
        what = f"move {MOVE_M:g} m ahead at speed {level}"
        self.call("set_speed", lambda: self.driver.set_speed(level))
        start = self.call("odometry", self.driver.odometry)
        t0 = time.monotonic()
        action_id = self._start(what, lambda: self.driver.move(0.0, MOVE_M))
        if level == 3:
            self._refused_while_running()
        statuses, odometry = self._follow(what, action_id, "move")
        took = time.monotonic() - t0
        first = statuses[0].remaining
        self.rule(abs(first - MOVE_M) <= 0.25 * MOVE_M + 0.1, f"{what}: remaining starts at about {MOVE_M:g} m",
                  f"{first}")
        rises = [(a.remaining, b.remaining) for a, b in itertools.pairwise(statuses)
                 if b.outcome == "running" and b.remaining > a.remaining + 0.2]
        self.rule(not rises, f"{what}: remaining does not grow", str(rises[:2]))
        self.rule(any(o.moving for o in odometry[:-1]) or len(odometry) < 3, f"{what}: odometry says moving",
                  "never")
        last = self._ended_at_zero(what, statuses, "completed")
        self.rule(math.hypot(last.x, last.z - MOVE_M) <= POSITION_TOLERANCE_M, f"{what}: ends on its goal",
                  f"({last.x:.2f}, {last.z:.2f})")
        self._agrees(what, start, self.call("odometry", self.driver.odometry), last, AGREEMENT_TOLERANCE_M)
        return took

    def _refused_while_running(self) -> None:
        try:
            self.call("move while moving", lambda: self.driver.move(0.0, 1.0))
            self.rule(False, "a move while another runs is refused (action_in_progress)", "accepted")
        except ActionRefused as exc:
            self.rule(exc.reason == "action_in_progress", "a move while another runs is refused as "
                      "action_in_progress", exc.reason)

    def check_moves(self) -> None:
        fast = self._move_ahead(3)
        slow = self._move_ahead(1)
        self.rule(slow > fast * 1.2, "speed level 1 is slower than level 3",
                  f"level 1 took {slow:.2f} s, level 3 {fast:.2f} s for {MOVE_M:g} m")

    def check_rotate(self) -> None:
        for degrees in (TURN_DEG, -TURN_DEG):
            what = f"rotate {degrees:+g} degrees"
            start = self.call("odometry", self.driver.odometry)
            statuses, _ = self._follow(what, self._start(what, lambda d=degrees: self.driver.rotate(d)), "rotate")
            first = statuses[0].remaining
            self.rule(first <= abs(degrees) + ANGLE_TOLERANCE_DEG, f"{what}: remaining is in degrees", f"{first}")
            last = self._ended_at_zero(what, statuses, "completed")
            self.rule(abs(last.angle_deg - degrees) <= ANGLE_TOLERANCE_DEG, f"{what}: turns by what was asked",
                      f"{last.angle_deg:.1f}")
            self._agrees(what, start, self.call("odometry", self.driver.odometry), last, AGREEMENT_TOLERANCE_M)

    def check_cancel(self) -> None:
        what = f"cancel a {CANCEL_MOVE_M:g} m move"
        self.call("set_speed", lambda: self.driver.set_speed(1))
        start = self.call("odometry", self.driver.odometry)
        action_id = self._start(what, lambda: self.driver.move(0.0, CANCEL_MOVE_M))
        cancelled: list[bool] = []

        def cancel_once_under_way(status: ActionStatus) -> None:
            if not cancelled and status.remaining <= CANCEL_MOVE_M - 0.5:
                self.call("cancel", self.driver.cancel)
                cancelled.append(True)

        statuses, _ = self._follow(what, action_id, "move", cancel_once_under_way)
        last = self._ended_at_zero(what, statuses, "cancelled")
        self.rule(0.0 < last.z < CANCEL_MOVE_M - 0.1, f"{what}: stops part way", f"z = {last.z:.2f} m")
        self._agrees(what, start, self.call("odometry", self.driver.odometry), last, AGREEMENT_TOLERANCE_M)
        try:
            self.call("cancel", self.driver.cancel)
            self.rule(False, "a cancel with nothing running is refused (no_action)", "accepted")
        except ActionRefused as exc:
            self.rule(exc.reason == "no_action", "a cancel with nothing running is refused as no_action", exc.reason)

    def check_out_of_view(self) -> None:
        if self.driver.field_of_view_deg >= 360:
            return
        try:
            action_id = self.call("move behind", lambda: self.driver.move(0.0, -2.0))
        except ActionRefused as exc:
            self.rule(exc.reason == "out_of_view", "a move behind the rover is refused as out_of_view", exc.reason)
            return
        self.rule(False, "a move behind the rover is refused as out_of_view", f"accepted as action {action_id}")
        self.call("cancel", self.driver.cancel)
        self._follow("move behind", action_id, "move")

    # ---- radio and camera ----

    def check_radio(self) -> None:
        radio = self.driver.radio
        if radio is None:
            self.say("note: the driver has no radio")
            return
        ids = self.call("radio partners", radio.partners)
        self.rule(isinstance(ids, list) and all(isinstance(i, int) and i >= 0 for i in ids),
                  "radio partners are ids (0 the lander)", repr(ids))
        if self.radio_echo is None:
            self.say("note: no --radio-echo ID given: radio round trip not checked")
            return
        nonce = os.urandom(8)
        self.call("radio send", lambda: radio.send([self.radio_echo], "comm_in", nonce))
        deadline, got = time.monotonic() + 3.0, []
        while time.monotonic() < deadline and not any(t.payload == nonce for t in got):
            got += self.call("radio receive", radio.receive)
            time.sleep(0.05)
        echo = [t for t in got if t.payload == nonce]
        self.rule(bool(echo) and echo[0].sender == self.radio_echo and echo[0].channel == "comm_in",
                  f"radio round trip through {self.radio_echo}", str(echo[:1] or got[:3] or "nothing in 3 s"))

    def check_camera(self) -> None:
        try:
            png = self.call("photo", self.driver.photo, self.driver.photo_timeout_s)
        except NotSupported:
            self.say("note: the driver has no camera")
            return
        ok = isinstance(png, bytes) and png[:8] == b"\x89PNG\r\n\x1a\n" and png[12:16] == b"IHDR"
        size = struct.unpack(">II", png[16:24]) if ok and len(png) >= 24 else (0, 0)
        self.rule(ok and min(size) > 0, "the camera gives a PNG", f"{png[:16]!r}... size {size}")
