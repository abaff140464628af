"""``lunarsim ros2`` through a real router on loopback, against an independent implementation of rmw_zenoh's wire
format (``zenoh-ros2-sdk``, in ``tests/support/ros2_sdk_side.py``): ROS 2 subscribers read a running mission, a ROS 2
publisher drives a rover, ROS 2's graph lists the bridge's topics, and nothing a ROS node sends stops the bridge."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest
import zenoh
from procs import REPO, SCENARIOS, free_port, lunarsim, module, read_until, stop, two_rover_scenario, wait_for

from bus.zenoh_config import build_config
from ros2_bridge import rmw, ros_types
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace

pytestmark = pytest.mark.e2e
DOMAIN = 7


def _bridge_tokens(session: zenoh.Session) -> list[str]:
    replies = session.liveliness().get(f"{rmw.ADMIN_SPACE}/{DOMAIN}/**", timeout=3.0)
    return [str(r.ok.key_expr) for r in replies if r.ok is not None and "lunarsim_bridge" in str(r.ok.key_expr)]


def test_ros2_nodes_read_a_mission_drive_a_rover_and_list_the_bridge(router, tmp_path):
    """Rover 1 has its agent; rover 2 has none (the world starts without it), so only the ROS node drives it."""
    world_name = "ros2"
    keys = Keyspace(world_name)
    scenario = two_rover_scenario(tmp_path)
    common = ["--world", world_name, "--connect", router]
    world = module("world_service", str(scenario), *common, "--start-timeout", "4", "--max-sim-time", "300")
    lander = module("lander_agent", str(scenario), *common)
    rover = module("rover_agent", "--id", "1", "--params", str(scenario), *common)
    bridge = module("ros2_bridge", *common, "--params", str(scenario), "--domain-id", str(DOMAIN))
    states: list[m.WorldState] = []
    estimates: list[m.EstimatedPose] = []
    try:
        with zenoh.open(build_config(connect=[router])) as session:
            session.declare_subscriber(keys.state, lambda s: states.append(codec.decode(m.WorldState,
                                                                                       s.payload.to_bytes())))
            session.declare_subscriber(keys.rover(1, "pose_estimate"), lambda s: estimates.append(
                codec.decode(m.EstimatedPose, s.payload.to_bytes())))
            wait_for(lambda: states, 60, "the world's state")
            start = next(r for r in states[-1].rovers if r.id == 2).distance_covered_m
            port = router.rsplit(":", 1)[1]
            sdk_side = REPO / "tests" / "support" / "ros2_sdk_side.py"
            probe = subprocess.run([sys.executable, str(sdk_side), "--port", port,
                                    "--domain", str(DOMAIN), "--listen-rover", "1", "--drive-rover", "2"],
                                   capture_output=True, text=True, timeout=150)
            assert probe.returncode == 0, probe.stdout + probe.stderr
            seen = json.loads(probe.stdout.strip().splitlines()[-1])
            moved = next(r for r in states[-1].rovers if r.id == 2).distance_covered_m - start

            hostile = [b"not cdr at all", b"\x00\x01\x00\x00" + b"\xff" * 40]
            goal_key = rmw.topic_key(DOMAIN, "/rover_2/move_goal", "geometry_msgs/msg/PoseStamped",
                                     ros_types.type_hash("geometry_msgs/msg/PoseStamped"))
            for payload in hostile:
                session.put(goal_key, payload)
            far = ros_types.encode("geometry_msgs/msg/PoseStamped", {
                "header": {"frame_id": "rover_2/base_link"}, "pose": {"position": {"x": 1e9}}})
            session.put(goal_key, far)
            session.put(goal_key.replace("rover_2", "rover_99"), far)
            refused = read_until(bridge, ("not CDR", "no rover 99"), 30)
            tokens_running = _bridge_tokens(session)
            assert bridge.poll() is None, "the bridge died on hostile input"
            stop(bridge)
            tokens_after = wait_for(lambda: not _bridge_tokens(session) and ["gone"], 10, "the tokens withdrawn")
    finally:
        stop(bridge, rover, lander, world)
    for name in ("/rover_1/scan", "/rover_1/imu", "/rover_1/odom", "/clock"):
        assert seen["counts"][name] >= 3, seen["counts"]
    assert seen["scan_frame"] == "rover_1/base_link" and seen["scan_rays"] == 50 and seen["scan_misses_inf"]
    assert seen["odom_frames"] == ["rover_1/odom", "rover_1/base_link"]
    _odom_is_the_agents_estimate(seen["odom"], estimates)
    assert seen["clock_s"] == sorted(seen["clock_s"]) and seen["clock_s"][-1] > 0
    assert seen["completed"] is not None, seen["statuses"]
    assert moved > 2.0, f"rover 2 covered {moved:.2f} m"
    graph = seen["graph"]
    expected = {"/rover_1/scan": "sensor_msgs/msg/LaserScan", "/rover_2/imu": "sensor_msgs/msg/Imu",
                "/rover_2/odom": "nav_msgs/msg/Odometry", "/rover_1/move_goal": "geometry_msgs/msg/PoseStamped",
                "/lander/map": "nav_msgs/msg/OccupancyGrid", "/lander/goal": "geometry_msgs/msg/PointStamped",
                "/clock": "rosgraph_msgs/msg/Clock"}
    for name, ros_type in expected.items():
        assert ros_type in graph.get(name, []), (name, graph.get(name))
    assert "/tf" not in graph, "ground truth must be off by default"
    assert any("/NN/%/%/lunarsim_bridge" in t for t in tokens_running) and tokens_after == ["gone"]
    log = refused + bridge.stdout.read()
    assert "no rover 99" in log and "not CDR" in log and "move_goal" in log


def _odom_is_the_agents_estimate(odom: list[dict], estimates: list[m.EstimatedPose]) -> None:
    """Each odometry the ROS node got is one estimate the rover's agent published, in ROS axes, covariance and all.
    (This test's own subscriber may miss a sample on a loaded machine, as any Zenoh subscriber may: the odometry
    it has no estimate for is left unchecked, and most must have one.)"""
    by_stamp = {round(e.stamp, 6): e for e in estimates}
    matched = [(got, by_stamp[round(got["stamp"], 6)]) for got in odom if round(got["stamp"], 6) in by_stamp]
    assert len(matched) >= 3 and len(matched) >= 0.8 * len(odom), (len(odom), len(matched), len(estimates))
    for got, e in matched:
        assert (got["x"], got["y"]) == pytest.approx((e.x, e.z), abs=1e-9)
        assert math.cos(got["yaw"] - math.radians(90 - e.heading_deg)) == pytest.approx(1.0)
        cov = got["covariance"]
        assert (cov[0], cov[1], cov[7], cov[35], cov[5]) == pytest.approx((e.cov_xx, e.cov_xz, e.cov_zz, e.cov_hh,
                                                                            -e.cov_xh))


def test_a_rover_driven_from_ros2_reaches_its_crater_and_the_mission_completes(tmp_path):
    """``lunarsim run --external 1``: no agent for rover 1, the bridge holds its place; ``examples/ros2_rover.py``
    drives it on ROS 2 topics alone, and the mission's statistics count it as they count rover 2's agent."""
    port = free_port()
    out = tmp_path / "run"
    run = lunarsim("run", str(SCENARIOS / "crater_observation.yaml"), "--external", "1", "--rovers", "2",
                   "--time-scale", "2", "--port", str(port), "--max-sim-time", "300", "--quiet", "--out", str(out))
    node = subprocess.Popen([sys.executable, str(REPO / "examples" / "ros2_rover.py"), "--id", "1", "--connect",
                             f"tcp/127.0.0.1:{port}", "--timeout", "200"], cwd=REPO, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    try:
        said, _ = node.communicate(timeout=240)
        stdout, stderr = run.communicate(timeout=240)
    finally:
        stop(node, run)
    assert node.returncode == 0 and "rover 1: at its goal" in said, said
    assert run.returncode == 0, stdout + stderr
    report = json.loads((out / "report.json").read_text())
    assert report["complete"] and report["rovers_reached_final_goal"] == 2, report
    assert not (out / "logs" / "rover1.log").exists() and "serving rover 1" in (out / "logs" / "ros2.log").read_text()
