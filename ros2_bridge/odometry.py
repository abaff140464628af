"""A rover's odometry from what the rover itself knows: where the lander set it down (its calibration), the moves
and rotations it sent, and the world's answers to them (navigation status, where a cancelled move stopped).

It is the dead reckoning a wheel odometer gives, with the rule the agent's own dead reckoning applies: a completed
move ends on its goal facing along it, a rotation adds its angle, a move that ended early ends where its
CancelResult says; while an action runs, the status's remaining metres or degrees place the rover along it. It is
not ground truth, and not the agent's corrected estimate (which the agent does not publish).

The lander re-sends the calibration every second; like the agent, the odometry takes the first one, and only
before it has seen the rover act: a bridge that joins a rover already under way cannot know where it is, and counts
from where it joined (the origin, facing +z) instead of jumping back to where the rover was set down.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass

from schemas import messages as m
from schemas.frames import bearing_deg, to_world
from shared.pose import Pose

REMEMBERED_ACTIONS = 16
"""Actions sent and not yet answered that the odometry keeps: an agent has one running and perhaps one re-sent."""


@dataclass(frozen=True)
class _Sent:
    kind: str
    x: float = 0.0
    z: float = 0.0
    degrees: float = 0.0


class Odometry:
    """Dead reckoning of one rover. ``stamp`` is the simulated time of the last change."""

    def __init__(self) -> None:
        self.pose = Pose(0.0, 0.0, 0.0)
        self.calibrated = False
        self.acted = False
        self.stamp = 0.0
        self._sent: OrderedDict[int, _Sent] = OrderedDict()
        self._running: tuple[int, _Sent, Pose] | None = None

    def calibration(self, msg: m.Calibration) -> bool:
        """Place the rover where the lander set it down; False when that is no news (see the module's docstring)."""
        if self.calibrated or self.acted:
            return False
        self.pose = Pose(msg.x, msg.z, msg.heading_deg % 360.0)
        self.calibrated = True
        return True

    def sent_move(self, msg: m.MoveAction) -> None:
        self._remember(msg.action_id, _Sent("move", msg.x, msg.z))

    def sent_rotate(self, msg: m.RotateAction) -> None:
        self._remember(msg.action_id, _Sent("rotate", degrees=msg.degrees))

    def _remember(self, action_id: int, sent: _Sent) -> None:
        self._sent[action_id] = sent
        self._sent.move_to_end(action_id)
        while len(self._sent) > REMEMBERED_ACTIONS:
            self._sent.popitem(last=False)

    def status(self, msg: m.NavigationStatus) -> bool:
        """Moves the pose along the action the status is about; False when it is about none the rover sent (or
        one already ended)."""
        running = self._start(msg.action_id, msg.action)
        if running is None:
            return False
        action_id, sent, start = running
        self.stamp, self.acted = msg.stamp, True
        if msg.outcome == "completed":
            self.pose = _after(start, sent, 1.0)
            self._end(action_id)
        elif msg.outcome == "running":
            self.pose = _after(start, sent, _share(sent, msg.remaining))
        return True

    def cancel_result(self, msg: m.CancelResult) -> bool:
        """Where the move (or rotation) that ended early stopped, relative to its start."""
        running = self._running
        if running is None or running[0] != msg.action_id:
            running = self._start(msg.action_id, None)
        if running is None:
            return False
        _, _, start = running
        self.acted = True
        self.pose = start.after_partial(msg.x, msg.z, msg.angle_deg)
        self._end(msg.action_id)
        return True

    def _start(self, action_id: int, kind: str | None) -> tuple[int, _Sent, Pose] | None:
        """The running action ``action_id`` names: the one under way, or one sent that starts now from here."""
        if self._running is not None and self._running[0] == action_id:
            return self._running
        sent = self._sent.get(action_id)
        if sent is None or (kind is not None and sent.kind != kind):
            return None
        self._running = (action_id, sent, self.pose)
        return self._running

    def _end(self, action_id: int) -> None:
        self._sent.pop(action_id, None)
        self._running = None


def _share(sent: _Sent, remaining: float) -> float:
    total = math.hypot(sent.x, sent.z) if sent.kind == "move" else abs(sent.degrees)
    if total <= 1e-9:
        return 1.0
    return min(1.0, max(0.0, 1.0 - abs(remaining) / total))


def _after(start: Pose, sent: _Sent, share: float) -> Pose:
    if sent.kind == "rotate":
        return Pose(start.x, start.z, (start.heading + share * sent.degrees) % 360.0)
    if math.hypot(sent.x, sent.z) <= 1e-9:
        return start
    x, z = to_world(start.x, start.z, start.heading, share * sent.x, share * sent.z)
    return Pose(x, z, bearing_deg(x - start.x, z - start.z) if share > 0 else start.heading)
