"""What a rover hears in one round, as arrays, and what it may say, from arrays: the environment's Gymnasium spaces.

The observation is exactly the samples that reached the rover's keys in the round (``harness.rounds``), each
topic's content in fixed-shape arrays and ``heard`` saying which topics arrived; a topic not heard is all zeros.
Nothing else goes in: no pose, no map, no other rover's truth (report 9.1). The samples themselves, encoded as
on the wire, are in the step's ``infos[agent]["samples"]``, for policies (like the shipped agent) that read
messages rather than arrays.

The action is what a rover may publish: one of move / rotate / cancel / photo (``command``), a speed level, and
a radio broadcast of ``RADIO_FLOATS`` numbers to the other rovers. Codes come from the message models, so they
cannot drift from the contract.
"""

from __future__ import annotations

from typing import get_args, get_type_hints

import numpy as np
from gymnasium import spaces

from schemas import keyspace as ks
from schemas import messages as m
from schemas.params import RoverParams

HEARD_TOPICS = (ks.CLOCK, *ks.ROVER_INPUTS)
"""Every topic the world sends a rover, and the clock."""
NAV_ACTIONS = get_args(get_type_hints(m.NavigationStatus)["action"])
NAV_OUTCOMES = get_args(get_type_hints(m.NavigationStatus)["outcome"])
REJECT_REASONS = get_args(get_type_hints(m.ActionRejected)["reason"])
DIRECTION_KINDS = get_args(m.DirectionKind)
COMMANDS = ("none", "move", "rotate", "cancel", "photo")
GOAL_REPORTS = ("none", "reached", "stuck")
"""What a rover says of the goal its last mission direction named: the lander sends the next goal on "reached"
(as the shipped agent's ``radio.GoalReport``), and the rover's status says done (final goal), waiting or stuck."""
RADIO_FLOATS = 8
"""Numbers in one radio broadcast of the array action (float32, sent as their bytes)."""
RADIO_MARK = b"LSnum1"
"""Starts an array policy's broadcast (``pack_numbers``)."""
_F = np.float32
_INF = np.float32(np.inf)


def _box(*shape: int, low: float = -_INF, high: float = _INF) -> spaces.Box:
    return spaces.Box(low=low, high=high, shape=shape, dtype=_F)


def observation_space(params: RoverParams, radio_ids: int) -> spaces.Dict:
    """``radio_ids``: the lander (0) and every rover id, so ids index the partner and sender arrays."""
    rays = params.perception.perception_granularity
    return spaces.Dict({
        "heard": spaces.MultiBinary(len(HEARD_TOPICS)),
        "sim_time": _box(1, low=0.0),
        "hit_angle_deg": _box(rays), "hit_distance_m": _box(rays, low=0.0),
        "hit_kind": spaces.MultiDiscrete([len(m.HIT_KINDS) + 1] * rays),  # 0: no hit; k: HIT_KINDS[k - 1]
        "pitch_deg": _box(1),
        "navigation": spaces.MultiDiscrete([len(NAV_ACTIONS) + 1, len(NAV_OUTCOMES) + 1]),
        "navigation_remaining": _box(1, low=0.0),
        "cancel_result": _box(3),  # x, z (m, rover frame at the move's start), angle (degrees)
        "rejected": spaces.Discrete(len(REJECT_REASONS) + 1),
        "partners": spaces.MultiBinary(radio_ids),
        "radio_senders": spaces.MultiBinary(radio_ids),
        "radio_in": _box(radio_ids, RADIO_FLOATS, low=-1.0, high=1.0),
        "direction_kind": spaces.Discrete(len(DIRECTION_KINDS) + 1),
        "direction": _box(4),  # goal index, goals in total, bearing (degrees) and distance (m) from the lander
        "calibration": _box(3),  # dispatch x, z (m, lander frame) and heading (degrees)
        "power": _box(3),  # battery fraction, temperature (C), panel lit (0/1); zeros in a world with no sun
    })


def action_space(params: RoverParams) -> spaces.Dict:
    reach = float(params.perception.perception_radius)
    return spaces.Dict({
        "command": spaces.Discrete(len(COMMANDS)),
        "move": _box(2, low=-reach, high=reach),  # x (right), z (ahead), m; must be in view, as MoveAction
        "rotate": _box(1, low=-180.0, high=180.0),  # degrees, positive right
        "speed": spaces.Discrete(4),  # 0: keep; 1-3: SpeedAction level
        "goal": spaces.Discrete(len(GOAL_REPORTS)),  # tell the lander (and the world's status) of the goal
        "radio": spaces.Discrete(2),  # 1: broadcast radio_out to the other rovers
        "radio_out": _box(RADIO_FLOATS, low=-1.0, high=1.0),
    })


def empty_observation(space: spaces.Dict) -> dict[str, np.ndarray]:
    return {name: np.zeros(sub.shape, dtype=sub.dtype) if not isinstance(sub, spaces.Discrete)
            else np.int64(0) for name, sub in space.spaces.items()}


def observe(heard: list[tuple[str, m.Message]], empty: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The round's samples (topic, decoded message) as arrays, filled into a copy of ``empty``."""
    obs = {name: value.copy() for name, value in empty.items()}
    for topic, message in heard:
        obs["heard"][HEARD_TOPICS.index(topic)] = 1
        _FILL[topic](obs, message)
    return obs


def _clock(obs, msg: m.Clock) -> None:
    obs["sim_time"][0] = msg.sim_time


def _perception(obs, msg: m.Perception) -> None:
    n = min(len(msg.kinds), len(obs["hit_kind"]))
    obs["hit_angle_deg"][:n] = msg.angles_deg[:n]
    obs["hit_distance_m"][:n] = msg.distances_m[:n]
    obs["hit_kind"][:n] = [m.HIT_KINDS.index(kind) + 1 for kind in msg.kinds[:n]]


def _navigation(obs, msg: m.NavigationStatus) -> None:
    obs["navigation"][:] = (NAV_ACTIONS.index(msg.action) + 1, NAV_OUTCOMES.index(msg.outcome) + 1)
    obs["navigation_remaining"][0] = msg.remaining


def _cancel(obs, msg: m.CancelResult) -> None:
    obs["cancel_result"][:] = (msg.x, msg.z, msg.angle_deg)


def _rejected(obs, msg: m.ActionRejected) -> None:
    obs["rejected"] = np.int64(REJECT_REASONS.index(msg.reason) + 1)


def _gyroscope(obs, msg: m.Gyroscope) -> None:
    obs["pitch_deg"][0] = msg.pitch_deg


def _comm_in(obs, msg: m.InboundComm) -> None:
    if 0 <= msg.sender < len(obs["radio_senders"]):
        obs["radio_senders"][msg.sender] = 1
        numbers = unpack_numbers(msg.payload)  # another array policy's broadcast; anything else only in the samples
        if numbers is not None:
            obs["radio_in"][msg.sender] = numbers


def _partners(obs, msg: m.CommPartners) -> None:
    ids = [i for i in msg.ids if 0 <= i < len(obs["partners"])]
    obs["partners"][ids] = 1


def _direction(obs, msg: m.MissionDirection) -> None:
    obs["direction_kind"] = np.int64(DIRECTION_KINDS.index(msg.kind) + 1)
    obs["direction"][:] = (msg.goal_index, msg.goals_total, msg.bearing_deg, msg.distance_m)


def _calibration(obs, msg: m.Calibration) -> None:
    obs["calibration"][:] = (msg.x, msg.z, msg.heading_deg)


def _battery(obs, msg: m.Battery) -> None:
    obs["power"][0] = msg.fraction


def _temperature(obs, msg: m.Temperature) -> None:
    obs["power"][1] = msg.celsius


def _sun(obs, msg: m.Sunlight) -> None:
    obs["power"][2] = float(msg.lit)


_FILL = {ks.CLOCK: _clock, ks.PERCEPTION: _perception, ks.NAVIGATION_STATUS: _navigation,
         ks.CANCEL_RESULT: _cancel, ks.ACTION_REJECTED: _rejected, ks.GYROSCOPE: _gyroscope, ks.COMM_IN: _comm_in,
         ks.COMM_PARTNERS: _partners, ks.MISSION_DIRECTION: _direction, ks.CALIBRATION: _calibration,
         ks.PHOTO: lambda obs, msg: None, ks.BATTERY: _battery, ks.TEMPERATURE: _temperature, ks.SUN: _sun}


def pack_numbers(numbers: object) -> bytes:
    """An array policy's radio broadcast: marked, so a receiver never reads another payload as numbers."""
    values = np.nan_to_num(np.asarray(numbers, dtype=np.float32), nan=0.0, posinf=1.0, neginf=-1.0)
    return RADIO_MARK + np.clip(values, -1.0, 1.0).astype(np.float32).tobytes()


def unpack_numbers(payload: bytes) -> np.ndarray | None:
    """The numbers of ``pack_numbers``'s payload, None for any other payload."""
    if len(payload) != len(RADIO_MARK) + 4 * RADIO_FLOATS or not payload.startswith(RADIO_MARK):
        return None
    values = np.frombuffer(payload[len(RADIO_MARK):], dtype=np.float32)
    return np.clip(np.nan_to_num(values, nan=0.0), -1.0, 1.0)
