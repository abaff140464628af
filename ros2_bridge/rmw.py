"""rmw_zenoh's wire format: the key a topic's samples travel on, the liveliness tokens that make an entity show in
ROS 2's graph, and the attachment every sample carries. Pure strings and bytes, no Zenoh.

As ros2/rmw_zenoh's ``docs/design.md`` and ``liveliness_utils.cpp`` define them:

- data key ``<domain>/<topic without its leading and trailing '/'>/<pkg>::msg::dds_::<Name>_/RIHS01_<sha256>``;
- node token ``@ros2_lv/<domain>/<zid>/<node_id>/<node_id>/NN/<enclave>/<namespace>/<node>``, an endpoint's
  ``.../<node_id>/<entity_id>/<MP|MS>/<enclave>/<namespace>/<node>/<topic>/<type>/<hash>/<qos>``, every '/' inside
  a name written '%' (the enclave and namespace '/' are thus '%');
- the attachment (``attachment_helpers.cpp``): int64 sequence number (from 1), int64 source time in Unix ns, a
  length byte (16) and the GID, little-endian: 33 bytes. rmw_zenoh's GID is the XXH3-128 hash of the entity's
  token (low 64 bits first), so a sample's GID is the one ROS 2's graph lists for its publisher.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import Final, Literal

import xxhash

ADMIN_SPACE: Final = "@ros2_lv"
GID_SIZE: Final = 16
ATTACHMENT_SIZE: Final = 8 + 8 + 1 + GID_SIZE
DOMAIN_ID_LIMIT: Final = 232
"""ROS 2 domain ids are 0..232 (REP 2000's note on DDS ports; rmw_zenoh takes the same range)."""

Kind = Literal["MP", "MS"]
"""A message publisher or a message subscription (services, ``SS``/``SC``, are not bridged)."""


@dataclass(frozen=True)
class Qos:
    """The QoS an endpoint announces, in rmw_zenoh's compact form: only what differs from rmw_zenoh's default
    (reliable, volatile, keep last 42) is written (``qos_to_keyexpr``)."""

    depth: int = 10
    best_effort: bool = False
    transient_local: bool = False

    def keyexpr(self) -> str:
        reliability = "2" if self.best_effort else ""
        durability = "1" if self.transient_local else ""
        depth = "" if self.depth == 42 else str(self.depth)
        return f"{reliability}:{durability}:,{depth}:,:,:,,"


DEFAULT_QOS: Final = Qos()
"""Reliable, volatile, keep last 10: rclcpp's default profile, announced as ``::,10:,:,:,,``."""


def mangle(name: str) -> str:
    return name.replace("/", "%")


def dds_type_name(ros_type: str) -> str:
    """``sensor_msgs/msg/LaserScan`` -> ``sensor_msgs::msg::dds_::LaserScan_`` (the CDR type name)."""
    package, kind, name = ros_type.split("/")
    return f"{package}::{kind}::dds_::{name}_"


def topic_key(domain_id: int, topic: str, ros_type: str, type_hash: str) -> str:
    """The data key of a topic (``TopicInfo``): its fully qualified name without leading and trailing '/'."""
    return f"{domain_id}/{topic.strip('/')}/{dds_type_name(ros_type)}/{type_hash}"


@dataclass(frozen=True)
class Node:
    """One ROS 2 node as rmw_zenoh announces it: ``zid`` is the Zenoh session's id (hex), ``node_id`` its number
    within that session."""

    domain_id: int
    zid: str
    node_id: int
    name: str
    namespace: str = "/"
    enclave: str = "/"

    def _head(self, entity_id: int, kind: str) -> str:
        return (f"{ADMIN_SPACE}/{self.domain_id}/{self.zid}/{self.node_id}/{entity_id}/{kind}/{mangle(self.enclave)}/"
                f"{mangle(self.namespace)}/{mangle(self.name)}")

    def token(self) -> str:
        return self._head(self.node_id, "NN")

    def endpoint_token(self, entity_id: int, kind: Kind, topic: str, ros_type: str, type_hash: str,
                       qos: Qos = DEFAULT_QOS) -> str:
        return (f"{self._head(entity_id, kind)}/{mangle(topic)}/{mangle(dds_type_name(ros_type))}/{type_hash}/"
                f"{qos.keyexpr()}")


def gid(token: str) -> bytes:
    """rmw_zenoh's GID of an entity: XXH3-128 of its liveliness token, low 64 bits then high, little-endian."""
    return xxhash.xxh3_128_intdigest(token.encode()).to_bytes(GID_SIZE, "little")


def attachment(sequence: int, source_ns: int, entity_gid: bytes) -> bytes:
    return struct.pack("<qqB", sequence, source_ns, len(entity_gid)) + entity_gid


@dataclass(frozen=True)
class Attachment:
    sequence: int
    source_ns: int
    gid: bytes


def parse_attachment(raw: bytes | None) -> Attachment:
    """A sample's attachment; ValueError for one that is not rmw_zenoh's 33 bytes (the sample is refused)."""
    if raw is None or len(raw) != ATTACHMENT_SIZE:
        raise ValueError(f"attachment of {0 if raw is None else len(raw)} bytes, not {ATTACHMENT_SIZE}")
    sequence, source_ns, length = struct.unpack_from("<qqB", raw)
    if length != GID_SIZE:
        raise ValueError(f"attachment GID of {length} bytes, not {GID_SIZE}")
    return Attachment(sequence, source_ns, bytes(raw[17:]))
