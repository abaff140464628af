"""The bridge's Zenoh side: one ROS 2 node, ``lunarsim_bridge``, as rmw_zenoh would announce it, and the loop that
moves samples between LunarSim's keys and its topics through ``Translator``.

Every publisher and subscription of the node holds its liveliness token (``@ros2_lv/...``) while the bridge runs,
so ``ros2 node list`` and ``ros2 topic list -t`` show them; the tokens are withdrawn when it stops. Rovers are
served from the first sample the world sends them, so the bridge needs no scenario to start.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass

import zenoh
import zenoh.ext

from bus.bus import Bus
from ros2_bridge import rmw, ros_types
from ros2_bridge import topics as tp
from ros2_bridge.translator import Translator

log = logging.getLogger("lunarsim.ros2")
NODE_NAME = "lunarsim_bridge"
IDLE_WAIT_S = 0.1
LATCHED_QOS = rmw.Qos(depth=1, transient_local=True)
"""A latched topic's QoS (``Topic.latched``): reliable, transient local, keep last 1."""
HEARTBEAT_S = 0.5
"""How often, at most, a latched publication tells late subscribers it has a sample they may have missed (rmw_zenoh
sets a sporadic heartbeat on reliable transient-local publishers, so subscribers recover from its cache)."""


@dataclass
class Publication:
    """One ROS publisher: its Zenoh publisher, the GID its samples carry and the next sequence number."""

    publisher: zenoh.Publisher | zenoh.ext.AdvancedPublisher
    ros_type: str
    gid: bytes
    sequence: int = 1

    def put(self, fields: dict) -> None:
        attachment = rmw.attachment(self.sequence, time.time_ns(), self.gid)
        self.sequence += 1
        self.publisher.put(ros_types.encode(self.ros_type, fields), attachment=attachment)


class RosNode:
    """The node's entities on one Zenoh session: publishers and subscription tokens declared once per topic."""

    def __init__(self, session: zenoh.Session, domain_id: int) -> None:
        self.session = session
        self.domain_id = domain_id
        self.node = rmw.Node(domain_id, str(session.info.zid()), 0, NODE_NAME)
        self.tokens: list[zenoh.LivelinessToken] = [session.liveliness().declare_token(self.node.token())]
        self.publications: dict[str, Publication] = {}
        self.subscribed: set[str] = set()
        self._next_entity = 1

    def _token(self, kind: rmw.Kind, topic: str, ros_type: str, qos: rmw.Qos = rmw.DEFAULT_QOS) -> str:
        token = self.node.endpoint_token(self._next_entity, kind, topic, ros_type, ros_types.type_hash(ros_type),
                                         qos)
        self._next_entity += 1
        self.tokens.append(self.session.liveliness().declare_token(token))
        return token

    def advertise(self, topic: str, ros_type: str, latched: bool = False) -> None:
        """A publisher of ``topic``; ``latched``: transient local, as rmw_zenoh makes one (an advanced publisher
        with a one-sample cache that late subscribers query, found through its liveliness)."""
        if topic in self.publications:
            return
        token = self._token("MP", topic, ros_type, LATCHED_QOS if latched else rmw.DEFAULT_QOS)
        key = rmw.topic_key(self.domain_id, topic, ros_type, ros_types.type_hash(ros_type))
        drop = zenoh.CongestionControl.DROP
        if latched:
            publisher = zenoh.ext.declare_advanced_publisher(
                self.session, key, congestion_control=drop, cache=zenoh.ext.CacheConfig(max_samples=1),
                publisher_detection=True,
                sample_miss_detection=zenoh.ext.MissDetectionConfig(sporadic_heartbeat=HEARTBEAT_S))
        else:
            # Not express: an express put writes at once (measured ~120 us a put against ~10 us batched), and the
            # world's burst of samples, each in its own batch, overflowed the transmit queue and was dropped.
            publisher = self.session.declare_publisher(key, congestion_control=drop)
        self.publications[topic] = Publication(publisher, ros_type, rmw.gid(token))

    def announce_subscription(self, topic: str, ros_type: str) -> None:
        if topic not in self.subscribed:
            self.subscribed.add(topic)
            self._token("MS", topic, ros_type)

    def publish(self, topic: str, ros_type: str, fields: dict) -> None:
        self.advertise(topic, ros_type)
        self.publications[topic].put(fields)

    def data_key(self, topic: str) -> str:
        """The key expression of an inbound topic; ``/rover_{id}/...`` becomes one chunk wildcard."""
        name = topic.replace("rover_{id}", "*")
        return rmw.topic_key(self.domain_id, name, _type_of(topic), ros_types.type_hash(_type_of(topic)))

    def topic_of_key(self, key: str) -> str:
        """``<domain>/<topic>/<type>/<hash>`` -> ``/<topic>``."""
        return "/" + key.split("/", 1)[1].rsplit("/", 2)[0]

    def close(self) -> None:
        """Withdraw every token (the graph forgets the node at once) and undeclare the publishers."""
        for token in reversed(self.tokens):
            token.undeclare()
        for publication in self.publications.values():
            publication.publisher.undeclare()
        self.tokens.clear()
        self.publications.clear()


def _type_of(name: str) -> str:
    return next(t.ros_type for t in tp.TOPICS if t.name == name)


class BridgeLoop:
    """Subscribe, then move samples both ways until ``stop``; ``serve`` declares each new rover's endpoints."""

    def __init__(self, bus: Bus, node: RosNode, translator: Translator) -> None:
        self.bus, self.node, self.translator = bus, node, translator
        self.topics = tp.served(translator.truth)
        self.served: set[int] = set()
        self.lunar_prefix = translator.keys.prefix + "/"

    def start(self) -> None:
        for key in self.translator.lunarsim_keys():
            self.bus.subscribe(key)
        for rover_id in sorted(self.translator.driven):
            self.bus.declare_token(self.translator.keys.alive_rover(rover_id))
        self.bus.watch_liveliness(self.translator.keys.alive_rovers)
        for topic in self.topics:
            if topic.direction == "in":
                self.bus.subscribe(self.node.data_key(topic.name))
                if not topic.per_rover:
                    self.node.announce_subscription(topic.name, topic.ros_type)
            elif not topic.per_rover:
                self.node.advertise(topic.name, topic.ros_type, topic.latched)

    def serve(self, rover_id: int) -> None:
        """Declare a rover's publishers and subscription tokens: ROS graph tools list them from now on."""
        self.served.add(rover_id)
        for topic in self.topics:
            if topic.per_rover:
                name = topic.for_rover(rover_id)
                if topic.direction == "out":
                    self.node.advertise(name, topic.ros_type)
                else:
                    self.node.announce_subscription(name, topic.ros_type)
        log.info("serving rover %d on /rover_%d/", rover_id, rover_id)

    def run(self, stop: threading.Event) -> None:
        while not stop.is_set():
            item = self.bus.receive(timeout=IDLE_WAIT_S)
            if item is not None and item.alive is not None:
                self.liveliness(item.key, item.alive)
            elif item is not None:
                self.handle(item.key, item.payload)

    def liveliness(self, key: str, alive: bool) -> None:
        try:
            self.translator.agent(self.translator.keys.parse_alive_key(key), alive)
        except ValueError as exc:
            log.warning("ignored liveliness token: %s", exc)

    def handle(self, key: str, payload: bytes) -> None:
        translator = self.translator
        if key.startswith(self.lunar_prefix):
            outs = translator.outbound(key, payload)
            for rover_id in translator.rovers.keys() - self.served:
                self.serve(rover_id)
            for topic, ros_type, fields in outs:
                self.node.publish(topic, ros_type, fields)
            requests, translator.requests = translator.requests, []
        else:
            requests = translator.inbound(self.node.topic_of_key(key), payload)
        for lunar_key, message in requests:
            self.bus.publish(lunar_key, message)
