"""The bridge's core without Zenoh: LunarSim samples to ROS 2 messages (frames, +inf misses, REP 145 marks,
odometry from the rover's own estimate) and ROS 2 requests to LunarSim actions, with everything refused counted,
never raised."""

from __future__ import annotations

import math
import zlib

import pytest
from hostile import huge_lander_map, pack
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


def test_odometry_is_the_rovers_own_estimate_with_its_covariance_in_ros_axes():
    tr = _bridge()
    estimate = m.EstimatedPose(stamp=3.5, x=10.0, z=20.0, heading_deg=90.0, cov_xx=0.4, cov_xz=0.1, cov_zz=0.9,
                               cov_xh=0.02, cov_zh=-0.03, cov_hh=0.01, moving=True)
    odom = _feed(tr, 1, "pose_estimate", estimate)["/rover_1/odom"]
    pose = odom["pose"]["pose"]
    assert pose["position"] == {"x": 10.0, "y": 20.0, "z": 0.0} and _yaw(pose["orientation"]) == pytest.approx(0.0)
    assert odom["header"] == {"stamp": {"sec": 3, "nanosec": 500_000_000}, "frame_id": "rover_1/odom"}
    assert odom["child_frame_id"] == "rover_1/base_link"
    cov = odom["pose"]["covariance"]
    assert (cov[0], cov[1], cov[6], cov[7]) == (0.4, 0.1, 0.1, 0.9)
    # yaw = 90 deg - heading: the heading's covariances with x and z change sign, its variance stays
    assert (cov[5], cov[30], cov[11], cov[31], cov[35]) == (-0.02, -0.02, 0.03, 0.03, 0.01)
    assert cov[14] == cov[21] == cov[28] == 1e6  # height, roll, pitch: not observed
    assert odom["twist"]["covariance"][0] == -1
    # the ROS type takes it as it is: the covariance survives CDR
    decoded = ros_types.decode("nav_msgs/msg/Odometry", ros_types.encode("nav_msgs/msg/Odometry", odom))
    assert decoded["pose"]["covariance"][:2] == [0.4, 0.1]


def test_no_odometry_from_what_the_rover_did_only_from_what_it_estimates():
    tr = _bridge()
    said = [_feed(tr, 1, "calibration", m.Calibration(x=10.0, z=20.0, heading_deg=90.0)),
            _feed(tr, 1, "navigation_status", m.NavigationStatus(stamp=2, action="move", remaining=0.0,
                                                                 outcome="completed", action_id=7))]
    assert all("/rover_1/odom" not in out for out in said) and tr.requests == []
    assert "move_action" not in " ".join(tr.lunarsim_keys()) and KEYS.rovers("pose_estimate") in tr.lunarsim_keys()


def test_an_estimate_that_is_no_covariance_is_refused_and_counted():
    tr = _bridge()
    payload = pack({"stamp": 1.0, "x": 0.0, "z": 0.0, "heading_deg": 0.0, "cov_xx": 1.0, "cov_xz": 5.0, "cov_zz": 1.0,
                    "cov_xh": 0.0, "cov_zh": 0.0, "cov_hh": 0.0, "moving": False})  # as sent, never built
    assert tr.outbound(KEYS.rover(1, "pose_estimate"), payload) == []
    assert tr.rejected.by_topic["pose_estimate"] == 1


def _driven(noise) -> Translator:
    tr = Translator(KEYS, LAYOUT, truth=False, noise=noise)
    tr.driven = frozenset({1})
    _feed(tr, 1, "gyroscope", m.Gyroscope(stamp=0.0, pitch_deg=0.0))
    return tr


def _published(tr: Translator) -> list[m.EstimatedPose]:
    out, tr.requests = tr.requests, []
    return [msg for key, msg in out if key == KEYS.rover(1, "pose_estimate")]


def test_a_driven_rovers_estimate_is_kept_by_the_agents_filter_and_published_as_its_agent_would():
    from rover_agent.estimation.pose_filter import NoiseModel

    tr = _driven(NoiseModel(slip_std=0.05, heading_std_rad=0.02))
    placed_odom = _feed(tr, 1, "calibration", m.Calibration(x=10.0, z=20.0, heading_deg=90.0))["/rover_1/odom"]
    (placed,) = _published(tr)
    assert placed_odom["pose"]["pose"]["position"] == {"x": 10.0, "y": 20.0, "z": 0.0}
    assert (placed.x, placed.z, placed.heading_deg, placed.cov_xx) == (10.0, 20.0, 90.0, 0.0)
    goal = {"header": {"frame_id": "rover_1/base_link"},
            "pose": {"position": {"x": 4.0, "y": 0.0}, "orientation": {"x": 0, "y": 0, "z": 0, "w": 0}}}
    ((_, move),) = tr.inbound("/rover_1/move_goal", ros_types.encode("geometry_msgs/msg/PoseStamped", goal))
    _feed(tr, 1, "navigation_status", m.NavigationStatus(stamp=1, action="move", remaining=2.0,
                                                         action_id=move.action_id))
    (half,) = _published(tr)
    assert half.x == pytest.approx(12.0) and half.moving and 0 < half.cov_zz < half.cov_xx + 1
    ended = _feed(tr, 1, "navigation_status", m.NavigationStatus(stamp=2, action="move", remaining=0.0,
                                                                 outcome="completed", action_id=move.action_id))
    (done,) = _published(tr)
    assert list(ended) == ["/rover_1/odom", "/rover_1/navigation_status"], "the node sees where it is, then the end"
    assert ended["/rover_1/odom"]["pose"]["pose"]["position"]["x"] == pytest.approx(14.0)
    assert done.x == pytest.approx(14.0) and not done.moving and done.cov_hh == pytest.approx(0.02 ** 2)
    assert done.cov_xx + done.cov_zz > half.cov_xx + half.cov_zz, "a whole move's slip is more than half of one"
    _feed(tr, 1, "navigation_status", m.NavigationStatus(stamp=2.2, action="move", remaining=0.0,
                                                         outcome="completed", action_id=move.action_id))
    assert _published(tr) == [], "an end the world re-sends must not move the rover twice"
    _feed(tr, 1, "calibration", m.Calibration(x=10.0, z=20.0, heading_deg=90.0))
    assert _published(tr) == [], "the lander's calibration, sent again every second, must not set the rover back"
    # the published estimate comes back from the key: already made odom, it is not made odom twice
    assert _feed(tr, 1, "pose_estimate", done) == {}


def test_a_rover_its_agent_drives_gets_no_estimate_from_the_bridge():
    tr = _bridge()
    _feed(tr, 1, "calibration", m.Calibration(x=10.0, z=20.0, heading_deg=90.0))
    assert tr.requests == [] and tr.rovers[1].estimate is None


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


def test_a_map_past_the_viewers_bound_is_published_coarsened():
    (_, _, occupancy), = _bridge().outbound(KEYS.lander("map"), huge_lander_map(4096, 2048))
    info = occupancy["info"]
    assert (info["width"], info["height"], info["resolution"]) == (2048, 1024, 2.0)
    assert len(occupancy["data"]) == 2048 * 1024 and occupancy["data"][:2] == bytes([100, 0])


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
    ("/rover_1/move_goal", _goal(1e9, 0.0), "z: Expected `float` <= 40000000.0"),
    ("/rover_1/move_goal", _goal(float("nan"), 0.0), "finite"),
    ("/rover_99/move_goal", _goal(1.0, 0.0), "no rover 99"),
    ("/rover_1/move_goal", b"\x00\x01\x00\x00\x01", "not CDR"),
    ("/rover_1/speed", ros_types.encode("std_msgs/msg/UInt8", {"data": 9}), "level: Expected `int` <= 3"),
    ("/rover_1/take_photo", ros_types.encode("std_msgs/msg/String", {"data": "x" * 65}), "label: Expected `str` of "
     "length <= 64"),
    ("/rover_1/take_photo", ros_types.encode("std_msgs/msg/String", {"data": "a\nb"}), "label: Expected `str` "
     "matching regex"),
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
