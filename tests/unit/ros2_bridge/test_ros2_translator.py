"""The bridge's core without Zenoh: LunarSim samples to ROS 2 messages (frames, +inf misses, REP 145 marks,
dead-reckoned odometry) and ROS 2 requests to LunarSim actions, with everything refused counted, never raised."""

from __future__ import annotations

import math
import zlib

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ros2_bridge import ros_types
from ros2_bridge.mapping import RayLayout
from ros2_bridge.translator import Translator
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace

KEYS = Keyspace("t")
LAYOUT = RayLayout(fov_deg=180.0, rays=7, radius_m=10.0, period_s=0.2)
"""Rays every 30 degrees from 90 left to 90 right."""


def _feed(tr: Translator, rover: int, topic: str, msg: m.Message) -> dict[str, dict]:
    return {name: fields for name, _, fields in tr.outbound(KEYS.rover(rover, topic), codec.encode(msg))}


def _bridge(truth: bool = False) -> Translator:
    tr = Translator(KEYS, LAYOUT, pitch_std_deg=0.5, truth=truth)
    _feed(tr, 1, "gyroscope", m.Gyroscope(stamp=0.0, pitch_deg=0.0))
    return tr


def _yaw(q: dict) -> float:
    return math.atan2(2 * (q["w"] * q["z"] + q["x"] * q["y"]), 1 - 2 * (q["y"] ** 2 + q["z"] ** 2))


def test_a_scan_has_a_range_per_ray_inf_where_nothing_was_hit_and_rays_counter_clockwise():
    tr = _bridge()
    out = _feed(tr, 1, "perception", m.Perception(stamp=2.5, angles_deg=[-90.0, 30.0],
                                                  distances_m=[4.0, 6.0], kinds=["rover", "lander"]))
    scan = out["/rover_1/scan"]
    assert scan["header"] == {"stamp": {"sec": 2, "nanosec": 500_000_000}, "frame_id": "rover_1/base_link"}
    assert scan["angle_min"] == pytest.approx(-math.pi / 2) and scan["angle_increment"] == pytest.approx(math.pi / 6)
    # 90 deg to the left is ROS +90 deg, the last ray; 30 deg to the right is ROS -30 deg, the third ray
    assert scan["ranges"] == [math.inf, math.inf, 6.0, math.inf, math.inf, math.inf, 4.0]
    assert scan["intensities"][6] == 1.0 and scan["intensities"][2] == 4.0 and scan["intensities"][0] == 0.0
    assert scan["range_max"] == 10.0


def test_a_hit_on_no_ray_of_the_layout_is_refused_and_counted():
    tr = _bridge()
    assert "/rover_1/scan" not in _feed(tr, 1, "perception", m.Perception(stamp=1, angles_deg=[15.0],
                                                                           distances_m=[2.0], kinds=["rover"]))
    assert tr.rejected.by_topic["perception"] == 1


def test_the_imu_carries_the_pitch_and_marks_what_the_gyroscope_does_not_measure():
    tr = _bridge()
    imu = _feed(tr, 1, "gyroscope", m.Gyroscope(stamp=1.0, pitch_deg=10.0))["/rover_1/imu"]
    q = imu["orientation"]
    assert q["y"] == pytest.approx(-math.sin(math.radians(10) / 2)) and q["x"] == q["z"] == 0.0  # nose up: -y
    assert imu["angular_velocity_covariance"][0] == -1 and imu["linear_acceleration_covariance"][0] == -1
    assert imu["orientation_covariance"][4] == pytest.approx(math.radians(0.5) ** 2)
    assert imu["orientation_covariance"][0] == imu["orientation_covariance"][8] == pytest.approx(math.pi ** 2)


def test_odometry_dead_reckons_the_rovers_own_actions_from_its_calibration():
    tr = _bridge()
    out = _feed(tr, 1, "calibration", m.Calibration(x=10.0, z=20.0, heading_deg=90.0))
    pose = out["/rover_1/odom"]["pose"]["pose"]
    assert pose["position"] == {"x": 10.0, "y": 20.0, "z": 0.0} and _yaw(pose["orientation"]) == pytest.approx(0.0)
    _feed(tr, 1, "move_action", m.MoveAction(x=0.0, z=4.0, action_id=7))
    half = _feed(tr, 1, "navigation_status", m.NavigationStatus(stamp=1, action="move", remaining=2.0, action_id=7))
    assert half["/rover_1/odom"]["pose"]["pose"]["position"]["x"] == pytest.approx(12.0)
    done = _feed(tr, 1, "navigation_status", m.NavigationStatus(stamp=2, action="move", remaining=0.0,
                                                                 outcome="completed", action_id=7))
    odom = done["/rover_1/odom"]
    assert odom["pose"]["pose"]["position"]["x"] == pytest.approx(14.0)
    assert odom["header"]["frame_id"] == "rover_1/odom" and odom["child_frame_id"] == "rover_1/base_link"
    assert odom["pose"]["covariance"][0] == -1  # not estimated
    again = _feed(tr, 1, "navigation_status", m.NavigationStatus(stamp=2.2, action="move", remaining=0.0,
                                                                  outcome="completed", action_id=7))
    assert "/rover_1/odom" not in again, "an end the world re-sends must not move the rover twice"
    _feed(tr, 1, "rotate_action", m.RotateAction(degrees=90.0, action_id=8))
    turned = _feed(tr, 1, "navigation_status", m.NavigationStatus(stamp=3, action="rotate", remaining=0.0,
                                                                   outcome="completed", action_id=8))
    assert _yaw(turned["/rover_1/odom"]["pose"]["pose"]["orientation"]) == pytest.approx(-math.pi / 2)
    _feed(tr, 1, "move_action", m.MoveAction(x=0.0, z=10.0, action_id=9))
    _feed(tr, 1, "navigation_status", m.NavigationStatus(stamp=4, action="move", remaining=10.0, action_id=9))
    stopped = _feed(tr, 1, "cancel_result", m.CancelResult(x=0.0, z=3.0, angle_deg=0.0, action_id=9))
    assert stopped["/rover_1/odom"]["pose"]["pose"]["position"]["y"] == pytest.approx(17.0)
    again = _feed(tr, 1, "calibration", m.Calibration(x=10.0, z=20.0, heading_deg=90.0))
    assert again == {}, "the lander's calibration, sent again every second, must not set the rover back"


def test_a_bridge_that_joins_a_rover_under_way_does_not_take_its_calibration():
    tr = _bridge()
    _feed(tr, 1, "rotate_action", m.RotateAction(degrees=90.0, action_id=3))
    _feed(tr, 1, "navigation_status", m.NavigationStatus(stamp=9, action="rotate", remaining=0.0,
                                                         outcome="completed", action_id=3))
    assert _feed(tr, 1, "calibration", m.Calibration(x=10.0, z=20.0, heading_deg=0.0)) == {}


def test_clock_and_map_frames():
    tr = _bridge()
    out = {n: f for n, _, f in tr.outbound(KEYS.clock, codec.encode(m.Clock(tick=3, sim_time=1.25, time_scale=1)))}
    assert out["/clock"] == {"clock": {"sec": 1, "nanosec": 250_000_000}}
    grid = m.LanderMap(stamp=1.0, cell_m=2.0, origin_x=-10.0, origin_z=5.0, width=3, height=1,
                       classes=["unknown", "free", "obstacle", "crater", "rover"],
                       cells=zlib.compress(bytes([0, 2, 3])))
    (name, ros_type, occupancy), = tr.outbound(KEYS.lander("map"), codec.encode(grid))
    assert (name, ros_type) == ("/lander/map", "nav_msgs/msg/OccupancyGrid")
    assert occupancy["header"]["frame_id"] == "map" and occupancy["info"]["origin"]["position"]["y"] == 5.0
    assert list(occupancy["data"]) == [255, 100, 50]  # int8 -1 as a byte


def test_ground_truth_only_when_asked():
    state = m.WorldState(stamp=1.0, rovers=[m.RoverTruth(id=1, x=3.0, z=4.0, heading_deg=0.0, action="idle",
                                                          state="waiting", goal_index=0, distance_to_goal_m=0,
                                                          distance_covered_m=0, alive=True)])
    plain = _bridge()
    assert KEYS.state not in plain.lunarsim_keys() and plain.outbound(KEYS.state, codec.encode(state)) == []
    tr = _bridge(truth=True)
    out = {n: f for n, _, f in tr.outbound(KEYS.state, codec.encode(state))}
    (transform,) = out["/tf"]["transforms"]
    assert transform["child_frame_id"] == "rover_1/base_link" and transform["transform"]["translation"]["y"] == 4.0
    assert _yaw(transform["transform"]["rotation"]) == pytest.approx(math.pi / 2)  # heading 0 is +z, ROS +y
    assert "/rover_1/truth/odom" in out


def _goal(x: float, y: float, frame: str = "rover_1/base_link", yaw: float | None = None) -> bytes:
    q = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 0.0} if yaw is None else {"z": math.sin(yaw / 2), "w": math.cos(yaw / 2)}
    return ros_types.encode("geometry_msgs/msg/PoseStamped", {"header": {"frame_id": frame},
                                                              "pose": {"position": {"x": x, "y": y}, "orientation": q}})


def test_a_move_goal_in_base_link_becomes_a_move_then_the_turn_its_orientation_asks_for():
    tr = _bridge()
    tr.outbound(KEYS.clock, codec.encode(m.Clock(tick=1, sim_time=2.0, time_scale=1)))
    ((key, move),) = tr.inbound("/rover_1/move_goal", _goal(4.0, 3.0, yaw=0.0))
    assert key == KEYS.rover(1, "move_action") and (move.x, move.z) == (-3.0, 4.0)  # 3 m left, 4 ahead
    assert move.action_id > 0 and tr.requests == []
    _feed(tr, 1, "navigation_status", m.NavigationStatus(stamp=3, action="move", remaining=0.0, outcome="completed",
                                                         action_id=move.action_id))
    ((key, turn),) = tr.requests
    assert key == KEYS.rover(1, "rotate_action") and turn.degrees == pytest.approx(math.degrees(math.atan2(3, 4)))
    assert turn.action_id > move.action_id
    ((_, spin),) = tr.inbound("/rover_1/move_goal", _goal(0.0, 0.0, yaw=math.pi / 2))
    assert isinstance(spin, m.RotateAction) and spin.degrees == pytest.approx(-90.0)  # ROS left is LunarSim negative


@pytest.mark.parametrize(("topic", "payload", "why"), [
    ("/rover_1/move_goal", _goal(4.0, 0.0, frame="map"), "frame"),
    ("/rover_1/move_goal", _goal(1e9, 0.0), "less than or equal"),
    ("/rover_1/move_goal", _goal(float("nan"), 0.0), "finite"),
    ("/rover_99/move_goal", _goal(1.0, 0.0), "no rover 99"),
    ("/rover_1/move_goal", b"\x00\x01\x00\x00\x01", "not CDR"),
    ("/rover_1/speed", ros_types.encode("std_msgs/msg/UInt8", {"data": 9}), "less than or equal"),
    ("/rover_1/take_photo", ros_types.encode("std_msgs/msg/String", {"data": "x" * 65}), "at most"),
    ("/rover_1/take_photo", ros_types.encode("std_msgs/msg/String", {"data": "a\nb"}), "pattern"),
    ("/lander/goal", ros_types.encode("geometry_msgs/msg/PointStamped", {"header": {"frame_id": "rover_1/odom"}}),
     "frame"),
])
def test_what_a_ros_node_may_not_ask_is_refused_and_counted(topic, payload, why, caplog):
    tr = _bridge()
    assert tr.inbound(topic, payload) == []
    assert tr.rejected.total == 1 and why in caplog.text


def test_a_rover_its_agent_drives_takes_no_requests_unless_the_bridge_drives_it():
    tr = _bridge()
    tr.agent(1, True)
    assert tr.inbound("/rover_1/move_goal", _goal(2.0, 0.0)) == []
    assert tr.rejected.by_topic["move_goal"] == 1
    tr.driven = frozenset({1})
    assert len(tr.inbound("/rover_1/move_goal", _goal(2.0, 0.0))) == 1
    tr.driven = frozenset()
    tr.agent(1, False)
    assert len(tr.inbound("/rover_1/move_goal", _goal(2.0, 0.0))) == 1


def test_cancel_speed_photo_and_the_grounds_goal_are_lunarsims_messages():
    tr = _bridge()
    ((key, cancel),) = tr.inbound("/rover_1/cancel", ros_types.encode("std_msgs/msg/Empty", {}))
    assert key == KEYS.rover(1, "cancel_action") and cancel == m.CancelAction()
    ((_, speed),) = tr.inbound("/rover_1/speed", ros_types.encode("std_msgs/msg/UInt8", {"data": 3}))
    assert speed == m.SpeedAction(level=3)
    ((_, photo),) = tr.inbound("/rover_1/take_photo", ros_types.encode("std_msgs/msg/String", {"data": "rim"}))
    assert photo.label == "rim" and photo.action_id > 0
    ((key, command),) = tr.inbound("/lander/goal", ros_types.encode("geometry_msgs/msg/PointStamped", {
        "header": {"frame_id": "map"}, "point": {"x": -500.0, "y": 20.0}}))
    assert key == KEYS.ground_command and (command.command, command.x, command.z) == ("set_target", -500.0, 20.0)


@settings(max_examples=300, deadline=None)
@given(topic=st.sampled_from(["/rover_1/move_goal", "/rover_1/speed", "/rover_1/take_photo", "/rover_1/cancel",
                              "/lander/goal", "/rover_x/move_goal", "/nothing"]),
       payload=st.binary(max_size=200))
def test_no_bytes_a_ros_node_sends_raise(topic, payload):
    tr = _bridge()
    for _, message in tr.inbound(topic, b"\x00\x01\x00\x00" + payload) + tr.inbound(topic, payload):
        assert isinstance(message, m.Message)


@settings(max_examples=200, deadline=None)
@given(topic=st.sampled_from(["perception", "gyroscope", "navigation_status", "calibration", "cancel_result"]),
       payload=st.binary(max_size=200))
def test_no_bytes_on_a_lunarsim_key_raise(topic, payload):
    tr = _bridge()
    tr.outbound(KEYS.rover(1, topic), payload)
    tr.outbound(KEYS.rover(10**6, topic), payload)
    tr.outbound(KEYS.lander("map"), payload)
