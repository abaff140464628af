"""The world's side of lockstep: which agents a tick waits for, and when their answers take effect.

An agent publishes only in answer to a sample that may make it act (``keyspace.ANSWERED_TOPICS``: perception,
radio, photos) or on a tick the world asks it for, when its own timers are due (it says when with each ``Ack``:
``Ack.wake``). So a tick waits for the agents it sent such a sample and for those whose wake time has come, not
for all of them.

The ticks are pipelined (``AnswerBook``): the world steps tick N+1 while the agents work on tick N, and what
they answered to tick N takes effect just before tick N+2, in key order. On two cores the world's step and the
agents' answers then overlap instead of taking turns. Every agent still gets every sample, in order, over one
Zenoh session, and its answer to tick N is made from the samples up to tick N's clock; the world applies it at a
fixed tick whatever the machine's load. So runs stay reproducible, and a rover reacts one tick (50 ms of
simulated time) later than it would with nothing between its answer and the world.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import TYPE_CHECKING

from schemas import keyspace as ks

if TYPE_CHECKING:
    from deploy.bus import Received

WAKE_UNKNOWN = math.inf
"""An agent asked on a tick: its next wake time is unknown until its ack of that tick takes effect."""


class AckPlan:
    def __init__(self, keys: ks.Keyspace, dt: float) -> None:
        self.keys, self.dt = keys, dt
        self.wake: dict[int, float] = {}  # agent id -> first tick its timers may fire; not there: every tick
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
        """The agents whose ack of ``tick`` the world waits for; starts the next tick's record.

        An agent asked because its timers are due fires them now: it is not asked for them again until its ack
        says when they are next due."""
        due = {agent for agent in present if self.wake.get(agent, 0) <= tick}
        for agent in due:
            self.wake[agent] = WAKE_UNKNOWN
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


class AnswerBook:
    """What the agents answered, by the tick it answers: the pipeline between their acks and the world's step.

    An agent's samples (move actions, radio, ...) are held until its next ack, which says which tick they
    answer; ``take(tick)`` hands them over once every agent asked on that tick has acked, and only then do their
    wake times count. So what takes effect before a step does not depend on how far the agents have got with
    the tick after.
    """

    def __init__(self, plan: AckPlan) -> None:
        self.plan = plan
        self.waiting: dict[int, set[int]] = {}  # tick -> agents whose ack of it is still due
        self._since_ack: dict[int, list[Received]] = defaultdict(list)  # agent -> its samples since its last ack
        self._answers: dict[int, list[Received]] = defaultdict(list)
        self._wakes: dict[int, list[tuple[int, float | None]]] = defaultdict(list)
        self._late: list[tuple[int, int, float | None]] = []  # acks of ticks no longer waited for
        self._loose: list[Received] = []  # from agents that left, or acked a tick nobody waited for

    def ask(self, tick: int, present: set[int]) -> list[int]:
        asked = self.plan.ask(tick, present)
        if asked:
            self.waiting[tick] = set(asked)
        return asked

    def add(self, item: Received, agent: int) -> None:
        """A sample ``agent`` published: it answers the tick of the agent's next ack."""
        self._since_ack[agent].append(item)

    def ack(self, agent: int, tick: int, wake: float | None) -> None:
        items = self._since_ack.pop(agent, [])
        waited = self.waiting.get(tick)
        if waited is None or agent not in waited:  # late, after the world gave up on it: take effect next
            self._loose += items
            self._late.append((agent, tick, wake))
            return
        waited.discard(agent)
        self._answers[tick] += items
        self._wakes[tick].append((agent, wake))

    def ready(self, tick: int) -> bool:
        return not self.waiting.get(tick)

    def give_up(self, tick: int) -> list[int]:
        """Stop waiting for ``tick``'s missing acks; the agents that were missing."""
        return sorted(self.waiting.pop(tick, set()))

    def take(self, tick: int) -> list[Received]:
        """The answers to ``tick`` (and anything late), in key order; their wake times take effect."""
        self.waiting.pop(tick, None)
        for agent, wake in self._wakes.pop(tick, []):
            self.plan.acked(agent, tick, wake)
        for agent, late_tick, wake in self._late:
            self.plan.acked(agent, late_tick, wake)
        items = self._answers.pop(tick, []) + self._loose
        self._late, self._loose = [], []
        return sorted(items, key=lambda item: item.key)  # stable: each key's samples keep their order

    def leave(self, agent: int) -> None:
        """An agent gone: nothing waits for it; what it sent takes effect with the next tick."""
        for waited in self.waiting.values():
            waited.discard(agent)
        self._loose += self._since_ack.pop(agent, [])
        self.plan.forget(agent)
