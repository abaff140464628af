"""The ROS 2 bridge's run: its node on the mission's router and the loop that moves samples through the
``Translator`` until stopped (``ros2_bridge.node``), with what it served and refused logged at the end."""

from __future__ import annotations

import logging

import zenoh

from bus import process
from bus.bus import Bus
from ros2_bridge.mapping import RayLayout
from ros2_bridge.node import BridgeLoop, RosNode
from ros2_bridge.translator import Translator
from rover_agent.estimation.pose_filter import NoiseModel
from schemas.keyspace import Keyspace
from schemas.params import RoverParams

log = logging.getLogger("lunarsim.ros2")


def serve(session: zenoh.Session, keys: Keyspace, domain: int, params: RoverParams | None, truth: bool,
          drive: frozenset[int] = frozenset()) -> None:
    """Serve the world's rovers to ROS 2 on ``domain`` until SIGINT or SIGTERM; ``params`` lay out the scan's rays
    (None: the stock layout), ``truth`` adds ground truth, ``drive`` are the rovers a ROS 2 node drives."""
    layout = RayLayout.of(params.perception) if params is not None else RayLayout()
    pitch_std = params.perception.gyroscope_noise_std_deg if params is not None else 0.0
    noise = NoiseModel.of(params.navigation) if params is not None else None
    translator = Translator(keys, layout, pitch_std, truth, noise=noise)
    translator.driven = drive
    with Bus(session) as bus, process.stop_on_signals(process.SHUTDOWN_DEADLINE_S) as stop:
        bus.wake_on(stop)
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
