"""The pose estimate of a rover a ROS 2 node drives (``--drive``): with no LunarSim agent on board, the bridge holds
the rover's place as its flight software (its liveliness token, its status) and keeps the estimate an agent would
keep from the same actions, with the agent's own filter (``rover_agent.estimation.pose_filter``): where the lander
set it down, each action's end as the world reports it, the covariance its navigation noise gives. It publishes it
on ``rover/<id>/pose_estimate`` as an agent does, so ``odom`` is made from that key for every rover alike.

It has no landmarks to correct itself with (a ROS node that localises publishes its own estimate), and takes the
lander's calibration only before the rover has acted: joined while the rover is under way, it counts from where it
joined (the origin, facing +z) rather than jump back to where the rover was set down.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

from rover_agent.estimation.pose_filter import Localisation, NoiseModel
from schemas import messages as m
from shared.pose import Pose

REMEMBERED_ACTIONS = 16
"""Actions sent and not yet answered that the estimate keeps: one running and perhaps one re-sent."""


@dataclass(frozen=True)
class _Sent:
    kind: str
    x: float = 0.0
    z: float = 0.0
    degrees: float = 0.0


class DrivenEstimate:
    """One driven rover's estimate; each method returns the ``EstimatedPose`` to publish, or None (no news)."""

    def __init__(self, noise: NoiseModel) -> None:
        self.localisation = Localisation(Pose(0.0, 0.0, 0.0), noise)
        self.calibrated = False
        self.acted = False
        self._sent: OrderedDict[int, _Sent] = OrderedDict()
        self._running: tuple[int, _Sent, Pose] | None = None

    def calibration(self, msg: m.Calibration, now: float) -> m.EstimatedPose | None:
        if self.calibrated or self.acted:
            return None
        self.localisation = Localisation(Pose(msg.x, msg.z, msg.heading_deg % 360.0), self.localisation.noise)
        self.calibrated = True
        return self._report(now)

    def sent(self, action_id: int, msg: m.MoveAction | m.RotateAction) -> None:
        """An action the bridge sent for the ROS node."""
        sent = _Sent("move", msg.x, msg.z) if isinstance(msg, m.MoveAction) else _Sent("rotate", degrees=msg.degrees)
        self._sent[action_id] = sent
        self._sent.move_to_end(action_id)
        while len(self._sent) > REMEMBERED_ACTIONS:
            self._sent.popitem(last=False)

    def status(self, msg: m.NavigationStatus) -> m.EstimatedPose | None:
        running = self._start(msg.action_id, msg.action)
        if running is None:
            return None
        action_id, sent, start = running
        self.acted = True
        loc = self.localisation
        if msg.outcome == "running":
            if sent.kind != "move":
                return self._report(msg.stamp, start, moving=True)
            walked = max(0.0, (sent.x ** 2 + sent.z ** 2) ** 0.5 - abs(msg.remaining))
            pose, cov = loc.part_way(start, sent.x, sent.z, walked)
            return self._report(msg.stamp, pose, cov, moving=True)
        if msg.outcome == "completed":
            if sent.kind == "move":
                loc.moved(start, sent.x, sent.z)
            else:
                loc.rotated(start, sent.degrees)
            self._end(action_id)
            return self._report(msg.stamp)
        return None  # ended early: the CancelResult that follows says where

    def cancel_result(self, msg: m.CancelResult, now: float) -> m.EstimatedPose | None:
        running = self._start(msg.action_id, None)
        if running is None:
            return None
        self.acted = True
        self.localisation.stopped_early(running[2], msg.x, msg.z, msg.angle_deg)
        self._end(msg.action_id)
        return self._report(now)

    def _start(self, action_id: int, kind: str | None) -> tuple[int, _Sent, Pose] | None:
        """The running action ``action_id`` names: the one under way, or one sent that starts now from here."""
        if self._running is not None and self._running[0] == action_id:
            return self._running
        sent = self._sent.get(action_id)
        if sent is None or (kind is not None and sent.kind != kind):
            return None
        self._running = (action_id, sent, self.localisation.pose)
        return self._running

    def _end(self, action_id: int) -> None:
        self._sent.pop(action_id, None)
        self._running = None

    def _report(self, stamp: float, pose: Pose | None = None, cov: list[list[float]] | None = None,
                moving: bool = False) -> m.EstimatedPose:
        pose = pose or self.localisation.pose
        c = cov or self.localisation.cov
        return m.EstimatedPose(stamp=max(0.0, stamp), x=pose.x, z=pose.z, heading_deg=pose.heading % 360.0,
                               cov_xx=c[0][0], cov_xz=c[0][1], cov_zz=c[1][1], cov_xh=c[0][2], cov_zh=c[1][2],
                               cov_hh=c[2][2], moving=moving)
