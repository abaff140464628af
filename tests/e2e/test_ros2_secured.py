"""The ROS 2 bridge in a secured deployment (``lunarsim acl --ros2``): its own role, ``ros2``, has the ground's say and
reads what it bridges, never ground truth unless the deployment grants it; ROS 2 nodes (``ros2-nodes``) reach only
their domain's topics. The rules are checked with the model of Zenoh's matching in ``test_security``; then a real
router from ``lunarsim acl``, with certificates from ``make-dev-certs.sh --ros2``, carries a mission to a bridge
started with ``--truth`` that the deployment does not grant it."""

from __future__ import annotations

import subprocess

import pytest
import zenoh
from procs import SCENARIOS, free_port, lunarsim, module, stop, wait_for
from test_security import CERT_SCRIPT, Inbox, allowed, needs_openssl

from bus.zenoh_config import build_config
from deploy.children import wait_for_port
from deploy.security import acl
from ros2_bridge import rmw, ros_types
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m

KEYS = ks.Keyspace("secure")
DOMAIN = 7


def _control(**access) -> dict:
    return acl.access_control(acl.roles(KEYS, [1, 2], ros2=acl.Ros2Access(DOMAIN, **access)), KEYS)


def _reads(control: dict, role: str, key: str) -> bool:
    return (allowed(control, role, "declare_subscriber", "ingress", key)
            and allowed(control, role, "put", "egress", key))


def test_the_bridge_has_the_grounds_say_and_reads_what_it_bridges_but_no_truth():
    control = _control()
    assert allowed(control, "ros2", "put", "ingress", KEYS.ground_command)
    for topic in (ks.PERCEPTION, ks.GYROSCOPE, ks.POSE_ESTIMATE, ks.NAVIGATION_STATUS, ks.CALIBRATION):
        assert _reads(control, "ros2", KEYS.rovers(topic)), topic
    assert _reads(control, "ros2", KEYS.clock) and _reads(control, "ros2", KEYS.lander(ks.MAP))
    for key in (KEYS.state, KEYS.stats, KEYS.rover(1, ks.COMM_IN), KEYS.all):
        assert not _reads(control, "ros2", key), key
    for key in (KEYS.rover(1, ks.MOVE_ACTION), KEYS.rover(1, ks.PERCEPTION), KEYS.rover(1, ks.POSE_ESTIMATE),
                KEYS.clock, KEYS.state):
        assert not allowed(control, "ros2", "put", "ingress", key), key
    assert not allowed(control, "ros2", "liveliness_token", "ingress", KEYS.alive_rover(1))
    assert _reads(_control(truth=True), "ros2", KEYS.state) and not _reads(_control(truth=True), "ros2", KEYS.stats)


def test_for_the_rovers_ros2_drives_the_bridge_acts_as_their_agent_and_for_no_other():
    control = _control(driven=(2,))
    for topic in (ks.MOVE_ACTION, ks.ROTATE_ACTION, ks.STATUS, ks.POSE_ESTIMATE, ks.ACK):
        assert allowed(control, "ros2", "put", "ingress", KEYS.rover(2, topic)), topic
        assert not allowed(control, "ros2", "put", "ingress", KEYS.rover(1, topic)), topic
    assert allowed(control, "ros2", "liveliness_token", "ingress", KEYS.alive_rover(2))
    assert not allowed(control, "ros2", "liveliness_token", "ingress", KEYS.alive_rover(1))
    with pytest.raises(ValueError, match="not rovers of this world"):
        acl.roles(KEYS, [1, 2], ros2=acl.Ros2Access(DOMAIN, driven=(3,)))


def test_ros2_nodes_reach_their_domains_topics_and_graph_and_no_lunarsim_key():
    control = _control()
    scan = rmw.topic_key(DOMAIN, "/rover_1/scan", "sensor_msgs/msg/LaserScan",
                         ros_types.type_hash("sensor_msgs/msg/LaserScan"))
    for role in ("ros2", "ros2-nodes"):
        assert allowed(control, role, "put", "ingress", scan) and _reads(control, role, scan), role
        assert allowed(control, role, "liveliness_token", "ingress", f"@ros2_lv/{DOMAIN}/abc/0/0/NN/%/%/node")
        assert allowed(control, role, "declare_liveliness_subscriber", "ingress", f"@ros2_lv/{DOMAIN}/**")
    cache = rmw.topic_key(DOMAIN, "/lander/map", "nav_msgs/msg/OccupancyGrid",
                          ros_types.type_hash("nav_msgs/msg/OccupancyGrid")) + "/@adv/pub/abc/1/_/_"
    assert allowed(control, "ros2", "declare_queryable", "ingress", cache)  # the map's cache, for late joiners
    assert allowed(control, "ros2-nodes", "query", "ingress", cache)
    assert allowed(control, "ros2-nodes", "reply", "egress", cache)
    assert not allowed(control, "ros2-nodes", "query", "ingress", f"{KEYS.prefix}/@adv/x")
    other_domain = scan.replace(f"{DOMAIN}/", "8/", 1)
    assert not allowed(control, "ros2-nodes", "put", "ingress", other_domain)
    for key in (KEYS.ground_command, KEYS.rover(1, ks.MOVE_ACTION), KEYS.clock):
        assert not allowed(control, "ros2-nodes", "put", "ingress", key), key
    for key in (KEYS.state, KEYS.rover(1, ks.PERCEPTION), KEYS.rovers(ks.POSE_ESTIMATE)):
        assert not _reads(control, "ros2-nodes", key), key
    # the agents may publish their estimates, which the ground reads; the world does not
    assert allowed(control, "rover-1", "put", "ingress", KEYS.rover(1, ks.POSE_ESTIMATE))
    assert not allowed(control, "rover-1", "put", "ingress", KEYS.rover(2, ks.POSE_ESTIMATE))
    assert _reads(control, "ground", KEYS.rover(1, ks.POSE_ESTIMATE))
    assert not _reads(control, "world", KEYS.rover(1, ks.POSE_ESTIMATE))


def test_acl_ros2_options_are_checked(tmp_path, capsys):
    from deploy import cli

    common = ["acl", str(SCENARIOS / "crater_observation.yaml"), "-o", str(tmp_path / "r.json5")]
    assert cli.main([*common, "--ros2-truth"]) == 2
    assert "need --ros2" in capsys.readouterr().err
    assert cli.main([*common, "--ros2", "300"]) == 2
    assert "0 to 232" in capsys.readouterr().err
    assert cli.main([*common, "--ros2", "--ros2-drive", "9"]) == 2
    assert "not rovers of this world" in capsys.readouterr().err


# ---- a real secured router ----

def _ros_key(topic: str, ros_type: str) -> str:
    return rmw.topic_key(DOMAIN, topic, ros_type, ros_types.type_hash(ros_type))


@needs_openssl
@pytest.mark.e2e
def test_a_secured_bridge_serves_ros2_nodes_without_truth_it_asks_for_but_is_not_granted(tmp_path):
    folder = tmp_path / "secure"
    made = subprocess.run([str(CERT_SCRIPT), "--ros2", str(folder / "certs"), "1"], capture_output=True, text=True,
                          timeout=60)
    assert made.returncode == 0 and "ros2-nodes.pem" in made.stdout, made.stderr
    acl_run = lunarsim("acl", str(SCENARIOS / "crater_observation.yaml"), "--rovers", "1", "--world", KEYS.world,
                       "--ros2", str(DOMAIN), "-o", str(folder / "router.json5"))
    out, err = acl_run.communicate(timeout=60)
    assert acl_run.returncode == 0 and "ros2, ros2-nodes" in out, out + err
    port = free_port()
    router = lunarsim("router", "--config", str(folder / "router.json5"), "--listen", f"tls/127.0.0.1:{port}")
    endpoint = f"tls/localhost:{port}"

    def args(role: str) -> list[str]:
        return ["--world", KEYS.world, "--config", str(folder / "clients" / f"{role}.json5"), "--connect", endpoint]

    def conf(role: str) -> zenoh.Config:
        return build_config(config_file=str(folder / "clients" / f"{role}.json5"), connect=[endpoint])

    scenario = str(SCENARIOS / "crater_observation.yaml")
    procs = []
    try:
        assert wait_for_port("127.0.0.1", port, 15, router)
        procs = [module("world_service", scenario, *args("world"), "--rovers", "1", "--max-sim-time", "300",
                        "--start-timeout", "20"),
                 module("lander_agent", scenario, *args("lander")),
                 module("rover_agent", "--id", "1", "--params", scenario, *args("rover-1")),
                 module("ros2_bridge", *args("ros2"), "--params", scenario, "--domain-id", str(DOMAIN), "--truth")]
        with zenoh.open(conf("ros2-nodes")) as ros, zenoh.open(conf("recorder")) as recorder:
            topics, lunar = Inbox(ros, f"{DOMAIN}/**"), Inbox(ros, KEYS.all)
            truth, commands = Inbox(recorder, KEYS.state), Inbox(recorder, KEYS.ground_command)
            odom = _ros_key("/rover_1/odom", "nav_msgs/msg/Odometry")
            wait_for(lambda: truth.items, 60, "world/state at the recorder: the world publishes truth")
            seen_truth = len(truth.items)
            wait_for(lambda: sum(k == odom for k, _ in topics.items) >= 2 and len(truth.items) > seen_truth + 5, 60,
                     "the rover's odometry at the ROS node, published after the truth")
            for _ in range(5):  # a ROS node may not command the ground itself...
                ros.put(KEYS.ground_command, codec.encode(m.GroundCommand(request_id="forged", command="stop",
                                                                          rover_id=1)))
            goal = ros_types.encode("geometry_msgs/msg/PointStamped",
                                    {"header": {"frame_id": "map"}, "point": {"x": 30.0, "y": 40.0}})
            goal_key = _ros_key("/lander/goal", "geometry_msgs/msg/PointStamped")
            wait_for(lambda: ros.put(goal_key, goal) or commands.items, 20, "/lander/goal as a ground command",
                     interval=0.5)  # ...but through the bridge, its /lander/goal is one
            sent = [codec.decode(m.GroundCommand, p) for _, p in commands.items]
            scan = _ros_key("/rover_1/scan", "sensor_msgs/msg/LaserScan")
            graph = ros.liveliness().get(f"@ros2_lv/{DOMAIN}/**", timeout=3.0)
            tokens = [str(r.ok.key_expr) for r in graph if r.ok is not None]
        bridge = procs[-1]
        assert bridge.poll() is None, "the bridge stopped"
    finally:
        stop(*reversed(procs), router)
    served = topics.keys()
    assert scan in served and _ros_key("/clock", "rosgraph_msgs/msg/Clock") in served
    assert not any("/tf/" in k or "/truth/" in k for k in served), "truth crossed an ACL that denies it"
    # its own session hands back its own puts, and nothing the router holds
    assert all(k == KEYS.ground_command and b"forged" in p for k, p in lunar.items), "a ROS node read a LunarSim key"
    assert all(c.request_id != "forged" for c in sent) and sent[0].command == "set_target" and sent[0].z == 40.0
    assert any("/NN/%/%/lunarsim_bridge" in t for t in tokens), tokens
