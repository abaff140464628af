"""Key expressions: builders, parsers and world-name validation."""

from __future__ import annotations

import pytest

from schemas import keyspace as ks
from schemas.keyspace import Keyspace, check_world_name


def test_default_world():
    assert Keyspace().world == "default"
    assert Keyspace().prefix == "lunar/default"


def test_key_builders():
    k = Keyspace("moon-1")
    assert k.prefix == "lunar/moon-1"
    assert k.all == "lunar/moon-1/**"
    assert k.rover(3, ks.PERCEPTION) == "lunar/moon-1/rover/3/perception"
    assert k.rover(12, ks.MOVE_ACTION) == "lunar/moon-1/rover/12/move_action"
    assert k.rovers(ks.MOVE_ACTION) == "lunar/moon-1/rover/*/move_action"
    assert k.lander(ks.COMM_OUT) == "lunar/moon-1/lander/comm_out"
    assert k.lander("status") == "lunar/moon-1/lander/status"
    assert k.ground_command == "lunar/moon-1/ground/command"
    assert k.clock == "lunar/moon-1/world/clock"
    assert k.state == "lunar/moon-1/world/state"
    assert k.stats == "lunar/moon-1/world/stats"
    assert k.alive_rover(7) == "lunar/moon-1/alive/rover/7"
    assert k.alive_rovers == "lunar/moon-1/alive/rover/*"
    assert k.alive_lander == "lunar/moon-1/alive/lander"


def test_keys_of_different_worlds_do_not_overlap():
    a, b = Keyspace("a"), Keyspace("ab")
    assert not b.rover(1, ks.PERCEPTION).startswith(a.prefix + "/")
    with pytest.raises(ValueError):
        a.parse_rover_key(b.rover(1, ks.PERCEPTION))


@pytest.mark.parametrize("rover_id", [0, 1, 9, 10, 123456])
@pytest.mark.parametrize("topic", [ks.PERCEPTION, ks.MOVE_ACTION, ks.NAVIGATION_STATUS, ks.COMM_OUT, ks.STATUS])
def test_parse_rover_key_round_trip(rover_id, topic):
    k = Keyspace("w_1")
    assert k.parse_rover_key(k.rover(rover_id, topic)) == (rover_id, topic)


@pytest.mark.parametrize(("key", "fragment"), [
    ("lunar/other/rover/1/perception", "is not a rover key of world 'w'"),
    ("lunar/w/lander/comm_out", "is not a rover key"),
    ("lunar/w/rovers/1/perception", "is not a rover key"),
    ("lunar/w/rover", "is not a rover key"),
    ("lunar/w/rover/x/perception", "does not name a rover id and topic"),
    ("lunar/w/rover/-1/perception", "does not name a rover id and topic"),
    ("lunar/w/rover/1.5/perception", "does not name a rover id and topic"),
    ("lunar/w/rover//perception", "does not name a rover id and topic"),
    ("lunar/w/rover/1", "does not name a rover id and topic"),
    ("lunar/w/rover/1/perception/extra", "does not name a rover id and topic"),
    ("lunar/w/rover/*/perception", "does not name a rover id and topic"),
])
def test_parse_rover_key_errors_name_the_key(key, fragment):
    with pytest.raises(ValueError) as info:
        Keyspace("w").parse_rover_key(key)
    assert fragment in str(info.value)
    assert repr(key) in str(info.value)


@pytest.mark.parametrize("rover_id", [1, 42])
def test_parse_alive_key_round_trip(rover_id):
    k = Keyspace("w")
    assert k.parse_alive_key(k.alive_rover(rover_id)) == rover_id


@pytest.mark.parametrize("key", [
    "lunar/w/alive/rover/",
    "lunar/w/alive/rover/x",
    "lunar/w/alive/rover/1/extra",
    "lunar/w/alive/lander",
    "lunar/other/alive/rover/1",
    "lunar/w/rover/1/perception",
])
def test_parse_alive_key_errors(key):
    with pytest.raises(ValueError, match="is not a rover liveliness key of world 'w'"):
        Keyspace("w").parse_alive_key(key)


@pytest.mark.parametrize("parse", ["parse_rover_key", "parse_alive_key"])
def test_non_ascii_digits_are_not_rover_ids(parse):
    k = Keyspace("w")
    key = "lunar/w/rover/\u0661/move_action" if parse == "parse_rover_key" else "lunar/w/alive/rover/\u0661"
    with pytest.raises(ValueError):
        getattr(k, parse)(key)


@pytest.mark.parametrize("world", ["", "a/b", "*", "**", "w*", "$w", "w#1", "w?", " w", "w ", "\tw", "w\n"])
def test_invalid_world_names_are_rejected(world):
    with pytest.raises(ValueError, match="invalid world name"):
        Keyspace(world)
    with pytest.raises(ValueError, match="invalid world name"):
        check_world_name(world)


@pytest.mark.parametrize("world", ["default", "sim-2", "replay_01", "A"])
def test_valid_world_names_are_accepted(world):
    assert check_world_name(world) == world
    assert Keyspace(world).prefix == f"lunar/{world}"


def test_keyspace_is_frozen():
    k = Keyspace("w")
    with pytest.raises(AttributeError):
        k.world = "other"  # type: ignore[misc]
