"""The bridge's core, without Zenoh: LunarSim samples in, ROS 2 messages out, and the other way round.

``outbound(key, payload)`` turns one LunarSim sample into the ROS messages it makes (topic, type, fields);
``inbound(topic, payload)`` turns one CDR sample a ROS node published into the LunarSim messages to publish. Both
refuse what they cannot use (a malformed payload, an unknown rover, a goal out of bounds) by counting it in
``rejected`` and returning nothing: no input ends the loop. The rosbag2 export drives the same ``outbound``.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

from bus.rejections import Rejections
from ros2_bridge import inbound, mapping, ros_types
from ros2_bridge import topics as tp
from ros2_bridge.odometry import DrivenEstimate
from rover_agent.estimation.pose_filter import NoiseModel
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.wire_limits import ACTION_ID_STRIDE, MAX_ID

log = logging.getLogger("lunarsim.ros2")
RosOut = tuple[str, str, dict[str, Any]]
"""(topic, ROS type, fields) of one ROS message to publish."""

ROVER_SOURCES = {ks.PERCEPTION: m.Perception, ks.GYROSCOPE: m.Gyroscope, ks.BATTERY: m.Battery, ks.PHOTO: m.Photo,
                 ks.NAVIGATION_STATUS: m.NavigationStatus, ks.ACTION_REJECTED: m.ActionRejected,
                 ks.MISSION_DIRECTION: m.MissionDirection, ks.CALIBRATION: m.Calibration,
                 ks.CANCEL_RESULT: m.CancelResult, ks.POSE_ESTIMATE: m.EstimatedPose}
"""The rover keys the bridge reads, and their models."""
WORLD_SENSES = frozenset({ks.PERCEPTION, ks.GYROSCOPE})
"""A rover is served once the world has sent it one of these: the world has it."""


@dataclass
class ActionIds:
    """Ids of the actions the bridge sends for one rover, as an agent makes them (``schemas.wire_limits``): the
    simulated millisecond of the first one, times the stride, plus a count."""

    base: int | None = None
    count: int = 0

    def next(self, sim_time: float) -> int:
        if self.base is None:
            self.base = int(max(0.0, sim_time) * 1000)
        self.count += 1
        return self.base * ACTION_ID_STRIDE + self.count


@dataclass
class RoverSide:
    estimate: DrivenEstimate | None = None
    """A driven rover's pose estimate, which the bridge keeps in its agent's place (``ros2_bridge.odometry``)."""
    ids: ActionIds = field(default_factory=ActionIds)
    then_rotate: tuple[int, float] | None = None
    """A move goal's rotation, sent once its move (this id) has completed."""
    goal_index: int = -1
    """The goal the lander last sent the rover to."""
    state: str = "waiting"
    """What the ROS 2 node driving the rover last said it does (``--drive`` rovers)."""
    heard: int = 0
    """The last action whose end the bridge has passed on: a driven rover's status says so, so the world stops
    sending that end again."""


class Translator:
    def __init__(self, keys: ks.Keyspace, layout: mapping.RayLayout | None = None, pitch_std_deg: float = 0.0,
                 truth: bool = False, rejected: Rejections | None = None, noise: NoiseModel | None = None) -> None:
        self.keys = keys
        self.noise = noise or NoiseModel()
        """The navigation noise a driven rover's estimate assumes (the scenario's, as its agent would)."""
        self.layout = layout or mapping.RayLayout()
        self.pitch_std_deg = pitch_std_deg
        self.truth = truth
        self.rejected = rejected or Rejections(log, "ros2 bridge")
        self.rovers: dict[int, RoverSide] = {}
        self.agents: set[int] = set()
        """Rovers whose agent runs (its liveliness token is there): they take no requests from ROS 2, which would
        fight the agent for the rover and, with action ids of their own, lock the agent's out as stale."""
        self.driven: frozenset[int] = frozenset()
        """Rovers the bridge holds the token of for an outside (ROS 2) agent (``--drive``): they take requests."""
        self.sim_time = 0.0
        self.requests: list[Out] = []
        """LunarSim messages a LunarSim sample has made due (a move goal's rotation once its move completed): the
        loop publishes and clears them."""
        self._rover_head = f"{keys.prefix}/rover/"
        self._area = {keys.clock: self._clock, keys.lander(ks.MAP): self._map}
        if truth:
            self._area[keys.state] = self._state

    def lunarsim_keys(self) -> list[str]:
        """What the bridge subscribes to; world truth only with ``truth``."""
        out = [self.keys.rovers(topic) for topic in ROVER_SOURCES] + [self.keys.clock, self.keys.lander(ks.MAP)]
        return [*out, self.keys.state] if self.truth else out

    # ---- LunarSim -> ROS 2 ----

    def outbound(self, key: str, payload: bytes) -> list[RosOut]:
        try:
            if key.startswith(self._rover_head):
                return self._rover_sample(key, payload)
            handler = self._area.get(key)
            return handler(payload) if handler is not None else []
        except (codec.DecodeError, ValueError) as exc:
            self.rejected.count(key.rsplit("/", 1)[-1], exc, key)
            return []

    def _rover_sample(self, key: str, payload: bytes) -> list[RosOut]:
        rover_id, topic = self.keys.parse_rover_key(key)
        model = ROVER_SOURCES.get(topic)
        if model is None:
            return []
        if not 1 <= rover_id <= MAX_ID:
            raise ValueError(f"no rover {rover_id}")
        msg = codec.decode(model, payload)
        if rover_id not in self.rovers:
            if topic not in WORLD_SENSES:
                return []
            driven = rover_id in self.driven
            self.rovers[rover_id] = RoverSide(DrivenEstimate(self.noise) if driven else None)
        return self._for_rover(rover_id, self.rovers[rover_id], msg)

    def _for_rover(self, rid: int, side: RoverSide, msg: m.Message) -> list[RosOut]:
        if isinstance(msg, m.Perception):
            return [(tp.SCAN.for_rover(rid), tp.SCAN.ros_type, mapping.scan(msg, rid, self.layout))]
        if isinstance(msg, m.Gyroscope):
            return [(tp.IMU.for_rover(rid), tp.IMU.ros_type, mapping.imu(msg, rid, self.pitch_std_deg))]
        if isinstance(msg, m.EstimatedPose):  # a driven rover's is the bridge's own, made odom as it was published
            return [] if side.estimate is not None else [self._odom(rid, msg)]
        if isinstance(msg, m.Battery):
            return [(tp.BATTERY.for_rover(rid), tp.BATTERY.ros_type, mapping.battery(msg, rid))]
        if isinstance(msg, m.Photo):
            return [(tp.PHOTO.for_rover(rid), tp.PHOTO.ros_type, mapping.photo(msg, rid))]
        if isinstance(msg, m.NavigationStatus):
            odom = self._estimate(rid, side, lambda e: e.status(msg))
            self._rotation_due(rid, side, msg)
            if msg.outcome != "running":
                self._heard(rid, side, msg.action_id)
            return [*odom, (tp.NAVIGATION.for_rover(rid), tp.NAVIGATION.ros_type, mapping.navigation(msg, rid))]
        if isinstance(msg, m.ActionRejected):
            self._forget_rotation(side, msg.action_id)
            self._heard(rid, side, msg.action_id)
            return [(tp.NAVIGATION.for_rover(rid), tp.NAVIGATION.ros_type, mapping.refusal(msg, rid, self.sim_time))]
        if isinstance(msg, m.MissionDirection):
            side.goal_index = msg.goal_index
            return [(tp.MISSION_GOAL.for_rover(rid), tp.MISSION_GOAL.ros_type,
                     mapping.mission_goal(msg, rid, self.sim_time))]
        if isinstance(msg, m.Calibration):
            return self._estimate(rid, side, lambda e: e.calibration(msg, self.sim_time))
        if isinstance(msg, m.CancelResult):
            self._forget_rotation(side, msg.action_id)
            return self._estimate(rid, side, lambda e: e.cancel_result(msg, self.sim_time))
        return []

    def _estimate(self, rid: int, side: RoverSide, update) -> list[RosOut]:
        """A driven rover's estimate, updated: published on its ``pose_estimate`` key as its agent would, and its
        ``odom`` at once (the sample the key brings back is not made odom twice)."""
        if side.estimate is None or (estimate := update(side.estimate)) is None:
            return []
        self.requests.append((self.keys.rover(rid, ks.POSE_ESTIMATE), estimate))
        return [self._odom(rid, estimate)]

    @staticmethod
    def _odom(rid: int, estimate: m.EstimatedPose) -> RosOut:
        return tp.ODOM.for_rover(rid), tp.ODOM.ros_type, mapping.odometry(estimate, rid)

    def _clock(self, payload: bytes) -> list[RosOut]:
        msg = codec.decode(m.Clock, payload)
        self.sim_time = msg.sim_time
        return [(tp.CLOCK.name, tp.CLOCK.ros_type, mapping.clock(msg))]

    def _map(self, payload: bytes) -> list[RosOut]:
        from lander_agent.map_view import for_viewers
        from lander_agent.mapping import from_message

        msg = for_viewers(codec.decode(m.LanderMap, payload))
        _, codes = from_message(msg)
        return [(tp.MAP.name, tp.MAP.ros_type, mapping.occupancy(msg, codes))]

    def _state(self, payload: bytes) -> list[RosOut]:
        state = codec.decode(m.WorldState, payload)
        out = [(tp.TF.name, tp.TF.ros_type, mapping.truth_transforms(state))]
        return out + [(tp.TRUE_ODOM.for_rover(r.id), tp.TRUE_ODOM.ros_type, mapping.truth_odometry(r, state.stamp))
                      for r in state.rovers if r.id in self.rovers]

    # ---- ROS 2 -> LunarSim ----

    def inbound(self, topic: str, payload: bytes) -> list[Out]:
        """A sample a ROS node published on one of the bridge's inbound topics (its full name)."""
        try:
            if topic == tp.GROUND_GOAL.name:
                goal = inbound.ground_goal(ros_types.decode(tp.GROUND_GOAL.ros_type, payload))
                return [(self.keys.ground_command, goal)]
            rover_id, spec = self._rover_topic(topic)
            return self._rover_request(rover_id, spec, ros_types.decode(spec.ros_type, payload))
        except (ros_types.CdrError, ValueError, KeyError, TypeError) as exc:
            self.rejected.count(topic.rsplit("/", 1)[-1], exc, topic)
            return []

    def _rover_topic(self, topic: str) -> tuple[int, tp.Topic]:
        head, _, suffix = topic.lstrip("/").partition("/")
        number = head.removeprefix("rover_")
        spec = INBOUND.get(suffix)
        if spec is None or not head.startswith("rover_") or not (number.isascii() and number.isdigit()):
            raise ValueError(f"topic {topic[:60]!r} is none of the bridge's")
        if len(number) > len(str(MAX_ID)) or int(number) not in self.rovers:
            raise ValueError(f"no rover {number[:12]} in this world")
        return int(number), spec

    def agent(self, rover_id: int, alive: bool) -> None:
        """A rover agent's liveliness token came or went."""
        if alive:
            self.agents.add(rover_id)
        else:
            self.agents.discard(rover_id)

    def _rover_request(self, rid: int, spec: tp.Topic, fields: dict[str, Any]) -> list[Out]:
        if rid in self.agents and rid not in self.driven:
            raise ValueError(f"rover {rid} is driven by its agent: ROS 2 drives only rovers without one")
        side = self.rovers[rid]
        if spec is tp.CANCEL:
            side.then_rotate = None
            return [(self.keys.rover(rid, ks.CANCEL_ACTION), m.CancelAction())]
        if spec is tp.SPEED:
            return [(self.keys.rover(rid, ks.SPEED_ACTION), inbound.speed(fields))]
        if spec is tp.STATE:
            if rid not in self.driven:
                raise ValueError(f"rover {rid} is not driven from ROS 2 (--drive): its agent says its state")
            side.state = codec.checked(m.RoverStatus(stamp=0, state=fields["data"])).state
            return [self._status(rid, side)]
        if spec is tp.TAKE_PHOTO:
            label = inbound.photo_request(fields).label
            return [(self.keys.rover(rid, ks.PHOTO_ACTION), m.PhotoAction(label=label, action_id=self._id(side)))]
        goal = inbound.move_goal(fields, rid)
        if goal.move is None:
            return [self._rotate(rid, side, goal.rotate_deg or 0.0)]
        action_id = self._id(side)
        side.then_rotate = (action_id, goal.rotate_deg) if goal.rotate_deg is not None else None
        return [self._sent(rid, side, ks.MOVE_ACTION, m.MoveAction(x=goal.move[0], z=goal.move[1],
                                                                    action_id=action_id))]

    def _sent(self, rid: int, side: RoverSide, topic: str, msg: m.MoveAction | m.RotateAction) -> Out:
        """An action for the rover, which a driven rover's estimate follows."""
        if side.estimate is not None:
            side.estimate.sent(msg.action_id, msg)
        return self.keys.rover(rid, topic), msg

    def _heard(self, rid: int, side: RoverSide, action_id: int) -> None:
        if rid in self.driven and action_id > side.heard:
            side.heard = action_id
            self.requests.append(self._status(rid, side))

    def _status(self, rid: int, side: RoverSide) -> Out:
        """A driven rover's status, as its agent would publish it."""
        return self.keys.rover(rid, ks.STATUS), m.RoverStatus(stamp=self.sim_time, state=side.state,
                                                              goal_index=side.goal_index, action_id=side.heard)

    def _id(self, side: RoverSide) -> int:
        return side.ids.next(self.sim_time)

    def _rotate(self, rid: int, side: RoverSide, degrees: float) -> Out:
        side.then_rotate = None
        return self._sent(rid, side, ks.ROTATE_ACTION, m.RotateAction(degrees=degrees, action_id=self._id(side)))

    def _rotation_due(self, rid: int, side: RoverSide, msg: m.NavigationStatus) -> None:
        """A move goal's rotation goes out once the world says its move completed; any other end drops it."""
        if side.then_rotate is None or side.then_rotate[0] != msg.action_id or msg.outcome == "running":
            return
        if msg.outcome == "completed":
            self.requests.append(self._rotate(rid, side, side.then_rotate[1]))
        side.then_rotate = None

    @staticmethod
    def _forget_rotation(side: RoverSide, action_id: int) -> None:
        if side.then_rotate is not None and side.then_rotate[0] == action_id:
            side.then_rotate = None


INBOUND: dict[str, tp.Topic] = {t.suffix: t for t in tp.TOPICS if t.direction == "in" and t.per_rover}
"""Per-rover inbound topics by the part after ``/rover_<id>/``."""
