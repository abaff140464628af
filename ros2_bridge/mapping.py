"""LunarSim messages as ROS 2 messages (dicts of ``ros2_bridge.ros_types``): pure functions, one per topic.

Standard types only (``common_interfaces``, and ``rosgraph_msgs/Clock`` for simulated time), in the frames of
``ros2_bridge.frames``. What LunarSim does not know is marked as ROS says: an unmeasured battery value is NaN
(``BatteryState``), an IMU field with no data has -1 as its covariance's first element (REP 145), and so has
odometry's twist, which no estimate gives.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ros2_bridge import frames as fr
from schemas import messages as m
from schemas.base import HIT_KINDS
from sessions.rays import RayLayout

Fields = dict[str, Any]
NAN = float("nan")
UNKNOWN = [-1.0] + [0.0] * 8
"""A 3x3 covariance of a field with no data (REP 145)."""
UNKNOWN_6 = [-1.0] + [0.0] * 35
"""A 6x6 covariance LunarSim does not estimate."""
UNOBSERVED_VARIANCE = 1e6
"""The variance of a pose coordinate a planar estimate does not observe (height, roll, pitch): a 1-sigma of a
kilometre or a thousand radians, as planar odometry in ROS marks what it leaves out."""
ANY_ANGLE_VARIANCE = math.pi ** 2
"""The variance of an angle the gyroscope does not measure (roll, yaw): a 1-sigma of half a turn, anything."""
OCCUPANCY = {"unknown": -1, "free": 0, "rover": 0, "crater": 50, "obstacle": 100}
"""The lander's map classes as ``OccupancyGrid`` values: a rover seen is passing traffic on free ground; crater
terrain is walkable but to be avoided when the way round is short."""
LEVELS = {"running": 0, "completed": 0, "cancelled": 1, "collided": 2}
"""``DiagnosticStatus`` level (OK, WARN, ERROR) of a navigation outcome; a refused action is an ERROR."""
KIND_CODES = {kind: float(i + 1) for i, kind in enumerate(HIT_KINDS)}
"""A hit kind's ``intensities`` value in ``scan``."""
STATUS_CHARGING, STATUS_DISCHARGING, STATUS_NOT_CHARGING = 1, 2, 3
HEALTH_GOOD, HEALTH_DEAD = 1, 3


def scan(msg: m.Perception, rover_id: int, layout: RayLayout) -> Fields:
    """Each ray's nearest hit, +inf where it met nothing within range (REP 117); ``intensities`` carry the hit's
    kind, 1 + its index in ``HIT_KINDS`` (0: no hit)."""
    ranges = [math.inf] * layout.rays
    kinds = [0.0] * layout.rays
    for i, distance, kind in zip(layout.indices(msg.angles_deg), msg.distances_m, msg.kinds, strict=True):
        if distance < ranges[i]:
            ranges[i], kinds[i] = distance, KIND_CODES[kind]
    half = math.radians(layout.fov_deg) / 2
    return {"header": fr.header(msg.stamp, fr.base_link(rover_id)), "angle_min": -half, "angle_max": half,
            "angle_increment": layout.step_rad, "time_increment": 0.0, "scan_time": layout.period_s,
            "range_min": 0.0, "range_max": layout.radius_m, "ranges": ranges, "intensities": kinds}


def imu(msg: m.Gyroscope, rover_id: int, pitch_std_deg: float = 0.0) -> Fields:
    """Pitch is all the gyroscope gives: roll and yaw are zero with a variance that says they may be anything;
    angular velocity and acceleration are not measured (REP 145: covariance[0] = -1)."""
    pitch_var = math.radians(pitch_std_deg) ** 2
    return {"header": fr.header(msg.stamp, fr.base_link(rover_id)),
            "orientation": fr.quaternion(pitch=fr.pitch_angle(msg.pitch_deg)),
            "orientation_covariance": [ANY_ANGLE_VARIANCE, 0, 0, 0, pitch_var, 0, 0, 0, ANY_ANGLE_VARIANCE],
            "angular_velocity_covariance": UNKNOWN, "linear_acceleration_covariance": UNKNOWN}


def _pose(x: float, z: float, heading_deg: float) -> Fields:
    return {"position": {"x": x, "y": z, "z": 0.0}, "orientation": fr.quaternion(yaw=fr.yaw_of_heading(heading_deg))}


def odometry(msg: m.EstimatedPose, rover_id: int) -> Fields:
    """The rover's own estimate in ``rover_<id>/odom`` with its covariance (``pose_covariance``); no velocity."""
    return {"header": fr.header(msg.stamp, fr.odom_frame(rover_id)), "child_frame_id": fr.base_link(rover_id),
            "pose": {"pose": _pose(msg.x, msg.z, msg.heading_deg), "covariance": pose_covariance(msg)},
            "twist": {"covariance": UNKNOWN_6}}


def pose_covariance(msg: m.EstimatedPose) -> list[float]:
    """The 6x6 row-major covariance of ``PoseWithCovariance`` (x, y, z, roll, pitch, yaw): LunarSim's x and z are
    ROS x and y, and yaw = 90 deg - heading turns the opposite way, so the heading's covariances with x and z change
    sign and its variance stays. Height, roll and pitch are not estimated: ``UNOBSERVED_VARIANCE``."""
    out = [0.0] * 36
    planar = {(0, 0): msg.cov_xx, (0, 1): msg.cov_xz, (1, 1): msg.cov_zz, (0, 5): -msg.cov_xh,
              (1, 5): -msg.cov_zh, (5, 5): msg.cov_hh}
    for (i, j), value in planar.items():
        out[i * 6 + j] = out[j * 6 + i] = value
    for i in (2, 3, 4):
        out[i * 6 + i] = UNOBSERVED_VARIANCE
    return out


def battery(msg: m.Battery, rover_id: int) -> Fields:
    """Charge as a share of capacity; volts, amperes and ampere-hours are not modelled (NaN, as ROS asks)."""
    status = STATUS_NOT_CHARGING if msg.empty else STATUS_CHARGING if msg.solar_w > 0 else STATUS_DISCHARGING
    return {"header": fr.header(msg.stamp, fr.base_link(rover_id)), "voltage": NAN, "temperature": NAN,
            "current": NAN, "charge": NAN, "capacity": NAN, "design_capacity": NAN, "percentage": msg.fraction,
            "power_supply_status": status, "power_supply_health": HEALTH_DEAD if msg.empty else HEALTH_GOOD,
            "power_supply_technology": 0, "present": True, "location": f"rover_{rover_id}"}


def photo(msg: m.Photo, rover_id: int) -> Fields:
    return {"header": fr.header(msg.stamp, fr.base_link(rover_id)), "format": "png", "data": msg.png}


def navigation(msg: m.NavigationStatus, rover_id: int) -> Fields:
    unit = "m" if msg.action == "move" else "deg"
    return _status(rover_id, LEVELS[msg.outcome], f"{msg.action} {msg.outcome}, {msg.remaining:.2f} {unit} to go",
                   {"action": msg.action, "outcome": msg.outcome, "remaining": f"{msg.remaining:.3f}",
                    "action_id": str(msg.action_id), "stamp": f"{msg.stamp:.3f}"})


def refusal(msg: m.ActionRejected, rover_id: int, stamp: float) -> Fields:
    return _status(rover_id, 2, f"{msg.action} refused: {msg.reason}",
                   {"action": msg.action, "outcome": "refused", "reason": msg.reason, "detail": msg.detail,
                    "action_id": str(msg.action_id), "stamp": f"{stamp:.3f}"})


def _status(rover_id: int, level: int, message: str, values: dict[str, str]) -> Fields:
    return {"level": level, "name": f"rover_{rover_id}/navigation", "message": message,
            "hardware_id": f"rover_{rover_id}", "values": [{"key": k, "value": v} for k, v in values.items()]}


def mission_goal(msg: m.MissionDirection, rover_id: int, stamp: float) -> Fields:
    """The goal the lander sends the rover to, in the lander-centred frame its odometry starts in."""
    rad = math.radians(msg.bearing_deg)
    return {"header": fr.header(stamp, fr.odom_frame(rover_id)),
            "point": {"x": msg.distance_m * math.sin(rad), "y": msg.distance_m * math.cos(rad), "z": 0.0}}


def occupancy(msg: m.LanderMap, codes) -> Fields:
    """The lander's traverse map (its class codes, ``codes[row z][column x]``) as an ``OccupancyGrid`` in ``map``."""
    table = np.array([OCCUPANCY.get(name, -1) for name in msg.classes] or [-1], np.int8)
    data = table[np.minimum(codes, len(table) - 1)].ravel()
    return {"header": fr.header(msg.stamp, fr.MAP_FRAME),
            "info": {"map_load_time": fr.stamp(msg.stamp), "resolution": msg.cell_m, "width": msg.width,
                     "height": msg.height, "origin": {"position": {"x": msg.origin_x, "y": msg.origin_z, "z": 0.0},
                                                      "orientation": fr.quaternion()}},
            "data": data.tobytes()}


def clock(msg: m.Clock) -> Fields:
    return {"clock": fr.stamp(msg.sim_time)}


def truth_transforms(state: m.WorldState) -> Fields:
    """Ground truth, ``map`` -> ``rover_<id>/base_link``: what no real rover knows (report 9.1)."""
    return {"transforms": [{"header": fr.header(state.stamp, fr.MAP_FRAME), "child_frame_id": fr.base_link(r.id),
                            "transform": {"translation": {"x": r.x, "y": r.z, "z": 0.0},
                                          "rotation": fr.quaternion(yaw=fr.yaw_of_heading(r.heading_deg))}}
                           for r in state.rovers]}


def truth_odometry(rover: m.RoverTruth, stamp: float) -> Fields:
    return {"header": fr.header(stamp, fr.MAP_FRAME), "child_frame_id": fr.base_link(rover.id),
            "pose": {"pose": _pose(rover.x, rover.z, rover.heading_deg)}}
