"""The world's side of lockstep: the tick's schedule (``LockstepTick``) and which agents a tick waits for
(``AckPlan``), with no I/O, so the world service's Zenoh loop and the in-process harness (``harness.rounds``)
drive the one schedule.

A tick: the world steps; its samples go out (the photos due first), then its clock, naming the agents whose ack
it waits for (none: no clock); the agents answer both; once every ack is in, the world takes the answers by key,
each key's in order (moves draw their noise from one generator, so the order is part of the result), and what it
publishes meanwhile goes out at once: late samples, whose answers the world takes with the next tick's. The tick
that ends the mission goes out and its answers are not taken.

An agent publishes only in answer to a sample that may make it act (``keyspace.ANSWERED_TOPICS``: perception,
radio, photos) or when one of its own timers is due, and it says with each ``Ack`` when that will next be
(``Ack.wake``). So after a tick the world waits for the agents it sent such a sample since the last clock and
for those whose wake time has come, not for all of them: between a rover's perception samples most ticks wait
for nobody, and the clock runs as fast as the world steps. Every agent still gets every sample, in order, over
one Zenoh session, so what it knows at its next answer is the same whatever the machine's load.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import msgspec

from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out

if TYPE_CHECKING:
    from world_service.served import ServedWorld



class AckPlan:
    def __init__(self, keys: ks.Keyspace, dt: float) -> None:
        self.keys, self.dt = keys, dt
        self.wake: dict[int, int] = {}  # agent id -> first tick its timers may fire; unknown: every tick
        self.sent: set[int] = set()  # agents sent a sample they may answer since the last clock
        self._rover_head = f"{keys.prefix}/rover/"
        self._lander_head = keys.lander("")
        self._lander_keys = {keys.lander(topic) for topic in ks.ANSWERED_TOPICS}

    def agent_of(self, key: str) -> int:
        """The agent that publishes on ``key`` (an ack, an answer): 0 for the lander's keys, else the rover's id;
        ValueError for a key of neither."""
        if key.startswith(self._lander_head):
            return ks.LANDER_ID
        return self.keys.parse_rover_key(key)[0]

    def note(self, key: str) -> None:
        """A sample the world publishes: remember whom it may make act."""
        if key.startswith(self._rover_head):
            rover, _, topic = key[len(self._rover_head):].partition("/")
            if topic in ks.ANSWERED_TOPICS:
                self.sent.add(int(rover))
        elif key in self._lander_keys:
            self.sent.add(ks.LANDER_ID)

    def ask(self, tick: int, present: set[int]) -> list[int]:
        """The agents whose ack of ``tick`` the world waits for; starts the next tick's record."""
        due = {agent for agent in present if self.wake.get(agent, 0) <= tick}
        asked, self.sent = sorted(due | (self.sent & present)), set()
        return asked

    def acked(self, agent: int, tick: int, wake: float | None) -> None:
        """An agent's ack: its timers fire no earlier than ``wake``, so it is asked again then at the latest.

        Rounded half a tick early, so float noise in ``tick * dt`` can only make the world ask once too often.
        """
        if wake is None:
            self.wake[agent] = tick + 1
        else:
            self.wake[agent] = max(tick + 1, math.ceil(wake / self.dt - 0.5))

    def forget(self, agent: int) -> None:
        self.wake.pop(agent, None)


class ClockResend:
    """When to send a tick's clock again while acks it waits for are missing: after a few times the round trip
    of recent ticks, then twice as long each time up to ``CEILING_S``.

    A clock or ack lost on a lossy link would otherwise hold the tick for the whole first wait; at a fixed 50 ms,
    a lockstep run losing a fifth of the world's samples spent nine tenths of its wall time waiting. The round
    trip is learnt from ticks that needed no resend, so losses do not inflate it, and the first wait never
    exceeds its old fixed ``FIRST_MAX_S`` nor falls below ``FLOOR_S``: a slow agent (a long replan, a loaded
    machine) is asked at most a few times more, and an agent acks a clock it has handled again and does no
    more, so a resend never changes a run's result.
    """

    FACTOR = 4.0
    FLOOR_S = 0.005
    FIRST_MAX_S = 0.05
    CEILING_S = 1.0
    SMOOTHING = 0.1  # weight of the newest round trip in the running estimate

    def __init__(self) -> None:
        self.round_trip_s: float | None = None
        self.resends = 0  # counted for the world's log

    def first_wait(self) -> float:
        if self.round_trip_s is None:
            return self.FIRST_MAX_S
        return min(self.FIRST_MAX_S, max(self.FLOOR_S, self.FACTOR * self.round_trip_s))

    def next_wait(self, wait: float) -> float:
        """The wait after a resend that followed ``wait``."""
        self.resends += 1
        return min(2 * wait, self.CEILING_S)

    def acked(self, round_trip_s: float, resent: bool) -> None:
        """Every ack of a tick is in, ``round_trip_s`` after its clock went out."""
        if resent:
            return
        if self.round_trip_s is None:
            self.round_trip_s = round_trip_s
        else:
            self.round_trip_s += self.SMOOTHING * (round_trip_s - self.round_trip_s)


class LockstepTick:
    """The schedule of a lockstep run of ``world``; the caller publishes what it returns and hands it what arrives.

    ``max_sim_time``: the run ends once simulated time reaches it, as it ends when the mission is complete.
    """

    def __init__(self, world: ServedWorld, max_sim_time: float | None = None) -> None:
        self.world = world
        self.max_sim_time = max_sim_time
        self.plan = AckPlan(world.keys, world.clock.dt)
        self.waiting: set[int] = set()  # the agents whose ack of this tick is still due
        self.clock: m.Clock | None = None  # this tick's clock, to send again while acks are overdue
        self._said: list[tuple[str, bytes]] = []  # answers, taken by the world with this tick's

    def step(self, photos: list[Out], present: set[int]) -> tuple[list[Out], m.Clock | None]:
        """Step the world. Returns what to publish now, in order (``photos`` due, then the world's samples), and
        then the tick's clock naming the ``present`` agents it waits for; None when it waits for nobody."""
        out = self.world.step()
        clock_key = self.world.keys.clock
        samples = [*photos, *((key, message) for key, message in out if key != clock_key)]
        self.note(samples)
        self.waiting = set(self.plan.ask(self.world.clock.tick, present))
        clock = next(message for key, message in out if key == clock_key)
        self.clock = msgspec.structs.replace(clock, acks=sorted(self.waiting)) if self.waiting else None
        return samples, self.clock

    @property
    def over(self) -> bool:
        """The mission is complete, or its time is up: the tick just stepped ends it."""
        world = self.world
        return world.complete or (self.max_sim_time is not None and world.clock.sim_time >= self.max_sim_time)

    def note(self, published: list[Out]) -> None:
        """Samples published: whom they may make act (the ack plan asks for them)."""
        for key, _ in published:
            self.plan.note(key)

    def ack(self, agent: int, ack: m.Ack) -> None:
        """An agent's ack; one of another tick says nothing (a resent clock's second answer, a late one)."""
        if ack.tick == self.world.clock.tick:
            self.waiting.discard(agent)
            self.plan.acked(agent, ack.tick, ack.wake)

    def answer(self, key: str, payload: bytes) -> None:
        """A sample for the world: taken once every ack is in (``take``)."""
        self._said.append((key, payload))

    def take(self) -> list[Out]:
        """The world takes the answers, by key (a stable sort: each key's in order); what it publishes meanwhile,
        the late samples, is returned to go out at once."""
        said, self._said = self._said, []
        late: list[Out] = []
        for key, payload in sorted(said, key=lambda sample: sample[0]):
            late += self.world.receive(key, payload)
        self.note(late)
        return late

    def forget(self, agent: int) -> None:
        """An agent gone (its liveliness token withdrawn): no ack of it is waited for."""
        self.waiting.discard(agent)
        self.plan.forget(agent)
