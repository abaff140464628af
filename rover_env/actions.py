"""A policy's action as the samples its rover publishes.

Two forms are accepted: the array action of ``spaces.action_space`` (for learned policies), and a list of
``(key, message)`` pairs as a rover agent returns them (for policies that speak messages, like the shipped
agent). A list may only publish on the rover's own keys, and only what a rover publishes: a policy cannot
forge another rover's samples or the lander's.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from rover_env.spaces import COMMANDS, GOAL_REPORTS
from schemas import keyspace as ks
from schemas import messages as m
from schemas import radio

Out = tuple[str, m.Message]
PUBLISHED_TOPICS = frozenset({ks.MOVE_ACTION, ks.ROTATE_ACTION, ks.CANCEL_ACTION, ks.SPEED_ACTION, ks.PHOTO_ACTION,
                              ks.COMM_OUT, ks.STATUS, ks.ACK})
"""What a rover agent publishes (the world's inputs, its status and its lockstep ack)."""


class ActionError(ValueError):
    """A policy's action that no rover could publish: names the rover and what is wrong."""


class ArrayActions:
    """Turns one rover's array actions into messages, numbering its actions as an agent does."""

    def __init__(self, keys: ks.Keyspace, rover_id: int, others: list[int]) -> None:
        self.keys, self.id, self.others = keys, rover_id, others
        self.next_id = 1

    def messages(self, action: Mapping[str, np.ndarray], direction: m.MissionDirection | None,
                 now: float) -> list[Out]:
        """``direction``: the last mission direction the rover heard (the goal a goal report is about)."""
        out: list[Out] = []
        command = COMMANDS[int(action["command"])]
        if command != "none":
            out.append(self._command(command, action))
        report = GOAL_REPORTS[int(action.get("goal", 0))]
        if report != "none" and direction is not None:
            out += self._goal_report(report, direction, now)
        if int(action["speed"]):
            out.append((self.keys.rover(self.id, ks.SPEED_ACTION), m.SpeedAction(level=int(action["speed"]))))
        if int(action["radio"]) and self.others:
            payload = np.asarray(action["radio_out"], dtype=np.float32).tobytes()
            out.append((self.keys.rover(self.id, ks.COMM_OUT), m.OutboundComm(targets=self.others, payload=payload)))
        return out

    def _goal_report(self, outcome: str, direction: m.MissionDirection, now: float) -> list[Out]:
        final = direction.goal_index == direction.goals_total - 1
        state = "stuck" if outcome == "stuck" else "done" if final else "waiting"
        said = radio.pack(radio.GoalReport(goal_index=direction.goal_index, outcome=outcome))
        return [(self.keys.rover(self.id, ks.COMM_OUT), m.OutboundComm(targets=[ks.LANDER_ID], payload=said)),
                (self.keys.rover(self.id, ks.STATUS), m.RoverStatus(stamp=now, state=state,
                                                                     goal_index=direction.goal_index))]

    def _command(self, command: str, action: Mapping[str, np.ndarray]) -> Out:
        action_id, self.next_id = self.next_id, self.next_id + 1
        if command == "move":
            x, z = (float(v) for v in action["move"])
            return self.keys.rover(self.id, ks.MOVE_ACTION), m.MoveAction(x=x, z=z, action_id=action_id)
        if command == "rotate":
            degrees = float(action["rotate"][0])
            return self.keys.rover(self.id, ks.ROTATE_ACTION), m.RotateAction(degrees=degrees, action_id=action_id)
        if command == "cancel":
            return self.keys.rover(self.id, ks.CANCEL_ACTION), m.CancelAction(action_id=0)
        return self.keys.rover(self.id, ks.PHOTO_ACTION), m.PhotoAction(label=f"photo{action_id}", action_id=action_id)


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
        if rid != rover_id or topic not in PUBLISHED_TOPICS:
            raise ActionError(f"rover {rover_id} may not publish on {key!r}: only on its own keys "
                              f"({', '.join(sorted(PUBLISHED_TOPICS))})")
        if not isinstance(message, m.TOPIC_MODELS[topic]):
            raise ActionError(f"rover {rover_id}: {topic} carries {m.TOPIC_MODELS[topic].__name__}, "
                              f"got {type(message).__name__}")
    return messages
