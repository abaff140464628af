"""A process of rover agents declares every publisher it will use before any agent's liveliness token, so before
the world starts the clock: over a real router, with several agents sharing the process as ``--ids`` runs them."""

from __future__ import annotations

import threading

import pytest
from procs import wait_for

from bus.bus import Bus
from bus.zenoh_config import build_config, open_session
from rover_agent import runtime
from rover_agent.agent import RoverAgent
from schemas import keyspace as ks
from schemas.params import RoverParams

pytestmark = pytest.mark.e2e


class _Recording(Bus):
    """A real bus that notes, in order, the publishers it declares and the tokens."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.steps: list[tuple[str, str]] = []

    def _declare_publisher(self, key: str):
        self.steps.append(("publisher", key))
        return super()._declare_publisher(key)

    def declare_token(self, key: str) -> None:
        self.steps.append(("token", key))
        super().declare_token(key)


def test_every_publisher_is_declared_before_the_first_token(router):
    keys = ks.Keyspace("decl")
    agents = [RoverAgent(rid, keys, RoverParams()) for rid in (1, 2, 3)]
    stop = threading.Event()
    with _Recording(open_session(build_config(connect=[router]), router)) as bus:
        loop = threading.Thread(target=runtime.run, args=(agents, bus, stop))
        loop.start()
        try:
            wait_for(lambda: sum(kind == "token" for kind, _ in bus.steps) == len(agents), 20, "the agents' tokens")
        finally:
            stop.set()
            loop.join(timeout=20)
    first_token = next(i for i, (kind, _) in enumerate(bus.steps) if kind == "token")
    declared_before = {key for kind, key in bus.steps[:first_token] if kind == "publisher"}
    assert declared_before == {keys.rover(a.id, topic) for a in agents for topic in ks.ROVER_OUTPUTS}
    assert all(kind == "token" for kind, _ in bus.steps[first_token:])
