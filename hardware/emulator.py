"""An emulated rover base on a pseudo-terminal (``lunarsim emulate-device``).

It opens a real pty, and answers the reference line protocol (``hardware.protocol``) on it for a ``DeviceModel``
simulated in real time, so the serial driver, the bridge and the checker are exercised through a real serial port
opened by pyserial. Its radio links to the ids given as partners; each emulated partner echoes back every
``comm_in`` transmission it receives (a loopback for radio round trips). ``garble_every`` N puts a garbage line
before every Nth answer, to see a driver survive noise on the wire.
"""

from __future__ import annotations

import base64
import binascii
import os
import select
import threading
import time
import tty
from collections import deque
from dataclasses import dataclass, field
from typing import ClassVar

from hardware import protocol as p
from hardware.device_model import BaseParams, DeviceModel, Refused, Rock
from shared import png

DEVICE_NAME = "LUNARSIM-EMU"
PROTOCOL_VERSION = "1"
GARBAGE = (b"\x07\xff\xfe#noise\n", b"OK 12.5 3\n", b"17 MAYBE\n", b"4 OK \x1b[2J\n")
"""Kinds of noise: non-ASCII bytes, a line without a sequence number, a bad status word, control characters."""
PHOTO_SIZE = (80, 60)
PHOTO_FOV_DEG = 60.0


@dataclass
class EmulatedRadio:
    partners: list[int]
    inbox: deque = field(default_factory=deque)
    dropped: int = 0

    def transmit(self, channel: str, targets: list[int], payload: bytes) -> None:
        for target in targets:
            if target not in self.partners:
                self.dropped += 1
            elif channel == "comm_in":
                self.inbox.append((target, channel, payload))

    def inject(self, sender: int, channel: str, payload: bytes) -> None:
        """A transmission from outside arrives (a lander's mission direction in a test)."""
        self.inbox.append((sender, channel, payload))


class DeviceServer:
    """Request line in, answer lines out, for one emulated device."""

    def __init__(self, model: DeviceModel, radio: EmulatedRadio | None, camera: bool = True,
                 garble_every: int = 0) -> None:
        self.model, self.radio, self.camera, self.garble_every = model, radio, camera, garble_every
        self.lock = threading.Lock()
        self.t0 = time.monotonic()
        self.answers = 0
        self.bad_requests = 0

    def now(self) -> float:
        return time.monotonic() - self.t0

    def answer(self, line: bytes) -> bytes:
        try:
            seq, verb, args = p.parse_request(line)
        except p.GarbledLine:
            self.bad_requests += 1
            return b""  # no sequence number to answer to: the host's own timeout deals with it
        with self.lock:
            self.model.advance(self.now())
            reply = self._dispatch(seq, verb, args)
        self.answers += 1
        noise = GARBAGE[self.answers % len(GARBAGE)] if self.garble_every and self.answers % self.garble_every == 0 \
            else b""
        return noise + reply

    def _dispatch(self, seq: int, verb: str, args: tuple[str, ...]) -> bytes:
        handler = self._verbs.get(verb)
        if handler is None:
            return p.format_error(seq, "bad_request", f"unknown verb {verb!r}")
        try:
            return p.format_reply(seq, *handler(self, *args))
        except Refused as exc:
            return p.format_error(seq, exc.code, exc.detail)
        except (TypeError, ValueError, binascii.Error) as exc:
            return p.format_error(seq, "bad_request", f"{verb}: {exc}")

    def _hello(self) -> list[str]:
        b = self.model.params
        return [DEVICE_NAME, PROTOCOL_VERSION, f"fov={b.fov_deg:g}", f"range={b.range_m:g}",
                f"radio={int(self.radio is not None)}", f"camera={int(self.camera)}"]

    def _move(self, x: str, z: str) -> list[str]:
        return [str(self.model.move(p.number(x, "x"), p.number(z, "z")))]

    def _rotate(self, degrees: str) -> list[str]:
        return [str(self.model.rotate(p.number(degrees, "degrees")))]

    def _cancel(self) -> list[str]:
        self.model.cancel()
        return []

    def _speed(self, level: str) -> list[str]:
        if not level.lstrip("-").isdigit():
            raise Refused("bad_value", f"speed level {level!r} is not an integer")
        self.model.set_speed(int(level))
        return []

    def _status(self) -> list[str]:
        status = self.model.status()
        if status is None:
            return [p.fmt(self.now()), "NONE"]
        action_id, kind, outcome, *numbers = status
        return [p.fmt(self.now()), str(action_id), kind, outcome, *(p.fmt(v, 4) for v in numbers)]

    def _scan(self) -> list[str]:
        return [p.fmt(self.now()), *(f"{a:.2f}:{d:.3f}:{k}" for a, d, k in self.model.scan())]

    def _imu(self) -> list[str]:
        return [p.fmt(self.now()), p.fmt(self.model.pitch(), 4)]

    def _pose(self) -> list[str]:
        m = self.model
        return [p.fmt(self.now()), p.fmt(m.x, 4), p.fmt(m.z, 4), p.fmt(m.heading, 3), str(int(m.busy))]

    def _photo(self) -> list[str]:
        if not self.camera:
            raise Refused("unsupported", "this device has no camera")
        return [base64.b64encode(render_view(self.model)).decode()]

    def _tx(self, channel: str, ids: str, payload: str) -> list[str]:
        if self.radio is None:
            raise Refused("unsupported", "this device has no radio")
        data = b"" if payload == "=" else base64.b64decode(payload, validate=True)
        self.radio.transmit(channel, p.parse_ids(ids), data)
        return []

    def _rx(self) -> list[str]:
        if self.radio is None:
            raise Refused("unsupported", "this device has no radio")
        if not self.radio.inbox:
            return ["NONE"]
        sender, channel, payload = self.radio.inbox.popleft()
        return [str(sender), channel, base64.b64encode(payload).decode() or "="]

    def _links(self) -> list[str]:
        if self.radio is None:
            raise Refused("unsupported", "this device has no radio")
        return [p.format_ids(self.radio.partners)]

    _verbs: ClassVar[dict] = {"HELLO?": _hello, "MOVE": _move, "ROT": _rotate, "CANCEL": _cancel, "SPEED": _speed,
              "STATUS?": _status, "SCAN?": _scan, "IMU?": _imu, "POSE?": _pose, "PHOTO": _photo, "TX": _tx,
              "RX?": _rx, "LINKS?": _links}


def render_view(model: DeviceModel) -> bytes:
    """A grey-scale PNG of what is ahead: black sky, grey ground, rocks as bright columns, nearer ones taller."""
    width, height = PHOTO_SIZE
    horizon = height // 2
    rows = [bytearray([0] * width if y < horizon else [90] * width) for y in range(height)]
    for col in range(width):
        angle = (col / (width - 1) - 0.5) * PHOTO_FOV_DEG
        hit = model.first_rock(model.heading + angle, 30.0)
        if hit is not None:
            half = min(horizon, int(2 * hit[1].radius * height / max(hit[0], 0.1)))
            for y in range(horizon - half, horizon + half // 2):
                rows[y][col] = 200
    return png.encode(width, height, b"".join(bytes(row) for row in rows), channels=1)


class Emulator:
    """The device on a pty: ``path`` is the serial end a driver opens; ``start`` serves it on a thread."""

    def __init__(self, server: DeviceServer) -> None:
        self.server = server
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)  # no echo, no line editing: a serial line, not a terminal
        self.path = os.ttyname(self.slave)
        self.stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start(self) -> Emulator:
        self._thread = threading.Thread(target=self.serve, name="emulated-device", daemon=True)
        self._thread.start()
        return self

    def serve(self) -> None:
        buffer = b""
        while not self.stop.is_set():
            if not select.select([self.master], [], [], 0.1)[0]:
                continue
            try:
                buffer += os.read(self.master, 65536)
            except OSError:
                continue  # no client on the serial end right now
            *lines, buffer = buffer.split(b"\n")
            if len(buffer) > p.MAX_LINE:
                buffer = b""
            for line in lines:
                self._write_all(self.server.answer(line + b"\n"))

    def _write_all(self, data: bytes) -> None:
        while data and not self.stop.is_set():
            if select.select([], [self.master], [], 0.1)[1]:
                data = data[os.write(self.master, data):]

    def close(self) -> None:
        self.stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)
        os.close(self.master)
        os.close(self.slave)


def parse_rocks(text: str) -> tuple[Rock, ...]:
    """``x,z,radius[,kind];...`` (kind: obstacle, rover or lander), or ``none``; a ValueError names the bad item."""
    if text.strip() == "none":
        return ()
    rocks = []
    for item in filter(None, (part.strip() for part in text.split(";"))):
        fields = item.split(",")
        try:
            x, z, radius = (float(v) for v in fields[:3])
        except ValueError:
            raise ValueError(f"{item!r} is not x,z,radius[,kind]") from None
        kind = fields[3] if len(fields) > 3 else "obstacle"
        if len(fields) not in (3, 4) or radius <= 0 or kind not in ("obstacle", "rover", "lander"):
            raise ValueError(f"{item!r} is not x,z,radius[,kind] with radius > 0 and kind obstacle, rover or lander")
        rocks.append(Rock(x, z, radius, kind))
    return tuple(rocks)


def build(rocks: tuple[Rock, ...] | None, slope_deg: float = 0.0, partners: list[int] | None = None,
          camera: bool = True, garble_every: int = 0) -> Emulator:
    """An emulated device, not yet serving: ``rocks`` around its start (None: the model's default three),
    ``partners`` its radio links (None: no radio)."""
    base = BaseParams(slope_deg=slope_deg)
    model = DeviceModel(base) if rocks is None else DeviceModel(base, rocks)
    radio = None if partners is None else EmulatedRadio(partners)
    return Emulator(DeviceServer(model, radio, camera=camera, garble_every=garble_every))
