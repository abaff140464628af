"""A policy's action as the samples its rover publishes.

Two forms are accepted: the array action of ``spaces.action_space`` (for learned policies), and a list of
``(key, message)`` pairs as a rover agent returns them (for policies that speak messages, like the shipped
agent). A list may only publish on the rover's own keys, and only what a rover publishes: a policy cannot
forge another rover's samples or the lander's.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from gymnasium import spaces

from rover_env.spaces import COMMANDS, GOAL_REPORTS, pack_numbers
from schemas import keyspace as ks
from schemas import messages as m
from schemas import radio
from schemas.errors import LunarSimError
from schemas.messages import Out


class ActionError(LunarSimError, ValueError):
    """A policy's action that no rover could publish: names the rover and what is wrong."""


class ArrayActions:
    """Turns one rover's array actions into messages, as an agent would publish them: actions numbered, goal
    reports radioed to the lander, and a status naming the last action whose end the rover heard, so the world
    stops re-sending that end (``world_service.actuation.ledger``) and a collision is told once."""

    def __init__(self, keys: ks.Keyspace, rover_id: int, others: list[int], space: spaces.Dict) -> None:
        self.keys, self.id, self.others, self.space = keys, rover_id, others, space
        self.next_id = 1
        self.state: m.RoverState = "waiting"
        self.direction: m.MissionDirection | None = None  # the last heard: the goal a goal report is about
        self.heard_action = 0  # the last action whose end (or refusal) the rover heard
        self._told = 0  # the heard_action its last status carried
        self.moving = 0  # the move or rotate sent whose end it has not heard (0: none)
        self.photo = 0  # the photo asked for and not yet back (0: none)

    def hear(self, topic: str, message: m.Message) -> None:
        if topic == ks.MISSION_DIRECTION:
            self.direction = message
        ended = ((isinstance(message, m.NavigationStatus) and message.outcome != "running")
                 or isinstance(message, m.CancelResult | m.ActionRejected))
        if ended:
            self.heard_action = max(self.heard_action, message.action_id)
            if message.action_id == self.moving:
                self.moving = 0
            if message.action_id == self.photo:  # refused: no photo comes
                self.photo = 0
        if isinstance(message, m.Photo):
            self.photo = 0

    def mask(self) -> dict[str, np.ndarray]:
        """Which values of ``command`` and ``goal`` the rover can act on now (1) and which it cannot (0): no second
        move or rotate while one runs, a cancel only then, one photo at a time, no goal report before a goal."""
        command = {"none": True, "move": not self.moving, "rotate": not self.moving, "cancel": bool(self.moving),
                   "photo": not self.photo}
        has_goal = self.direction is not None
        goal = {"none": True, "reached": has_goal, "stuck": has_goal}
        return {"command": np.array([command[c] for c in COMMANDS], np.int8),
                "goal": np.array([goal[g] for g in GOAL_REPORTS], np.int8)}

    def messages(self, action: Mapping[str, np.ndarray], now: float) -> list[Out]:
        self._check(action)
        out: list[Out] = []
        command = COMMANDS[int(action["command"])]
        if command != "none":
            out.append(self._command(command, action))
        report = GOAL_REPORTS[int(action["goal"])]
        if report != "none" and self.direction is not None:
            out += self._goal_report(report, self.direction)
        if report != "none" or self.heard_action != self._told:
            out.append(self._status(now))
        if int(action["speed"]):
            out.append((self.keys.rover(self.id, ks.SPEED_ACTION), m.SpeedAction(level=int(action["speed"]))))
        if int(action["radio"]) and self.others:
            out.append((self.keys.rover(self.id, ks.COMM_OUT),
                        m.OutboundComm(targets=self.others, payload=pack_numbers(action["radio_out"]))))
        return out

    def _check(self, action: Mapping[str, np.ndarray]) -> None:
        if not isinstance(action, Mapping) or set(action) != set(self.space.spaces):
            given = sorted(action) if isinstance(action, Mapping) else type(action).__name__
            raise ActionError(f"rover {self.id}: an array action has the keys {sorted(self.space.spaces)}, got {given}")
        bad = [name for name, sub in self.space.spaces.items() if not _inside(sub, action[name])]
        if bad:
            raise ActionError(f"rover {self.id}: outside the action space: "
                              + ", ".join(f"{name}={action[name]!r}" for name in bad))

    def _goal_report(self, outcome: str, direction: m.MissionDirection) -> list[Out]:
        final = direction.goal_index == direction.goals_total - 1
        self.state = "stuck" if outcome == "stuck" else "done" if final else "waiting"
        said = radio.pack(radio.GoalReport(goal_index=direction.goal_index, outcome=outcome))
        return [(self.keys.rover(self.id, ks.COMM_OUT), m.OutboundComm(targets=[ks.LANDER_ID], payload=said))]

    def _status(self, now: float) -> Out:
        self._told = self.heard_action
        goal = self.direction.goal_index if self.direction is not None else -1
        return self.keys.rover(self.id, ks.STATUS), m.RoverStatus(stamp=now, state=self.state, goal_index=goal,
                                                                   action_id=self.heard_action)

    def _command(self, command: str, action: Mapping[str, np.ndarray]) -> Out:
        action_id, self.next_id = self.next_id, self.next_id + 1
        if command in ("move", "rotate"):
            self.moving = action_id
        elif command == "photo":
            self.photo = action_id
        if command == "move":
            x, z = (float(v) for v in action["move"])
            return self.keys.rover(self.id, ks.MOVE_ACTION), m.MoveAction(x=x, z=z, action_id=action_id)
        if command == "rotate":
            degrees = float(action["rotate"][0])
            return self.keys.rover(self.id, ks.ROTATE_ACTION), m.RotateAction(degrees=degrees, action_id=action_id)
        if command == "cancel":
            return self.keys.rover(self.id, ks.CANCEL_ACTION), m.CancelAction(action_id=0)
        return self.keys.rover(self.id, ks.PHOTO_ACTION), m.PhotoAction(label=f"photo{action_id}", action_id=action_id)


def _inside(sub: spaces.Space, value: object) -> bool:
    """``sub.contains``, for the two kinds of space actions use, at a third of its cost (it runs for every rover
    on every step); plain numbers and lists are accepted for a Box as for a Discrete."""
    if isinstance(sub, spaces.Discrete):
        return isinstance(value, int | np.integer) and sub.start <= value < sub.start + sub.n
    try:
        array = np.asarray(value, dtype=sub.dtype)
    except (TypeError, ValueError):
        return False
    return array.shape == sub.shape and bool(np.all(array >= sub.low) and np.all(array <= sub.high))


def checked_messages(keys: ks.Keyspace, rover_id: int, messages: list) -> list[Out]:
    """A message-form action, refused whole if any sample is not the rover's own to publish."""
    for sample in messages:
        if not (isinstance(sample, tuple) and len(sample) == 2 and isinstance(sample[1], m.Message)):
            raise ActionError(f"rover {rover_id}: a message action is a list of (key, message) pairs, got {sample!r}")
        key, message = sample
        try:
            rid, topic = keys.parse_rover_key(key)
        except ValueError as exc:
            raise ActionError(f"rover {rover_id}: {exc}") from None
        if rid != rover_id or topic not in ks.ROVER_OUTPUTS:
            raise ActionError(f"rover {rover_id} may not publish on {key!r}: only on its own keys "
                              f"({', '.join(sorted(ks.ROVER_OUTPUTS))})")
        if not isinstance(message, m.TOPIC_MODELS[topic]):
            raise ActionError(f"rover {rover_id}: {topic} carries {m.TOPIC_MODELS[topic].__name__}, "
                              f"got {type(message).__name__}")
    return messages
