"""The ROS 2 side of ``benchmarks/ros2_bridge.py``, in a process of its own (the SDK keeps one Zenoh session per
process): ``zenoh-ros2-sdk`` subscribers on every rover's scan and imu, noting when each sample arrived.

    python benchmarks/ros2_sdk_meter.py --port P --rovers N

Prints ``ready`` once subscribed; on a line on stdin, prints one JSON line: for each sample its topic, stamp (ns of
simulated time) and Unix ns of arrival, and exits.
"""

from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from pathlib import Path

MSGS = Path(__file__).resolve().parents[1] / "tests" / "data" / "ros2_msgs"
TYPES = {"scan": "sensor_msgs/msg/LaserScan", "imu": "sensor_msgs/msg/Imu"}


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--port", type=int, required=True)
    parser.add_argument("--rovers", type=int, required=True)
    parser.add_argument("--domain", type=int, default=0)
    args = parser.parse_args()
    from zenoh_ros2_sdk import ROS2Subscriber, get_registry

    get_registry(str(MSGS))
    seen: list[tuple[str, int, int]] = []
    lock = threading.Lock()

    def keep(topic: str):
        def callback(msg) -> None:
            now = time.time_ns()
            with lock:
                seen.append((topic, msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec, now))
        return callback

    subs = [ROS2Subscriber(f"/rover_{rid}/{kind}", ros_type, keep(f"/rover_{rid}/{kind}"), router_port=args.port,
                           domain_id=args.domain)
            for rid in range(1, args.rovers + 1) for kind, ros_type in TYPES.items()]
    print("ready", flush=True)
    sys.stdin.readline()
    with lock:
        out = list(seen)
    for sub in subs:
        sub.close()
    print(json.dumps(out), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
