"""The ROS 2 side of the bridge's tests, in a process of its own: ``zenoh-ros2-sdk``, an implementation of rmw_zenoh's
wire format independent of the bridge, with the vendored ``.msg`` definitions (it fetches nothing).

    python tests/support/ros2_sdk_side.py --port P --domain D --listen-rover 1 --drive-rover 2

Subscribes to a rover's scan, imu and odom and to /clock until each has samples, lists the graph's topics, then
publishes a move goal to another rover until its navigation status says the move completed; prints one JSON line.
The SDK keeps one Zenoh session per process, hence a process per test.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import threading
import time
from pathlib import Path

MSGS = Path(__file__).resolve().parents[1] / "data" / "ros2_msgs"
LISTENED = {"scan": "sensor_msgs/msg/LaserScan", "imu": "sensor_msgs/msg/Imu", "odom": "nav_msgs/msg/Odometry"}


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--domain", type=int, default=0)
    parser.add_argument("--listen-rover", type=int, default=1)
    parser.add_argument("--drive-rover", type=int, default=2)
    parser.add_argument("--ahead-m", type=float, default=3.0)
    parser.add_argument("--timeout", type=float, default=60.0)
    args = parser.parse_args()

    from zenoh_ros2_sdk import ROS2Publisher, ROS2Subscriber, get_message_class, get_registry, get_topic_names_and_types

    get_registry(str(MSGS))
    got: dict[str, list] = {}
    lock = threading.Lock()

    def keep(name: str):
        def callback(msg) -> None:
            with lock:
                got.setdefault(name, []).append(msg)
        return callback

    common = {"router_port": args.port, "domain_id": args.domain}
    topics = {f"/rover_{args.listen_rover}/{t}": ros_type for t, ros_type in LISTENED.items()}
    topics["/clock"] = "rosgraph_msgs/msg/Clock"
    status_topic = f"/rover_{args.drive_rover}/navigation_status"
    topics[status_topic] = "diagnostic_msgs/msg/DiagnosticStatus"
    subs = [ROS2Subscriber(name, ros_type, keep(name), **common) for name, ros_type in topics.items()]
    deadline = time.monotonic() + args.timeout
    listened = [name for name in topics if name != status_topic]
    while time.monotonic() < deadline and not all(len(got.get(name, [])) >= 3 for name in listened):
        time.sleep(0.1)
    graph = get_topic_names_and_types(domain_id=args.domain, router_port=args.port, timeout=3.0)

    header = get_message_class("std_msgs/msg/Header")
    stamp = get_message_class("builtin_interfaces/msg/Time")
    pose = get_message_class("geometry_msgs/msg/Pose")
    point = get_message_class("geometry_msgs/msg/Point")
    quaternion = get_message_class("geometry_msgs/msg/Quaternion")
    goal = ROS2Publisher(f"/rover_{args.drive_rover}/move_goal", "geometry_msgs/msg/PoseStamped", **common)
    completed, sent = None, 0
    while time.monotonic() < deadline and completed is None:
        goal.publish(header=header(stamp=stamp(sec=0, nanosec=0), frame_id=f"rover_{args.drive_rover}/base_link"),
                     pose=pose(position=point(x=args.ahead_m, y=0.0, z=0.0),
                               orientation=quaternion(x=0.0, y=0.0, z=0.0, w=0.0)))
        sent += 1
        until = time.monotonic() + 5.0
        while time.monotonic() < until and completed is None:
            with lock:
                completed = next((s.message for s in got.get(status_topic, []) if "completed" in s.message), None)
            time.sleep(0.1)
    with lock:
        scan = got.get(f"/rover_{args.listen_rover}/scan", [None])[-1]
        odom = got.get(f"/rover_{args.listen_rover}/odom", [None])[-1]
        summary = {
            "counts": {name: len(got.get(name, [])) for name in topics},
            "graph": {name: types for name, types in graph},
            "scan_frame": scan.header.frame_id if scan is not None else None,
            "scan_rays": len(scan.ranges) if scan is not None else 0,
            "scan_misses_inf": bool(scan is not None and any(math.isinf(r) for r in scan.ranges)),
            "odom_frames": [odom.header.frame_id, odom.child_frame_id] if odom is not None else None,
            "odom": [_odom(o) for o in got.get(f"/rover_{args.listen_rover}/odom", [])],
            "clock_s": [c.clock.sec + c.clock.nanosec * 1e-9 for c in got.get("/clock", [])][-3:],
            "goals_sent": sent,
            "completed": completed,
            "statuses": [s.message for s in got.get(status_topic, [])][:5],
        }
    for sub in subs:
        sub.close()
    goal.close()
    print(json.dumps(summary), flush=True)
    return 0


def _odom(msg) -> dict:
    """What the test compares with the agent's estimate: stamp, position, heading's yaw and the covariance."""
    p, q = msg.pose.pose.position, msg.pose.pose.orientation
    return {"stamp": msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9, "x": p.x, "y": p.y,
            "yaw": math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)),
            "covariance": [float(v) for v in msg.pose.covariance]}


if __name__ == "__main__":
    sys.exit(main())
