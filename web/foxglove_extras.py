"""What ``lunarsim view --foxglove`` serves beyond a recording's channels: simulated time, the rovers' senses, and the
ground's say from the Foxglove app.

- **Time**: the server has Foxglove's Time capability and broadcasts the world's clock (``world/clock``), and every
  message it logs is stamped with simulated time, so Foxglove's timeline follows the mission at any time scale.
- **Senses**: ``/rover_<id>/scan`` (a ``foxglove.LaserScan`` in the rover's frame: the perception rays, +inf where
  nothing was hit), ``/rover_<id>/imu`` (JSON: the gyroscope's pitch) and ``/rover_<id>/battery`` (JSON).
- **Ground commands**: a client may publish JSON on ``/ground/command`` (ClientPublish), in the web page's words
  (``web.page_commands``): ``{"command": "set-target", "x": 30, "z": 40}``, ``stop``/``return`` with ``rover_id``,
  ``pause``, ``resume``, ``step``. They go out once on ``ground/command``; the lander's answer to one comes back
  to the app as a status message.
- **Playback**: Foxglove's play, pause and seek (PlaybackControl) become the ground's ``resume``, ``pause`` and
  ``seek`` (seconds of simulated time from the start), which a replay (and, but for seek, a live world) carries out.

All of it is pure: samples and client messages in, Foxglove messages and ground commands out. What a client sends
is bounded (size, JSON, the command model) and what is refused is counted in ``rejected``; nothing ends the view.
"""

from __future__ import annotations

import json
import logging
import math
from collections import OrderedDict
from dataclasses import dataclass, field

import foxglove.messages as fm

from bus.rejections import Rejections
from schemas import messages as m
from schemas.base import HIT_KINDS
from sessions import foxglove as fx
from sessions.rays import RayLayout

log = logging.getLogger("lunarsim.view")

REMEMBERED_REQUESTS = 256
"""Commands sent whose answer the view waits for: a lander that never answers cannot grow the table."""
COMMAND_TOPIC = "/ground/command"
"""The one topic a Foxglove client may publish on."""
MAX_CLIENT_MESSAGE_BYTES = 4096
"""A ground command is a few numbers; anything longer is refused unread."""
PITCH_SCHEMA = {"type": "object", "properties": {"stamp": {"type": "number"}, "pitch_deg": {"type": "number"}}}
BATTERY_SCHEMA = {"type": "object", "properties": {
    "stamp": {"type": "number"}, "fraction": {"type": "number"}, "charge_wh": {"type": "number"},
    "capacity_wh": {"type": "number"}, "solar_w": {"type": "number"}, "empty": {"type": "boolean"}}}


def sim_ns(seconds: float) -> int:
    """Simulated seconds as Foxglove's nanoseconds (the timeline starts at the epoch, as ROS's simulated time)."""
    return max(0, round(seconds * 1e9))


def scan(msg: m.Perception, rover_id: int, layout: RayLayout) -> fm.LaserScan:
    """Every ray of the layout, counter-clockwise from the right (Foxglove's and ROS's angles), +inf where nothing
    was hit; intensities carry the hit's kind, 1 + its index in ``HIT_KINDS``. ValueError for a hit on no ray."""
    ranges, kinds = [math.inf] * layout.rays, [0.0] * layout.rays
    for i, distance, kind in zip(layout.indices(msg.angles_deg), msg.distances_m, msg.kinds, strict=True):
        if distance < ranges[i]:
            ranges[i], kinds[i] = distance, float(HIT_KINDS.index(kind) + 1)
    half = math.radians(layout.fov_deg) / 2
    return fm.LaserScan(timestamp=fx.timestamp(sim_ns(msg.stamp)), frame_id=fx.rover_frame(rover_id),
                        start_angle=-half, end_angle=half, ranges=ranges, intensities=kinds)


def pitch(msg: m.Gyroscope) -> dict:
    return {"stamp": msg.stamp, "pitch_deg": msg.pitch_deg}


def battery(msg: m.Battery) -> dict:
    return {"stamp": msg.stamp, "fraction": msg.fraction, "charge_wh": msg.charge_wh, "capacity_wh": msg.capacity_wh,
            "solar_w": msg.solar_w, "empty": msg.empty}


@dataclass
class GroundInput:
    """Client messages and playback requests into ground commands (``outbox``), refusals counted."""

    rejected: Rejections = field(default_factory=lambda: Rejections(log, "foxglove view"))
    channels: dict[tuple[int, int], str] = field(default_factory=dict)
    """(client, client channel) -> topic, of the channels clients advertised."""
    outbox: list[m.GroundCommand] = field(default_factory=list)
    sent: OrderedDict[str, str] = field(default_factory=OrderedDict)
    """Request id -> command, of the mission commands sent, until the lander answers."""

    def advertised(self, client: int, channel: int, topic: str, encoding: str) -> None:
        if topic != COMMAND_TOPIC or encoding != "json":
            self.rejected.count("advertise", f"a client channel {topic[:60]!r} ({encoding[:20]}): only "
                                f"{COMMAND_TOPIC} in json is taken")
            return
        if len(self.channels) < 1024:  # a client advertising without end cannot grow the table without end
            self.channels[(client, channel)] = topic

    def unadvertised(self, client: int, channel: int) -> None:
        self.channels.pop((client, channel), None)

    def message(self, client: int, channel: int, data: bytes) -> m.GroundCommand | None:
        """A client's message on an advertised channel as the ground command it asks for, queued in ``outbox``."""
        from web.page_commands import CommandError, command_from_request

        if (client, channel) not in self.channels:
            self.rejected.count("client message", f"on channel {channel}, which the client did not advertise")
            return None
        try:
            if len(data) > MAX_CLIENT_MESSAGE_BYTES:
                raise CommandError(f"{len(data)} bytes, more than {MAX_CLIENT_MESSAGE_BYTES}")
            command = command_from_request(json.loads(data))
        except (CommandError, ValueError, RecursionError) as exc:  # json's errors are ValueErrors
            self.rejected.count(COMMAND_TOPIC, str(exc)[:160])
            return None
        self.outbox.append(command)
        if command.command in m.MISSION_COMMANDS:
            self.sent[command.request_id] = command.command
            while len(self.sent) > REMEMBERED_REQUESTS:
                self.sent.popitem(last=False)
        return command

    def answer(self, result: m.CommandResult) -> str | None:
        """The status line of the lander's answer to a command this view sent; None for anyone else's."""
        name = self.sent.pop(result.request_id, None)
        if name is None:
            return None
        return f"{name} {'accepted' if result.accepted else 'refused'} by the lander" + (
            f": {result.detail}" if result.detail else "")

    def playback(self, play: bool, seek_ns: int | None, paused: bool) -> list[m.GroundCommand]:
        """Foxglove's play, pause and seek as the ground's commands: a seek first, then play or pause when it
        changes the state."""
        from bus.ground_commands import build_command

        out = []
        if seek_ns is not None:
            out.append(build_command("seek", seconds=min(max(0.0, seek_ns / 1e9), 1e9)))
        if play == paused:
            out.append(build_command("resume" if play else "pause"))
        self.outbox += out
        return out
