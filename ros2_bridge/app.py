"""``lunarsim ros2``: a mission's rovers as ROS 2 topics, for nodes on rmw_zenoh (ROS 2 Jazzy and later).

One ROS 2 node, ``lunarsim_bridge``, on the same Zenoh router as the mission, speaking rmw_zenoh's wire format:
each rover's scan, IMU, odometry, battery, photos, navigation status and mission goal under ``/rover_<id>/``, the
lander's map on ``/lander/map`` and simulated time on ``/clock``; move goals, cancels, speed levels and photo
requests into each rover, and the ground's new goal from ``/lander/goal``. Ground truth (``/tf``,
``/rover_<id>/truth/odom``) only with ``--truth``: no real rover knows it.

    lunarsim ros2 --connect tcp/127.0.0.1:7447 --params scenarios/crater_observation.yaml

ROS 2 nodes join with ``RMW_IMPLEMENTATION=rmw_zenoh_cpp`` and the same router and ``ROS_DOMAIN_ID``. What the
bridge refuses (a malformed sample, an unknown rover, a goal out of bounds) it counts and logs; it never stops on it.
"""

from __future__ import annotations

import argparse
import logging
import os

from bus import process
from bus.zenoh_config import add_zenoh_arguments, config_from_args, describe_endpoints, open_session

log = logging.getLogger("lunarsim.ros2")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--world", default="default", help="world name in the keyspace (default: default)")
    parser.add_argument("--domain-id", type=int, default=None, metavar="N",
                        help="ROS 2 domain id, 0 to 232 (default: $ROS_DOMAIN_ID, else 0)")
    parser.add_argument("--params", metavar="FILE", help="the scenario (or rover parameter file) of the mission: "
                        "the perception rays' layout for scan (default: the stock parameters)")
    parser.add_argument("--drive", type=rover_ids, default=frozenset(), metavar="IDS",
                        help="rovers a ROS 2 node drives instead of a LunarSim agent, e.g. 1 or 1,3: the bridge holds "
                        "their liveliness tokens (the world waits for them and stops them when the bridge goes) and "
                        "passes them the node's goals; every other rover whose agent runs takes none")
    parser.add_argument("--truth", action="store_true", help="also publish ground truth (/tf and "
                        "/rover_<id>/truth/odom): what no real rover knows; off by default")
    add_zenoh_arguments(parser, agent=True)


def rover_ids(text: str) -> frozenset[int]:
    from schemas.wire_limits import MAX_ID

    try:
        ids = frozenset(int(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a list of rover ids: {text[:40]!r}") from None
    if not all(1 <= i <= MAX_ID for i in ids):
        raise argparse.ArgumentTypeError(f"rover ids are 1 to {MAX_ID}, got {text[:40]}")
    return ids


def domain_id(given: int | None, environ: dict[str, str]) -> int:
    """``--domain-id``, else ``ROS_DOMAIN_ID`` as ROS 2 reads it, else 0; out of range is a usage error."""
    from ros2_bridge.rmw import DOMAIN_ID_LIMIT

    if given is None:
        text = environ.get("ROS_DOMAIN_ID", "").strip()
        if text and not (text.isascii() and text.isdigit()):
            raise process.UsageError(f"ROS_DOMAIN_ID={text[:20]!r} is not a whole number")
        given = int(text) if text else 0
    if not 0 <= given <= DOMAIN_ID_LIMIT:
        raise process.UsageError(f"the ROS 2 domain id must be 0 to {DOMAIN_ID_LIMIT}, got {given}")
    return given


def run_from_args(args: argparse.Namespace) -> int:
    from schemas.keyspace import Keyspace
    from schemas.scenario import load_rover_params

    domain = domain_id(args.domain_id, dict(os.environ))
    params = load_rover_params(args.params) if args.params else None
    conf = config_from_args(args)
    conf.insert_json5("mode", '"client"')  # rmw_zenohd does not relay between peers: a client of the router
    session = open_session(conf, describe_endpoints(args), args.router_timeout, who="ros2 bridge")
    serve(session, Keyspace(args.world), domain, params, args.truth, args.drive)
    return 0


def serve(session, keys, domain: int, params, truth: bool, drive: frozenset[int] = frozenset()) -> None:
    from bus.bus import Bus
    from ros2_bridge.mapping import RayLayout
    from ros2_bridge.node import BridgeLoop, RosNode
    from ros2_bridge.translator import Translator
    from rover_agent.estimation.pose_filter import NoiseModel

    layout = RayLayout.of(params.perception) if params is not None else RayLayout()
    pitch_std = params.perception.gyroscope_noise_std_deg if params is not None else 0.0
    noise = NoiseModel.of(params.navigation) if params is not None else None
    translator = Translator(keys, layout, pitch_std, truth, noise=noise)
    translator.driven = drive
    with Bus(session) as bus, process.stop_on_signals() as stop:
        node = RosNode(session, domain)
        loop = BridgeLoop(bus, node, translator)
        try:
            loop.start()
            log.info("ROS 2 bridge for world %s on domain %d%s: node /%s", keys.world, domain,
                     " with ground truth" if truth else "", node.node.name)
            loop.run(stop)
        finally:
            node.close()
            refused = ", ".join(f"{n} on {t}" for t, n in translator.rejected.by_topic.most_common())
            log.info("ROS 2 bridge stopped: served %d rover(s); refused %s", len(loop.served), refused or "nothing")


def main() -> None:
    process.main_for("ros2", "ros2_bridge.app")


if __name__ == "__main__":
    main()
