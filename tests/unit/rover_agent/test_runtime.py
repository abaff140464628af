"""The rover agent's Zenoh loop (``rover_agent.runtime``) on a session of its own: what it does around an answer."""

from __future__ import annotations

import threading

import zenoh
from agent_kit import PARAMS, joined_agent
from procs import wait_for

from bus.bus import Bus, Received
from bus.world_watch import ClockWatch
from bus.zenoh_config import build_config
from rover_agent import runtime
from rover_agent.restarts.saved_state import STATE_WRITER, load_state
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m

KEYS = ks.Keyspace("w")


class _Published(Bus):
    """A bus on a session of its own (no router, nothing listening) that notes, for each topic it puts, whether
    the state writer was held then."""

    def __init__(self) -> None:
        super().__init__(zenoh.open(build_config(mode="peer")), declare_publishers=False)
        self.puts: list[tuple[str, bool]] = []

    def put(self, key: str, payload: bytes) -> None:
        self.puts.append((key.rsplit("/", 1)[-1], STATE_WRITER.holding))
        super().put(key, payload)


def test_an_action_goes_out_before_the_state_it_leaves_is_written(tmp_path):
    """The agent saves its state as it starts an action; the write waits until the action is published."""
    path = tmp_path / "rover1.json"
    agent = joined_agent(1, KEYS, PARAMS, state_file=path)
    with _Published() as bus:
        handler = runtime._Handler([agent], bus, threading.Event(), ClockWatch("rover 1", KEYS.clock))
        for topic, message in ((ks.CALIBRATION, m.Calibration(x=0.0, z=0.0, heading_deg=0.0)),
                               (ks.MISSION_DIRECTION, m.MissionDirection(goal_index=0, goals_total=1, kind="waypoint",
                                                                         bearing_deg=0.0, distance_m=100.0)),
                               (ks.GYROSCOPE, m.Gyroscope(stamp=0.1, pitch_deg=0.0)),
                               (ks.PERCEPTION, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))):
            handler(Received(KEYS.rover(1, topic), codec.encode(message)))
        assert handler.failed is None
        assert ("move_action", True) in bus.puts, bus.puts
        assert not STATE_WRITER.holding
    wait_for(lambda: (state := load_state(path)) is not None and state.flight is not None, 10,
             "the action in flight in the state file")
