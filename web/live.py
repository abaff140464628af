"""What the page shows of a running world, kept as the latest value of each stream.

Zenoh callbacks only store bytes (no decoding on Zenoh's thread); the server's broadcast loop takes the
newest world state at its own pace (``STREAM_HZ``), so a browser never falls behind a fast world: it
gets the latest value, never a backlog. Works the same on a replay, which republishes these keys.
"""

from __future__ import annotations

import base64
import threading
import time
from collections import Counter
from dataclasses import dataclass, field

import msgspec
import numpy as np

from lander_agent import map_view, mapping
from schemas import codec
from schemas import messages as m
from schemas.keyspace import REPLAY_STATES

STREAM_HZ = 10.0
"""World states pushed to each browser per second at most."""
PHOTO_BYTES_KEPT = 64 * 2**20
"""The newest photo of each rover is kept for the page, and a page that opens gets them all: at most this many
bytes of them (a photo may be 48 MiB on the wire, and any rover id may carry one). Past it the photos that arrived
first are let go; a photo larger than this alone is not kept."""


@dataclass
class Latest:
    """Newest payload per stream plus a version counter, so the reader knows what changed since last time."""

    lock: threading.Lock = field(default_factory=threading.Lock)
    payloads: dict[str, bytes] = field(default_factory=dict)
    versions: dict[str, int] = field(default_factory=dict)
    photos: dict[int, bytes] = field(default_factory=dict)
    photo_versions: dict[int, int] = field(default_factory=dict)
    photo_bytes: int = 0
    photo_clock: int = 0
    photos_dropped: int = 0
    arrived: dict[str, float] = field(default_factory=dict)

    def put(self, stream: str, payload: bytes) -> None:
        with self.lock:
            self.payloads[stream] = payload
            self.versions[stream] = self.versions.get(stream, 0) + 1
            self.arrived[stream] = time.monotonic()

    def age(self, stream: str) -> float | None:
        """Seconds since the stream's newest payload arrived; None if none did (or a new run forgot it)."""
        with self.lock:
            at = self.arrived.get(stream) if stream in self.payloads else None
        return None if at is None else round(time.monotonic() - at, 3)

    def put_photo(self, rover_id: int, payload: bytes) -> bool:
        """Keep a rover's newest photo; False if it alone is over ``PHOTO_BYTES_KEPT`` (not kept, counted)."""
        if len(payload) > PHOTO_BYTES_KEPT:
            self.photos_dropped += 1
            return False
        with self.lock:
            self.photo_bytes += len(payload) - len(self.photos.pop(rover_id, b""))
            self.photos[rover_id] = payload  # (re-)inserted last: the dict's order is the order of arrival
            self.photo_clock += 1  # one count for all rovers: a rover let go and back gets a version never seen
            self.photo_versions[rover_id] = self.photo_clock
            while self.photo_bytes > PHOTO_BYTES_KEPT:
                oldest = next(iter(self.photos))
                self.photo_bytes -= len(self.photos.pop(oldest))
                del self.photo_versions[oldest]
        return True

    def newer(self, seen: dict[str, int]) -> dict[str, bytes]:
        """Streams whose version moved past ``seen`` (updated in place)."""
        with self.lock:
            out = {k: p for k, p in self.payloads.items() if self.versions[k] != seen.get(k)}
            seen.update({k: self.versions[k] for k in out})
        return out

    def newer_photos(self, seen: dict[int, int]) -> dict[int, bytes]:
        with self.lock:
            out = {r: p for r, p in self.photos.items() if self.photo_versions[r] != seen.get(r)}
            seen.update({r: self.photo_versions[r] for r in out})
        return out

    def forget(self) -> None:
        """A new run starts: old states and photos must not linger on the page."""
        with self.lock:
            self.payloads.clear()
            self.photos.clear()
            self.photo_versions.clear()
            self.photo_bytes = 0


@dataclass
class Source:
    """Where the page's samples come from, as far as the view knows: whether a router is reachable at ``where``,
    and whether a replay holds its token on the world (``Keyspace.alive_replay``), playing or paused. Written by
    Zenoh's threads, read by the server's loop."""

    where: str = ""
    connected: bool = True
    lock: threading.Lock = field(default_factory=threading.Lock)
    tokens: Counter[str] = field(default_factory=Counter)

    def set_connected(self, connected: bool) -> None:
        with self.lock:
            self.connected = connected  # a router gone takes its tokens: Zenoh says each one went

    def replay_token(self, key: str, alive: bool) -> None:
        """A replay's token came or went. Counted per state, in case two replays hold the same one; a state the
        view does not know (the key is anyone's to declare) is ignored."""
        state = key.rsplit("/", 1)[-1]
        if state not in REPLAY_STATES:
            return
        with self.lock:
            self.tokens[state] += 1 if alive else -1
            if self.tokens[state] <= 0:
                del self.tokens[state]

    def status(self) -> dict:
        with self.lock:
            replay = next((state for state in REPLAY_STATES if self.tokens[state] > 0), None)
            return {"router": self.where, "connected": self.connected, "replay": replay}


def power_json(r: m.RoverTruth) -> dict:
    """A rover's battery, temperature and light; nothing when the scenario has no sun (no power model)."""
    if r.battery_wh is None:
        return {}
    return {"battery_wh": round(r.battery_wh, 5), "temperature_c": _round(r.temperature_c, 2), "sunlit": r.sunlit,
            "powered": r.powered, "energy_used_wh": _round(r.energy_used_wh, 5)}


def _round(value: float | None, digits: int) -> float | None:
    return None if value is None else round(value, digits)


def state_json(state: m.WorldState) -> dict:
    """The world state for the page: one entry per rover, links and the daisy chain."""
    rovers = [{"id": r.id, "x": round(r.x, 3), "z": round(r.z, 3), "heading": round(r.heading_deg, 2),
               "state": r.state, "action": r.action, "goal": r.goal_index,
               "to_goal": round(r.distance_to_goal_m, 2), "covered": round(r.distance_covered_m, 2),
               "alive": r.alive, "stale": r.telemetry_stale, **power_json(r)} for r in state.rovers]
    return {"type": "state", "stamp": state.stamp, "rovers": rovers, "links": [list(p) for p in state.comm_links],
            "relays": state.relays, "counters": msgspec.to_builtins(state.counters), "completed_at": state.completed_at}


def stats_json(stats: m.WorldStats) -> dict:
    return {"type": "stats", "stamp": stats.stamp, "final": stats.final, "report": msgspec.to_builtins(stats.report)}


def lander_json(status: m.LanderStatus) -> dict:
    return {"type": "lander", **msgspec.to_builtins(status)}


def map_json(msg: m.LanderMap) -> dict:
    """The lander's traverse map, still zlib-compressed (the page inflates it): a few kB every 5 s, not the
    grid's full size, and coarsened past ``map_view.VIEW_CELLS`` cells or ``map_view.PAGE_SIDE`` a side. Decoded
    here once all the same, so a map that does not fit its shape never reaches a page, and so the page gets each
    class's cell count and colour (those of the map's PNG)."""
    msg = map_view.for_viewers(msg, max_side=map_view.PAGE_SIDE)
    _, cells = mapping.from_message(msg)
    counts = np.bincount(cells.ravel(), minlength=len(msg.classes))  # of at most VIEW_CELLS cells: 32 MB
    return {"type": "map", "stamp": msg.stamp, "cell_m": msg.cell_m, "origin_x": msg.origin_x,
            "origin_z": msg.origin_z, "width": msg.width, "height": msg.height, "classes": msg.classes,
            "colours": mapping.COLOURS[:len(msg.classes)].tolist(), "counts": counts.tolist(),
            "cells": base64.b64encode(msg.cells).decode("ascii")}


def photo_json(rover_id: int, photo: m.Photo) -> dict:
    return {"type": "photo", "rover": rover_id, "stamp": photo.stamp, "label": photo.label,
            "png": base64.b64encode(photo.png).decode("ascii")}


STREAM_MODELS = {"state": (m.WorldState, state_json), "stats": (m.WorldStats, stats_json),
                 "lander": (m.LanderStatus, lander_json), "map": (m.LanderMap, map_json)}


def stream_message(stream: str, payload: bytes) -> dict | None:
    """Decode one stored payload into the page's message; None if it does not decode (counted by the caller)."""
    model, to_json = STREAM_MODELS[stream]
    try:
        return to_json(codec.decode(model, payload))
    except ValueError:  # codec.DecodeError, or a map whose cells do not fit its shape
        return None


def photo_message(rover_id: int, payload: bytes) -> dict | None:
    try:
        return photo_json(rover_id, codec.decode(m.Photo, payload))
    except codec.DecodeError:
        return None
