"""The rover agent's Zenoh loop: subscribe to the rover's keys, feed the agent, publish what it returns."""

from __future__ import annotations

import logging
import threading

from bus.bus import Bus, Received
from bus.process import freeze_start_up_heap
from bus.world_watch import ClockWatch
from rover_agent.agent import RoverAgent
from rover_agent.restarts.saved_state import STATE_WRITER
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out

log = logging.getLogger("lunarsim.rover")


def run(agents: RoverAgent | list[RoverAgent], bus: Bus, stop: threading.Event) -> None:
    """Run one agent, or several sharing this process and its Zenoh session (``--ids``): each keeps its own
    subscriptions and liveliness token, so the world and the router see them exactly as separate processes.

    Each sample is handled on Zenoh's receiving thread as it arrives (``Bus.handle_directly``), in arrival order,
    and what the agent answers is published from there; this thread only watches the clock and waits for ``stop``.
    The book-keeping an answer leaves (``RoverAgent.catch_up``) waits for the agent's next sample: done at once,
    on whichever thread, it takes a core while the router and the world need theirs to carry the answer.
    A handler's exception stops the agent and is raised here, as it would be from a loop of its own."""
    agents = [agents] if isinstance(agents, RoverAgent) else agents
    keys = agents[0].keys
    who = f"rover {agents[0].id}" if len(agents) == 1 else f"rovers {agents[0].id}..{agents[-1].id}"
    handler = _Handler(agents, bus, stop, ClockWatch(who, keys.clock))
    bus.handle_directly(handler)
    bus.subscribe(keys.clock)  # before the tokens: the world starts the clock once it sees them
    # before the clock can start (keyspace.ROVER_OUTPUTS says why)
    bus.declare_publishers(keys.rover(agent.id, topic) for agent in agents for topic in ks.ROVER_OUTPUTS)
    for agent in agents:
        for topic in ks.ROVER_INPUTS:
            bus.subscribe(keys.rover(agent.id, topic))
        bus.declare_token(keys.alive_rover(agent.id))
    log.info("%s: started on %s, waiting for the world's clock", who, keys.prefix)
    freeze_start_up_heap()
    try:
        while not stop.wait(0.2):
            handler.check()
        if handler.failed is not None:
            raise handler.failed
    finally:
        handler.closed = True
        STATE_WRITER.flush()  # the states of the last actions, before the process ends
        for agent in agents:
            log.info("rover %d: stopping as %s at t = %.1f s; refused %d sample(s)", agent.id, agent.state,
                     agent.now, agent.rejected.total)


class _Handler:
    """What the agents of a process do with each sample, on Zenoh's thread: the clock to all of them, a rover's
    own topic to its agent; what they answer is published at once."""

    def __init__(self, agents: list[RoverAgent], bus: Bus, stop: threading.Event, watch: ClockWatch) -> None:
        self.agents, self.bus, self.stop, self.watch = agents, bus, stop, watch
        self.clock_key = agents[0].keys.clock
        self.by_prefix = {agent.keys.rover(agent.id, ""): agent for agent in agents}
        self.failed: BaseException | None = None
        self.closed = False
        self._watch_lock = threading.Lock()  # the watch is also checked from the waiting thread

    def __call__(self, item: Received) -> None:
        if self.closed or self.failed is not None:
            return
        try:
            self._handle(item)
        except BaseException as exc:  # raised by ``run`` on its own thread
            self.failed = exc
            self.stop.set()

    def _handle(self, item: Received) -> None:
        with STATE_WRITER.held():  # the states the answer leaves are written once it is out
            for key, message in self._answer(item):
                self.bus.publish(key, message)

    def _answer(self, item: Received) -> list[Out]:
        if item.key == self.clock_key:
            with self._watch_lock:
                self.watch.heard()
            clock = _decode_clock(self.agents, item.payload)
            return [o for agent in self.agents for o in agent.on_clock(clock)] if clock is not None else []
        prefix = item.key[:item.key.rindex("/") + 1]
        return self.by_prefix[prefix].handle(item.key[len(prefix):], item.payload)

    def check(self) -> None:
        with self._watch_lock:
            self.watch.check()


def _decode_clock(agents: list[RoverAgent], payload: bytes) -> m.Clock | None:
    """Decoded once for every agent of the process; a bad one is counted by each, as separate processes would."""
    try:
        return codec.decode(m.Clock, payload)
    except codec.DecodeError as exc:
        for agent in agents:
            agent.rejected.count(ks.CLOCK, exc)
        log.warning("rover(s) %s: rejected clock sample: %s", ",".join(str(a.id) for a in agents), exc)
        return None
