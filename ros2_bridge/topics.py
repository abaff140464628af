"""Every ROS 2 topic the bridge serves: its name, type, direction, frame and LunarSim source, as data.

The bridge declares its endpoints from this table, the rosbag2 export writes the same topics, and the reference
page (``docs/reference/ros2.md``) is generated from it, so the three cannot disagree.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from lander_agent.map_view import VIEW_CELLS

ROVER = "/rover_{id}"


@dataclass(frozen=True)
class Topic:
    name: str
    """``/rover_{id}/...`` for each rover, else the topic's full name."""
    ros_type: str
    direction: Literal["out", "in"]
    """``out``: LunarSim -> ROS 2 (the bridge publishes); ``in``: ROS 2 -> LunarSim (it subscribes)."""
    source: str
    """The LunarSim keys (under ``lunar/<world>/``) it is made from or turned into."""
    frame: str
    note: str
    truth: bool = False
    """Ground truth: only with ``--truth``."""
    latched: bool = False
    """Transient local (keep last 1): a subscription that joins late, with that durability, gets the last sample
    from the bridge's publication cache, as from an rmw_zenoh publisher of that QoS."""

    @property
    def per_rover(self) -> bool:
        return self.name.startswith(ROVER)

    def for_rover(self, rover_id: int) -> str:
        return self.name.format(id=rover_id)

    @property
    def suffix(self) -> str:
        """The part after ``/rover_<id>/`` (per-rover topics) or the whole name."""
        return self.name[len(ROVER) + 1:] if self.per_rover else self.name


SCAN = Topic(f"{ROVER}/scan", "sensor_msgs/msg/LaserScan", "out", "rover/<id>/perception", "rover_<id>/base_link",
             "one range per ray of the field of view, +inf where nothing was hit; intensities: the hit's kind "
             "(1 rover, 2 obstacle, 3 terrain, 4 lander, 5 crater_terrain; 0 no hit)")
IMU = Topic(f"{ROVER}/imu", "sensor_msgs/msg/Imu", "out", "rover/<id>/gyroscope", "rover_<id>/base_link",
            "orientation from the pitch (nose up is negative about y); roll and yaw unmeasured (variance pi^2); "
            "angular velocity and acceleration not measured (covariance[0] = -1, REP 145)")
ODOM = Topic(f"{ROVER}/odom", "nav_msgs/msg/Odometry", "out", "rover/<id>/pose_estimate",
             "rover_<id>/odom -> rover_<id>/base_link",
             "the rover's own pose estimate (its agent's localisation, or for a --drive rover the same filter kept "
             "by the bridge from its actions) with its covariance; height, roll and pitch unobserved (variance "
             "1e6); no velocity (twist covariance[0] = -1). Never ground truth")
BATTERY = Topic(f"{ROVER}/battery", "sensor_msgs/msg/BatteryState", "out", "rover/<id>/battery",
                "rover_<id>/base_link", "percentage and charging state; volts, amperes and Ah are NaN (not modelled); "
                "only in scenarios with a sun")
PHOTO = Topic(f"{ROVER}/photo", "sensor_msgs/msg/CompressedImage", "out", "rover/<id>/photo", "rover_<id>/base_link",
              "the camera's PNG")
NAVIGATION = Topic(f"{ROVER}/navigation_status", "diagnostic_msgs/msg/DiagnosticStatus", "out",
                   "rover/<id>/navigation_status, action_rejected", "-",
                   "an action's progress (OK), cancel (WARN), collision or refusal (ERROR); values: action, outcome, "
                   "remaining, reason, action_id")
MISSION_GOAL = Topic(f"{ROVER}/mission_goal", "geometry_msgs/msg/PointStamped", "out", "rover/<id>/mission_direction",
                     "rover_<id>/odom", "the goal the lander sends the rover to (over the radio: only while in reach)")
MAP = Topic("/lander/map", "nav_msgs/msg/OccupancyGrid", "out", "lander/map", "map",
            "the lander's traverse map: -1 unknown, 0 free (or a rover seen), 50 crater terrain, 100 obstacle "
            f"(past {VIEW_CELLS:,} cells, blocks of cells at their strongest class); transient local, keep last 1 "
            "(a late transient-local subscription gets the last map)", latched=True)
CLOCK = Topic("/clock", "rosgraph_msgs/msg/Clock", "out", "world/clock", "-",
              "simulated time, for nodes with use_sim_time (every stamp the bridge writes is simulated time)")
TF = Topic("/tf", "tf2_msgs/msg/TFMessage", "out", "world/state", "map -> rover_<id>/base_link",
           "where each rover really is", truth=True)
TRUE_ODOM = Topic(f"{ROVER}/truth/odom", "nav_msgs/msg/Odometry", "out", "world/state",
                  "map -> rover_<id>/base_link", "its exact pose (zero covariance)", truth=True)
MOVE_GOAL = Topic(f"{ROVER}/move_goal", "geometry_msgs/msg/PoseStamped", "in", "rover/<id>/move_action, rotate_action",
                  "rover_<id>/base_link", "the position is a move (bounded by the move model), the orientation the "
                  "heading to turn to after it; at the rover's own place, a rotation. Only for a rover no agent "
                  "drives")
CANCEL = Topic(f"{ROVER}/cancel", "std_msgs/msg/Empty", "in", "rover/<id>/cancel_action", "-",
               "cancels whatever action runs")
SPEED = Topic(f"{ROVER}/speed", "std_msgs/msg/UInt8", "in", "rover/<id>/speed_action", "-", "speed level 1 to 3")
TAKE_PHOTO = Topic(f"{ROVER}/take_photo", "std_msgs/msg/String", "in", "rover/<id>/photo_action", "-",
                   "takes a photo labelled with the string (at most 64 printable characters)")
STATE = Topic(f"{ROVER}/state", "std_msgs/msg/String", "in", "rover/<id>/status", "-",
              "for a rover a ROS 2 node drives (--drive): its behaviour state as LunarSim's statistics read it "
              "(waiting, migration, avoiding, climbing, observing, done, stuck...): done at its final goal counts it "
              "reached")
GROUND_GOAL = Topic("/lander/goal", "geometry_msgs/msg/PointStamped", "in", "ground/command", "map",
                    "the ground's new target for every rover (set_target, a waypoint)")

TOPICS: tuple[Topic, ...] = (SCAN, IMU, ODOM, BATTERY, PHOTO, NAVIGATION, MISSION_GOAL, MAP, CLOCK, TF, TRUE_ODOM,
                             MOVE_GOAL, CANCEL, SPEED, TAKE_PHOTO, STATE, GROUND_GOAL)
NOT_BRIDGED: tuple[tuple[str, str], ...] = (
    ("rover/<id>/comm_in, comm_out, comm_partners, lander/comm_*",
     "the radio carries LunarSim's own msgpack payloads between agents; no standard ROS type describes them"),
    ("rover/<id>/status, lander/status", "the agents' behaviour states are LunarSim's vocabulary, not a ROS type"),
    ("rover/<id>/temperature, sun", "no standard type for a survival temperature or a sun sensor's lit flag"),
    ("world/state, world/stats (without --truth)",
     "ground truth and the mission statistics: no real rover knows them (report 9.1)"),
    ("rover/<id>/ack, the lockstep", "an outside node does not acknowledge ticks; a ROS-driven rover runs in real "
     "time"),
)
"""What a ROS 2 user does not see, and why: listed on the reference page."""


def served(truth: bool) -> tuple[Topic, ...]:
    return tuple(t for t in TOPICS if truth or not t.truth)
