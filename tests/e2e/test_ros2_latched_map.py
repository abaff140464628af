"""``/lander/map`` is transient local, as rmw_zenoh makes such a publisher (``docs/design.md``, Quality of Service: an
advanced publisher with a cache, found through its liveliness): a transient-local subscription that joins after the
map went out still gets the last one, and the graph announces the durability."""

from __future__ import annotations

import zlib

import pytest
import zenoh
import zenoh.ext
from procs import module, stop, wait_for

from bus.zenoh_config import build_config
from ros2_bridge import rmw, ros_types
from schemas import codec
from schemas import messages as m
from schemas.keyspace import Keyspace

pytestmark = pytest.mark.e2e
KEYS = Keyspace("latched")
DOMAIN = 9
MAP_TYPE = "nav_msgs/msg/OccupancyGrid"


def _map(stamp: float, free: int) -> m.LanderMap:
    return m.LanderMap(stamp=stamp, cell_m=2.0, origin_x=-4.0, origin_z=-4.0, width=2, height=1,
                       classes=["unknown", "free", "obstacle", "crater", "rover"],
                       cells=zlib.compress(bytes([free, 2])))


def _put_until_bridged(lander: zenoh.Session, live: list[bytes], stamp: int, free: int) -> None:
    """The lander's map, put until the bridge's /lander/map of that stamp is seen."""
    def bridged() -> bool:
        lander.put(KEYS.lander("map"), codec.encode(_map(float(stamp), free)))
        return bool(live) and ros_types.decode(MAP_TYPE, live[-1])["header"]["stamp"]["sec"] == stamp

    wait_for(bridged, 30, f"the map of {stamp} s on /lander/map", interval=0.5)


def test_a_late_transient_local_subscription_gets_the_last_map(router):
    bridge = module("ros2_bridge", "--world", KEYS.world, "--connect", router, "--domain-id", str(DOMAIN))
    key = rmw.topic_key(DOMAIN, "/lander/map", MAP_TYPE, ros_types.type_hash(MAP_TYPE))
    try:
        with zenoh.open(build_config(connect=[router])) as lander:
            live: list[bytes] = []
            lander.declare_subscriber(key, lambda s: live.append(s.payload.to_bytes()))
            for stamp, free in ((1, 0), (2, 1)):  # the second is the one a late joiner must get
                _put_until_bridged(lander, live, stamp, free)
            published = len(live)
            tokens = [str(r.ok.key_expr) for r in lander.liveliness().get(f"@ros2_lv/{DOMAIN}/**", timeout=3.0)
                      if r.ok is not None]
        # nothing is published from here on: what the late joiner gets can only come from the cache
        with zenoh.open(build_config(connect=[router], mode="client")) as late:
            got: list[zenoh.Sample] = []
            late_sub = zenoh.ext.declare_advanced_subscriber(
                late, key, got.append, history=zenoh.ext.HistoryConfig(detect_late_publishers=True))
            wait_for(lambda: got, 15, "the last map from the bridge's cache")
            late_sub.undeclare()
        assert bridge.poll() is None
    finally:
        stop(bridge)
    grid = ros_types.decode(MAP_TYPE, got[-1].payload.to_bytes())
    assert grid["header"]["stamp"]["sec"] == 2 and list(grid["data"]) == [0, 100] and len(got) == 1
    assert got[-1].attachment is not None and len(got[-1].attachment.to_bytes()) == 33
    assert published >= 2
    (map_token,) = [t for t in tokens if "/MP/" in t and "%lander%map" in t]
    assert map_token.endswith("/:1:,1:,:,:,,"), map_token  # reliable, transient local, keep last 1
