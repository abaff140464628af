"""rmw_zenoh's wire format as ``ros2_bridge.rmw`` writes it, against the examples in ros2/rmw_zenoh's
``docs/design.md`` (quoted here verbatim), and one type hash from ``rosbags`` against the same document."""

from __future__ import annotations

import struct

import pytest

from ros2_bridge import rmw, ros_types

STRING_HASH = "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18"
"""std_msgs/msg/String, as design.md prints it."""


def test_rosbags_jazzy_hash_is_the_one_in_the_design_doc():
    assert ros_types.type_hash("std_msgs/msg/String") == STRING_HASH


def test_data_keys_are_the_design_docs():
    assert rmw.topic_key(0, "/chatter", "std_msgs/msg/String", STRING_HASH) == (
        "0/chatter/std_msgs::msg::dds_::String_/RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18")
    assert rmw.topic_key(0, "/robot1/chatter", "std_msgs/msg/String", STRING_HASH) == (
        "0/robot1/chatter/std_msgs::msg::dds_::String_/"
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18")


def test_liveliness_tokens_are_the_design_docs():
    listener = rmw.Node(2, "aac3178e146ba6f1fc6e6a4085e77f21", 0, "listener")
    assert listener.token() == "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/0/NN/%/%/listener"
    assert listener.endpoint_token(10, "MS", "/chatter", "std_msgs/msg/String", STRING_HASH) == (
        "@ros2_lv/2/aac3178e146ba6f1fc6e6a4085e77f21/0/10/MS/%/%/listener/%chatter/std_msgs::msg::dds_::String_/"
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,10:,:,:,,")
    talker = rmw.Node(2, "8b20917502ee955ac4476e0266340d5c", 0, "talker")
    assert talker.endpoint_token(10, "MP", "/chatter", "std_msgs/msg/String", STRING_HASH, rmw.Qos(depth=7)) == (
        "@ros2_lv/2/8b20917502ee955ac4476e0266340d5c/0/10/MP/%/%/talker/%chatter/std_msgs::msg::dds_::String_/"
        "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18/::,7:,:,:,,")


def test_a_rover_topic_keeps_its_slashes_in_the_key_and_mangles_them_in_the_token():
    scan_hash = ros_types.type_hash("sensor_msgs/msg/LaserScan")
    assert rmw.topic_key(0, "/rover_1/scan", "sensor_msgs/msg/LaserScan", scan_hash) == (
        f"0/rover_1/scan/sensor_msgs::msg::dds_::LaserScan_/{scan_hash}")
    token = rmw.Node(0, "1f", 0, "lunarsim_bridge").endpoint_token(3, "MP", "/rover_1/scan",
                                                                    "sensor_msgs/msg/LaserScan", scan_hash)
    assert "/lunarsim_bridge/%rover_1%scan/sensor_msgs::msg::dds_::LaserScan_/" in token


def test_qos_writes_only_what_differs_from_rmw_zenohs_default():
    assert rmw.Qos(depth=42).keyexpr() == "::,:,:,:,,"
    assert rmw.Qos(depth=5, best_effort=True).keyexpr() == "2::,5:,:,:,,"
    assert rmw.Qos(depth=1, transient_local=True).keyexpr() == ":1:,1:,:,:,,"


def test_the_attachment_is_33_little_endian_bytes_and_the_gid_hashes_the_token():
    token = "@ros2_lv/0/1f/0/1/MP/%/%/lunarsim_bridge/%clock/rosgraph_msgs::msg::dds_::Clock_/RIHS01_x/::,10:,:,:,,"
    gid = rmw.gid(token)
    raw = rmw.attachment(1, 1_700_000_000_123_456_789, gid)
    assert len(raw) == rmw.ATTACHMENT_SIZE == 33
    assert struct.unpack_from("<qqB", raw) == (1, 1_700_000_000_123_456_789, 16) and raw[17:] == gid
    assert rmw.parse_attachment(raw) == rmw.Attachment(1, 1_700_000_000_123_456_789, gid)
    assert gid != rmw.gid(token.replace("clock", "clock2")) and gid == rmw.gid(token)
    for bad in (None, raw[:-1], raw[:16] + b"\x08" + raw[17:]):
        with pytest.raises(ValueError):
            rmw.parse_attachment(bad)


def test_xxh3_128_gives_the_reference_digest():
    """rmw_zenoh copies XXH3-128's low then high 64 bits; the digest of b"abc" is xxHash's published one."""
    import xxhash

    assert xxhash.xxh3_128_hexdigest(b"abc") == "06b05ab6733a618578af5f94892f3950"


def test_cdr_payloads_carry_the_little_endian_encapsulation_header():
    payload = ros_types.encode("std_msgs/msg/String", {"data": "hello"})
    assert payload[:4] == b"\x00\x01\x00\x00"
    assert ros_types.decode("std_msgs/msg/String", payload) == {"data": "hello"}
