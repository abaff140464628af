"""The reference driver: a differential-drive base with an IMU, speaking ``protocol`` over a serial port.

``LineClient`` does the request/response over any pyserial-like port; ``SerialDriver`` maps the driver
interface onto the protocol's verbs. A device that does not answer raises ``DriverTimeout`` naming the port
and the request; a garbled line (noise, a device reset mid-line, a wrong baud rate) is logged and counted
and the client keeps reading for the answer until its deadline; a late answer to an earlier request is
recognised by its sequence number and dropped. Only this module imports pyserial.
"""

from __future__ import annotations

import base64
import binascii
import logging
import time
from typing import Protocol

import serial

from hardware import protocol as p
from hardware.driver import (
    ActionRefused,
    ActionStatus,
    Driver,
    DriverError,
    DriverTimeout,
    Imu,
    InvalidCommand,
    NotSupported,
    Odometry,
    Radio,
    RadioChannel,
    Scan,
    Transmission,
    check_finite,
)
from schemas.messages import HIT_KINDS
from shared.hit import Hit

log = logging.getLogger("lunarsim.hardware.serial")

READ_SLICE_S = 0.05
"""The port's read timeout: how long one read waits for the first byte before the deadline is looked at."""
REFUSALS = {"out_of_view": "out_of_view", "out_of_range": "out_of_range", "blocked": "blocked",
            "busy": "action_in_progress", "no_action": "no_action"}
RADIO_CHANNELS = ("comm_in", "mission_direction", "calibration")
GARBLED_LOGGED = 10
RX_PER_CALL = 32
"""At most this many transmissions fetched per ``receive`` call, so one call stays within its time bound."""


class Port(Protocol):
    """What ``LineClient`` needs of a port (pyserial's ``Serial`` has it)."""

    in_waiting: int

    def read(self, size: int) -> bytes: ...

    def write(self, data: bytes) -> int | None: ...


class LineClient:
    """Numbered requests and their answers over a byte stream, with a deadline per request."""

    def __init__(self, port: Port, timeout_s: float, name: str) -> None:
        self.port, self.timeout_s, self.name = port, timeout_s, name
        self.seq = 0
        self.garbled = 0
        self.stale = 0
        self._buffer = b""
        self._skipping = False  # inside an overlong line: drop up to its end

    def request(self, verb: str, *args: str, timeout_s: float | None = None) -> p.Reply:
        """Send one request and return its answer (OK or ERR); ``DriverTimeout`` when none comes in time."""
        self.seq = self.seq % p.MAX_SEQ + 1
        seq, limit = self.seq, self.timeout_s if timeout_s is None else timeout_s
        try:
            self.port.write(p.format_request(seq, verb, *args))
        except (OSError, serial.SerialException) as exc:
            raise DriverError(f"{self.name}: cannot send {verb}: {exc}") from None
        deadline = time.monotonic() + limit
        while True:
            line = self._read_line(deadline)
            if line is None:
                raise DriverTimeout(f"{self.name}: no answer to {verb} within {limit:g} s (is the device on, "
                                    "and is the baud rate right?)")
            reply = self._parse(line)
            if reply is None:
                continue
            if reply.seq == seq:
                return reply
            self.stale += 1
            log.info("%s: dropped a late answer to request %d (waiting for %d)", self.name, reply.seq, seq)

    def _parse(self, line: bytes) -> p.Reply | None:
        try:
            return p.parse_reply(line)
        except p.GarbledLine as exc:
            self._count_garbled(str(exc))
            return None

    def _count_garbled(self, why: str) -> None:
        """Count every garbled line; log the first ten, then every hundredth, so a noisy line does not flood the log."""
        self.garbled += 1
        if self.garbled <= GARBLED_LOGGED or self.garbled % 100 == 0:
            log.warning("%s: garbled line #%d ignored: %s", self.name, self.garbled, why)

    def _read_line(self, deadline: float) -> bytes | None:
        while b"\n" not in self._buffer:
            if time.monotonic() >= deadline:
                return None
            try:
                chunk = self.port.read(max(1, self.port.in_waiting))
            except (OSError, serial.SerialException) as exc:
                raise DriverError(f"{self.name}: read failed: {exc}") from None
            self._buffer += chunk
            if len(self._buffer) > p.MAX_LINE and b"\n" not in self._buffer:
                self._overlong()
        line, _, self._buffer = self._buffer.partition(b"\n")
        if self._skipping:
            self._skipping = False
            return self._read_line(deadline)
        return line + b"\n"

    def _overlong(self) -> None:
        self._count_garbled(f"more than {p.MAX_LINE} bytes without a newline")
        self._buffer, self._skipping = b"", True


def expect_ok(reply: p.Reply, verb: str) -> tuple[str, ...]:
    """The fields of an OK answer; an ERR becomes the driver interface's exception for it."""
    if reply.ok:
        return reply.fields
    if reply.code in REFUSALS:
        raise ActionRefused(REFUSALS[reply.code], reply.detail)
    if reply.code in ("bad_value", "bad_request"):
        raise InvalidCommand(f"{verb}: device says {reply.code}: {reply.detail}")
    if reply.code == "unsupported":
        raise NotSupported(f"{verb}: {reply.detail or 'not supported by the device'}")
    raise DriverError(f"{verb}: device error {reply.code}: {reply.detail}")


def _fields(reply: p.Reply, verb: str, count: int) -> tuple[str, ...]:
    fields = expect_ok(reply, verb)
    if len(fields) != count:
        raise DriverError(f"{verb}: expected {count} fields, got {len(fields)}: {' '.join(fields)[:80]!r}")
    return fields


def _decode_b64(text: str, what: str) -> bytes:
    try:
        return base64.b64decode(text, validate=True)
    except (binascii.Error, ValueError):
        raise DriverError(f"{what}: not base64: {text[:40]!r}") from None


def parse_hit(field: str) -> Hit:
    if field.count(":") != 2 or field.split(":")[2] not in HIT_KINDS:
        raise p.GarbledLine(f"hit {field!r}: expected <angle>:<distance>:<kind> with kind one of {HIT_KINDS}")
    angle, distance, kind = field.split(":")
    return Hit(p.number(angle, "hit angle"), p.number(distance, "hit distance"), kind)


def parse_status(fields: tuple[str, ...]) -> ActionStatus | None:
    if len(fields) == 2 and fields[1] == "NONE":
        return None
    if len(fields) != 8 or fields[2] not in ("move", "rotate") or \
            fields[3] not in ("running", "completed", "cancelled", "collided") or not fields[1].isdigit():
        raise p.GarbledLine(f"STATUS?: unexpected answer {' '.join(fields)[:80]!r}")
    x, z, angle = (p.number(f, name) for f, name in zip(fields[5:], ("x", "z", "angle"), strict=True))
    return ActionStatus(p.number(fields[0], "stamp"), int(fields[1]), fields[2], fields[3],
                        p.number(fields[4], "remaining"), x, z, angle)


class SerialRadio(Radio):
    def __init__(self, client: LineClient) -> None:
        self.client = client

    def send(self, targets: list[int], channel: RadioChannel, payload: bytes) -> None:
        if channel not in RADIO_CHANNELS:
            raise InvalidCommand(f"radio channel {channel!r} is not one of {RADIO_CHANNELS}")
        expect_ok(self.client.request("TX", channel, p.format_ids(targets), base64.b64encode(payload).decode()
                                      or "="), "TX")

    def receive(self) -> list[Transmission]:
        received: list[Transmission] = []
        for _ in range(RX_PER_CALL):
            fields = expect_ok(self.client.request("RX?"), "RX?")
            if fields == ("NONE",):
                break
            if len(fields) != 3 or fields[1] not in RADIO_CHANNELS or not fields[0].isdigit():
                raise DriverError(f"RX?: unexpected answer {' '.join(fields)[:80]!r}")
            payload = b"" if fields[2] == "=" else _decode_b64(fields[2], "RX? payload")
            received.append(Transmission(int(fields[0]), fields[1], payload))
        return received

    def partners(self) -> list[int]:
        return _guard(lambda: p.parse_ids(_fields(self.client.request("LINKS?"), "LINKS?", 1)[0]))


def _guard(parse):
    """A well-formed line whose fields make no sense is a garbled answer: a ``DriverError``, not a crash."""
    try:
        return parse()
    except p.GarbledLine as exc:
        raise DriverError(f"garbled answer: {exc}") from None


class SerialDriver(Driver):
    """The driver interface over ``protocol``; ``from_params`` builds it from a ``serial://`` URL's query."""

    def __init__(self, port: str, baud: int = 115200, timeout_s: float = 0.5) -> None:
        try:
            self.serial = serial.Serial(port, baud, timeout=READ_SLICE_S, write_timeout=timeout_s)
        except (serial.SerialException, ValueError) as exc:
            raise DriverError(f"cannot open serial port {port}: {exc}") from None
        self.port = port
        self.client = LineClient(self.serial, timeout_s, port)
        self.call_timeout_s = timeout_s
        try:
            self.device, self.capabilities = self._hello()
        except DriverError:
            self.serial.close()
            raise
        self.field_of_view_deg = float(self.capabilities.get("fov", self.field_of_view_deg))
        self.radio = SerialRadio(self.client) if self.capabilities.get("radio") == "1" else None

    @classmethod
    def from_params(cls, params: dict[str, str]) -> SerialDriver:
        known = {"port", "baud", "timeout"}
        if set(params) - known:
            raise InvalidCommand(f"serial driver: unknown option(s) {sorted(set(params) - known)}; "
                                 f"known: {sorted(known)}")
        try:
            return cls(params["port"], int(params.get("baud", 115200)), float(params.get("timeout", 0.5)))
        except ValueError as exc:
            raise InvalidCommand(f"serial driver: bad option value: {exc}") from None

    def _hello(self) -> tuple[str, dict[str, str]]:
        try:
            fields = expect_ok(self.client.request("HELLO?"), "HELLO?")
        except DriverTimeout:
            raise DriverTimeout(f"the device on {self.port} does not answer HELLO? within {self.call_timeout_s:g} s "
                                "(wrong port, device off, or a baud rate mismatch)") from None
        if len(fields) < 2:
            raise DriverError(f"HELLO?: expected '<device> <version> [key=value...]', got {' '.join(fields)!r}")
        caps = dict(f.partition("=")[::2] for f in fields[2:])
        return f"{fields[0]} {fields[1]}", caps

    def perception(self) -> Scan:
        fields = expect_ok(self.client.request("SCAN?"), "SCAN?")
        if not fields:
            raise DriverError("SCAN?: empty answer, expected a stamp")
        return _guard(lambda: Scan(p.number(fields[0], "stamp"), tuple(parse_hit(f) for f in fields[1:])))

    def imu(self) -> Imu:
        stamp, pitch = _fields(self.client.request("IMU?"), "IMU?", 2)
        return _guard(lambda: Imu(p.number(stamp, "stamp"), p.number(pitch, "pitch")))

    def odometry(self) -> Odometry:
        stamp, x, z, heading, moving = _fields(self.client.request("POSE?"), "POSE?", 5)
        return _guard(lambda: Odometry(p.number(stamp, "stamp"), p.number(x, "x"), p.number(z, "z"),
                                       p.number(heading, "heading"), moving == "1"))

    def move(self, x: float, z: float) -> int:
        check_finite(x=x, z=z)
        return self._action_id(self.client.request("MOVE", p.fmt(x), p.fmt(z)), "MOVE")

    def rotate(self, degrees: float) -> int:
        check_finite(degrees=degrees)
        return self._action_id(self.client.request("ROT", p.fmt(degrees)), "ROT")

    def _action_id(self, reply: p.Reply, verb: str) -> int:
        (action_id,) = _fields(reply, verb, 1)
        if not action_id.isdigit():
            raise DriverError(f"{verb}: action id {action_id!r} is not a number")
        return int(action_id)

    def cancel(self) -> None:
        expect_ok(self.client.request("CANCEL"), "CANCEL")

    def set_speed(self, level: int) -> None:
        if level not in (1, 2, 3):
            raise InvalidCommand(f"speed level must be 1, 2 or 3, got {level!r}")
        expect_ok(self.client.request("SPEED", str(level)), "SPEED")

    def action_status(self) -> ActionStatus | None:
        fields = expect_ok(self.client.request("STATUS?"), "STATUS?")
        return _guard(lambda: parse_status(fields))

    def photo(self) -> bytes:
        (data,) = _fields(self.client.request("PHOTO", timeout_s=self.photo_timeout_s), "PHOTO", 1)
        return _decode_b64(data, "PHOTO")

    def close(self) -> None:
        if self.serial.is_open:
            try:
                if (status := self.action_status()) is not None and status.outcome == "running":
                    self.cancel()
            except DriverError as exc:
                log.warning("%s: could not stop the rover on close: %s", self.port, exc)
            self.serial.close()
