"""A rover driven from ROS 2: a go-to-goal node that knows only ROS 2 topics, on rmw_zenoh's wire format.

It reads ``/rover_<id>/odom`` (where the rover thinks it is), ``/rover_<id>/scan`` (what is in the way),
``/rover_<id>/imu`` (its pitch), ``/rover_<id>/mission_goal`` (where the lander sends it) and
``/rover_<id>/navigation_status`` (how its last goal ended), and publishes ``/rover_<id>/move_goal``: a step
towards the goal in ``rover_<id>/base_link``, turned aside to the free ray nearest the goal's bearing when the scan
shows something in the way, or a turn on the spot when the goal is behind. A crater is observed from its crest:
once the scan shows crater terrain (intensity 5) just ahead, the node climbs in short steps and stops where the
pitch, nose up on the rim, levels out. On ``/rover_<id>/state`` it says what it does (``migration``, then
``done`` at its goal or ``stuck`` as close as it gets), as LunarSim's statistics read a rover's state.

Plain ``eclipse-zenoh`` and ``rosbags`` (no ROS install); a node on rclpy would use the same topics. Start the
mission with this rover left to it, then the node:

    lunarsim run scenarios/crater_observation.yaml --external 1
    python examples/ros2_rover.py --id 1 --connect tcp/127.0.0.1:7447
"""

from __future__ import annotations

import argparse
import math
import queue
import struct
import time
import uuid

import numpy as np
import zenoh
from rosbags.typesys import Stores, get_typestore

STORE = get_typestore(Stores.ROS2_JAZZY)
T = STORE.types
ARRIVED_M = 2.0
"""Close enough to the goal to stop."""
STEP_M = 6.0
"""The longest step: well inside the scan's range, so the world sees the target in view."""
CLEARANCE_M = 1.5
"""Room a step keeps from anything the scan shows along it."""
CREST_M = 2.5
"""Crater terrain this close ahead: the rover stands on the crest."""
CRATER_TERRAIN = 5
"""The scan's intensity of a crater terrain hit."""
CLIMB_STEP_M = 1.5
"""Steps up a crater's rim: short, so the crest is not overshot into the bowl."""
CLIMBING_DEG = 4.0
LEVEL_DEG = 1.5
"""Nose up by more than CLIMBING_DEG on the rim, then by less than LEVEL_DEG: the crest."""
HALF_VIEW_RAD = math.radians(90)
"""A goal further round than this is turned to first."""
ANSWER_WAIT_S = 30.0
"""Wall seconds to wait for a goal's end before sending another."""
GIVE_UP_AFTER = 8
"""Goals in a row that end blocked (collided or refused): the rover is as close as it gets (a crater's rim)."""
SIDESTEP_RAD = math.radians(40)
"""After a blocked goal the next one tries this far to one side, then the other, further each time."""


def key(domain: int, topic: str, ros_type: str) -> str:
    """rmw_zenoh's data key: ``<domain>/<topic>/<pkg>::msg::dds_::<Name>_/<RIHS01 hash>``."""
    package, kind, name = ros_type.split("/")
    return f"{domain}/{topic.strip('/')}/{package}::{kind}::dds_::{name}_/{STORE.hash_rihs01(ros_type)}"


def yaw_of(q) -> float:
    return math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))


def crest_ahead(scan, bearing: float) -> float:
    """How far ahead crater terrain starts on the ray nearest ``bearing`` (inf: none in range)."""
    i = int(np.argmin(np.abs(scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges)) - bearing)))
    return float(scan.ranges[i]) if int(scan.intensities[i]) == CRATER_TERRAIN else math.inf


def free_bearing(scan, wanted: float, step: float) -> tuple[float, float] | None:
    """The ray nearest ``wanted`` with room for a step (shortened to what it has), or None if every ray is blocked."""
    angles = scan.angle_min + scan.angle_increment * np.arange(len(scan.ranges))
    room = np.where(np.isfinite(scan.ranges), scan.ranges - CLEARANCE_M, np.inf)
    order = np.argsort(np.abs(angles - wanted))
    for i in order:
        if room[i] >= min(step, 2.0):
            return float(angles[i]), float(min(step, room[i]))
    return None


class Node:
    def __init__(self, session: zenoh.Session, rover: int, domain: int) -> None:
        self.rover, self.domain = rover, domain
        self.inbox: queue.SimpleQueue = queue.SimpleQueue()
        self.odom = self.scan = self.goal = self.imu = None
        self.on_rim = False
        self.climbed = 0.0
        self.waiting_since: float | None = None
        self.blocked = 0
        self.last_ended = 0
        self.sequence = 1
        self.verbose = False
        self.gid = uuid.uuid4().bytes
        topics = {"odom": "nav_msgs/msg/Odometry", "scan": "sensor_msgs/msg/LaserScan",
                  "mission_goal": "geometry_msgs/msg/PointStamped", "imu": "sensor_msgs/msg/Imu",
                  "navigation_status": "diagnostic_msgs/msg/DiagnosticStatus"}
        self.subs = [session.declare_subscriber(key(domain, f"/rover_{rover}/{name}", ros_type),
                                                lambda s, n=name, t=ros_type: self.inbox.put((n, t, s)))
                     for name, ros_type in topics.items()]
        self.goals = session.declare_publisher(key(domain, f"/rover_{rover}/move_goal",
                                                   "geometry_msgs/msg/PoseStamped"))
        self.states = session.declare_publisher(key(domain, f"/rover_{rover}/state", "std_msgs/msg/String"))
        self.state = ""

    def take(self, name: str, ros_type: str, sample: zenoh.Sample) -> None:
        msg = STORE.deserialize_cdr(sample.payload.to_bytes(), ros_type)
        if name == "navigation_status":
            values = {v.key: v.value for v in msg.values}
            outcome, action_id = values.get("outcome", ""), int(values.get("action_id", "0"))
            if action_id <= self.last_ended:
                return  # the end of an earlier goal, said again until the rover's agent shows it heard
            if outcome in ("completed", "cancelled", "collided", "refused"):
                self.last_ended = action_id
                self.waiting_since = None
                self.blocked = self.blocked + 1 if outcome in ("collided", "refused") else 0
                if self.verbose:
                    print(f"  {msg.message}", flush=True)
        else:
            setattr(self, {"mission_goal": "goal"}.get(name, name), msg)

    def nose_up_deg(self) -> float:
        q = self.imu.orientation
        return -math.degrees(math.asin(max(-1.0, min(1.0, 2 * (q.w * q.y - q.z * q.x)))))

    def attachment(self) -> bytes:
        """rmw_zenoh's: sequence number, source time (Unix ns), the publisher's 16-byte GID."""
        self.sequence += 1
        return struct.pack("<qqB", self.sequence - 1, time.time_ns(), 16) + self.gid

    def say(self, state: str) -> None:
        if state != self.state:
            self.state = state
            message = T["std_msgs/msg/String"](data=state)
            self.states.put(bytes(STORE.serialize_cdr(message, "std_msgs/msg/String")), attachment=self.attachment())

    def send(self, x: float, y: float, yaw: float | None) -> None:
        """A move goal in base_link; ``yaw`` None asks for no heading after the move."""
        q = T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=0.0) if yaw is None else \
            T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))
        header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0),
                                          frame_id=f"rover_{self.rover}/base_link")
        pose = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0), orientation=q)
        goal = T["geometry_msgs/msg/PoseStamped"](header=header, pose=pose)
        if self.verbose:
            p = self.odom.pose.pose.position
            pitch = self.nose_up_deg() if self.imu is not None else 0.0
            print(f"at ({p.x:.1f}, {p.y:.1f}) goal ({self.goal.point.x:.1f}, {self.goal.point.y:.1f}) pitch "
                  f"{pitch:.1f} rim {self.on_rim}: move_goal ({x:.1f}, {y:.1f}) yaw {yaw}", flush=True)
        self.goals.put(bytes(STORE.serialize_cdr(goal, "geometry_msgs/msg/PoseStamped")), attachment=self.attachment())
        self.waiting_since = time.monotonic()

    def decide(self) -> bool | None:
        """Send the next goal if the rover is idle; True once at the goal, False once it can get no closer."""
        if self.odom is None or self.scan is None or self.goal is None:
            return None
        if self.waiting_since is not None and time.monotonic() - self.waiting_since < ANSWER_WAIT_S:
            return None
        p = self.odom.pose.pose
        dx, dy = self.goal.point.x - p.position.x, self.goal.point.y - p.position.y
        distance = math.hypot(dx, dy)
        straight = math.atan2(dy, dx) - yaw_of(p.orientation)
        straight = math.atan2(math.sin(straight), math.cos(straight))
        if abs(straight) < HALF_VIEW_RAD and crest_ahead(self.scan, straight) < CREST_M:
            self.on_rim = True
        pitch = self.nose_up_deg() if self.imu is not None else 0.0
        self.climbed = max(self.climbed, pitch) if self.on_rim else 0.0
        arrived = distance < ARRIVED_M or (self.climbed > CLIMBING_DEG and pitch < LEVEL_DEG)
        if arrived or self.blocked >= GIVE_UP_AFTER:
            self.say("done" if arrived else "stuck")
            return arrived
        self.say("migration")
        side = (-1) ** self.blocked * SIDESTEP_RAD * ((self.blocked + 1) // 2)
        bearing = straight + side
        bearing = math.atan2(math.sin(bearing), math.cos(bearing))
        if abs(bearing) > HALF_VIEW_RAD:
            self.send(0.0, 0.0, bearing)
            return None
        way = free_bearing(self.scan, bearing, min(CLIMB_STEP_M if self.on_rim else STEP_M, distance))
        if way is None:
            self.send(0.0, 0.0, math.pi / 2)  # boxed in: look elsewhere
            return None
        angle, step = way
        self.send(step * math.cos(angle), step * math.sin(angle), None)
        return None

    def run(self, timeout_s: float) -> bool | None:
        """True at the goal, False as close as it gets, None out of time."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                self.take(*self.inbox.get(timeout=0.1))
            except queue.Empty:
                pass
            except Exception as exc:  # a sample that is not the type its key names: skip it
                print(f"skipped a sample: {exc}", flush=True)
            if self.inbox.empty() and (done := self.decide()) is not None:
                return done
        return None


def open_session(conf: zenoh.Config, timeout_s: float) -> zenoh.Session:
    """The router may not be up yet (the mission is starting): try again for a while."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            return zenoh.open(conf)
        except zenoh.ZError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.5)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--id", type=int, default=1, help="the rover to drive")
    parser.add_argument("--connect", default="tcp/127.0.0.1:7447", help="the Zenoh router")
    parser.add_argument("--domain-id", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=600.0, help="give up after this many wall seconds")
    parser.add_argument("--verbose", "-v", action="store_true", help="print each goal and how it ended")
    args = parser.parse_args()
    conf = zenoh.Config()
    conf.insert_json5("mode", '"client"')
    conf.insert_json5("connect/endpoints", f'["{args.connect}"]')
    with open_session(conf, args.timeout) as session:
        node = Node(session, args.id, args.domain_id)
        node.verbose = args.verbose
        arrived = node.run(args.timeout)
        p = node.odom.pose.pose.position if node.odom is not None else None
        left = math.hypot(node.goal.point.x - p.x, node.goal.point.y - p.y) if p and node.goal else float("nan")
    said = {True: "at its goal", False: "as close to its goal as it gets", None: "out of time"}[arrived]
    print(f"rover {args.id}: {said}, {left:.1f} m from it by its odometry", flush=True)
    return 1 if arrived is None else 0


if __name__ == "__main__":
    raise SystemExit(main())
