"""Every key expression LunarSim uses, built in one place.

Keys mirror the report's ROS topics: ``roverX/<topic>`` becomes ``lunar/<world>/rover/<X>/<topic>``.
The ``<world>`` segment lets several simulations (or a replay beside a live run) share a router.
"""

from __future__ import annotations

import functools
import re
from dataclasses import dataclass
from typing import Final

ROOT: Final = "lunar"
LANDER_ID: Final = 0
"""The lander's address on the radio; rovers are numbered from 1 as in the report (rover1, rover2...)."""

# Rover topics, named as in report section 10 (plus the few the design doc adds).
PERCEPTION: Final = "perception"
MOVE_ACTION: Final = "move_action"
ROTATE_ACTION: Final = "rotate_action"
NAVIGATION_STATUS: Final = "navigation_status"
CANCEL_ACTION: Final = "cancel_action"
CANCEL_RESULT: Final = "cancel_result"
SPEED_ACTION: Final = "speed_action"
ACTION_REJECTED: Final = "action_rejected"
GYROSCOPE: Final = "gyroscope"
COMM_OUT: Final = "comm_out"
COMM_IN: Final = "comm_in"
COMM_PARTNERS: Final = "comm_partners"
MISSION_DIRECTION: Final = "mission_direction"
CALIBRATION: Final = "calibration"
PHOTO_ACTION: Final = "photo_action"
PHOTO: Final = "photo"
STATUS: Final = "status"
ACK: Final = "ack"
"""Lockstep: an agent's acknowledgement that it has handled a clock tick (rover and lander keys)."""
CLOCK: Final = "clock"
STATE: Final = "state"
STATS: Final = "stats"
COMMAND: Final = "command"
COMMAND_RESULT: Final = "command_result"
TELEMETRY: Final = "telemetry"
"""A real rover's own pose estimate, from its hardware driver bridge to the world service in twin mode."""
POSE_ESTIMATE: Final = "pose_estimate"
"""A rover agent's estimate of its own pose and how sure it is (``EstimatedPose``), for the ground, the ROS 2 bridge
and the recorder: what the rover believes, never ground truth."""
MAP: Final = "map"
"""The lander's traverse map (occupancy grid), published at a low rate for viewers and the recorder."""
BATTERY: Final = "battery"
TEMPERATURE: Final = "temperature"
SUN: Final = "sun"
"""Power sensors: charge, temperature and whether the panel is lit; published only when the scenario
has a sun."""
ROVER_IDS: Final = "rover_ids"
"""The world's queryable that hands a rover agent started with ``--id auto`` a free rover id."""
REPLAY_STATES: Final = ("playing", "paused")
"""The last chunk of a replay's liveliness token (``Keyspace.alive_replay``): how viewers tell a replay from a live
world, and a paused replay from a stopped one."""
ROVER_INPUTS: Final = (PERCEPTION, NAVIGATION_STATUS, CANCEL_RESULT, ACTION_REJECTED, GYROSCOPE, COMM_IN, COMM_PARTNERS,
                       MISSION_DIRECTION, CALIBRATION, PHOTO, BATTERY, TEMPERATURE, SUN)
"""A rover's topics that a rover agent takes: its sensors, the world's answers to its actions and what its radio
receives, published by the world (or the rover's hardware bridge)."""
ROVER_OUTPUTS: Final = (MOVE_ACTION, ROTATE_ACTION, CANCEL_ACTION, SPEED_ACTION, PHOTO_ACTION, COMM_OUT, STATUS,
                        POSE_ESTIMATE, ACK)
"""A rover's topics that its agent publishes: actions, radio transmissions, status, pose estimate and lockstep acks.

A process of rover agents declares its publishers before the clock starts: a Zenoh declaration's cost grows with
the entities the session already holds (milliseconds each with 250 agents in one process), and made on first use,
mid-mission, it holds up every sample behind it. The world declares none of its thousands of rover keys: declared
ahead, a router process would match every agent's subscription against them, and a thousand shared rovers would
take minutes rather than seconds to connect; declared at all, each brings the agents' subscriptions matching it
into the world's session, against which Zenoh then matches every sample the world receives (docs/benchmarks.md)."""
RADIO_TOPICS: Final = frozenset({COMM_OUT, COMM_IN, MISSION_DIRECTION, CALIBRATION})
"""Topics that carry radio traffic: a transmission and its deliveries. The radio model counts what it loses
(``radio_lost``, ``radio_dropped``), so Zenoh must not lose them unseen: they are published without dropping under
congestion (``bus.bus.Bus``); each sender's airtime bounds their rate."""
ANSWERED_TOPICS: Final = frozenset({PERCEPTION, COMM_IN, MISSION_DIRECTION, CALIBRATION, PHOTO})
"""The world-to-agent topics (rover or lander) whose samples may make an agent publish. Samples of the others
(gyroscope, navigation status, cancel result, action rejected, comm partners) only update what the agent knows,
so in lockstep the world waits for an agent's ack only after a tick that sent it one of these, or when the
agent's own timers are due (``Ack.wake``)."""


_WORLD_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")


def check_world_name(world: str) -> str:
    """Reject world names that would break or widen key expressions: besides '/', '*', '$', '#' and '?', a chunk
    starting with '@' is verbatim in Zenoh 1.x, so ``lunar/**`` (the recorder, the viewers) would not match it. A
    name also starts with a letter or digit, as a recording's file and folder names must (``SafeName``)."""
    if not _WORLD_NAME.fullmatch(world):
        raise ValueError(f"invalid world name {world!r}: use 1 to 64 letters, digits, '-' or '_', starting with a "
                         "letter or digit (no '/', '*', '$', '#', '?', '@', spaces)")
    return world


def _is_id(text: str) -> bool:
    return text.isascii() and text.isdigit()


@dataclass(frozen=True)
class Keyspace:
    """Key expressions of one simulated (or real) world."""

    world: str = "default"

    def __post_init__(self) -> None:
        check_world_name(self.world)

    @functools.cached_property
    def prefix(self) -> str:
        """Every key's head; kept, since the world and the agents build keys from it for every sample."""
        return f"{ROOT}/{self.world}"

    @property
    def all(self) -> str:
        return f"{self.prefix}/**"

    def rover(self, rover_id: int, topic: str) -> str:
        return f"{self.prefix}/rover/{rover_id}/{topic}"

    def rovers(self, topic: str) -> str:
        """Wildcard over every rover id for one topic (what the world service subscribes to)."""
        return f"{self.prefix}/rover/*/{topic}"

    def lander(self, topic: str) -> str:
        return f"{self.prefix}/lander/{topic}"

    @property
    def ground_command(self) -> str:
        return f"{self.prefix}/ground/{COMMAND}"

    @property
    def ground_command_result(self) -> str:
        return f"{self.prefix}/ground/{COMMAND_RESULT}"

    @property
    def clock(self) -> str:
        return f"{self.prefix}/world/{CLOCK}"

    @property
    def state(self) -> str:
        return f"{self.prefix}/world/{STATE}"

    @property
    def stats(self) -> str:
        return f"{self.prefix}/world/{STATS}"

    @property
    def rover_ids(self) -> str:
        return f"{self.prefix}/world/{ROVER_IDS}"

    def alive_rover(self, rover_id: int) -> str:
        """Liveliness token a rover agent holds while it runs."""
        return f"{self.prefix}/alive/rover/{rover_id}"

    @property
    def alive_rovers(self) -> str:
        return f"{self.prefix}/alive/rover/*"

    @property
    def alive_lander(self) -> str:
        return f"{self.prefix}/alive/lander"

    def alive_replay(self, state: str) -> str:
        """Liveliness token a replay publishing into this world holds while it runs, its state (``REPLAY_STATES``)
        the last chunk: the samples carry nothing that tells a replay, and a token vanishes with its process."""
        return f"{self.prefix}/alive/replay/{state}"

    @property
    def alive_replays(self) -> str:
        return f"{self.prefix}/alive/replay/*"

    def remap(self, key: str, other: Keyspace) -> str:
        """The same key in another world (replaying a session beside a live one)."""
        if not key.startswith(self.prefix + "/"):
            raise ValueError(f"key {key!r} is not in world {self.world!r}")
        return other.prefix + key[len(self.prefix):]

    def parse_rover_key(self, key: str) -> tuple[int, str]:
        """Split ``lunar/<w>/rover/<X>/<topic>`` into (X, topic); ValueError names the bad part."""
        head = f"{self.prefix}/rover/"
        if not key.startswith(head):
            raise ValueError(f"key {key!r} is not a rover key of world {self.world!r}")
        parts = key[len(head):].split("/")
        if len(parts) != 2 or not _is_id(parts[0]):
            raise ValueError(f"key {key!r} does not name a rover id and topic")
        return int(parts[0]), parts[1]

    def parse_alive_key(self, key: str) -> int:
        """Rover id from a liveliness key."""
        head = f"{self.prefix}/alive/rover/"
        tail = key[len(head):] if key.startswith(head) else ""
        if not _is_id(tail):
            raise ValueError(f"key {key!r} is not a rover liveliness key of world {self.world!r}")
        return int(tail)
