"""The configuration layers of ``bus.zenoh_config`` (the sessions they open are tested across processes in e2e)."""

from __future__ import annotations

import json

from bus.zenoh_config import build_config


def test_without_multicast_scouting_a_session_does_not_wait_for_scouting_answers():
    """A router (the world of ``lunarsim run``) would otherwise sit half a second in zenoh.open for nothing."""
    for mode in ("router", "peer", "client"):
        conf = build_config(mode, environ={}, listen=["tcp/127.0.0.1:7447"] if mode == "router" else None)
        assert json.loads(conf.get_json("scouting/delay")) == 0
        assert json.loads(conf.get_json("scouting/multicast/enabled")) is False


def test_with_multicast_scouting_asked_for_zenoh_keeps_its_own_delay():
    conf = build_config("peer", environ={}, scouting=True)
    assert json.loads(conf.get_json("scouting/delay")) != 0
    assert json.loads(conf.get_json("scouting/multicast/enabled")) is True
