"""The world's side of lockstep: which agents a tick waits for.

An agent publishes only in answer to a sample that may make it act (``keyspace.ANSWERED_TOPICS``: perception,
radio, photos) or when one of its own timers is due, and it says with each ``Ack`` when that will next be
(``Ack.wake``). So after a tick the world waits for the agents it sent such a sample since the last clock and
for those whose wake time has come, not for all of them: between a rover's perception samples most ticks wait
for nobody, and the clock runs as fast as the world steps. Every agent still gets every sample, in order, over
one Zenoh session, so what it knows at its next answer is the same whatever the machine's load.
"""

from __future__ import annotations

import math

from schemas import keyspace as ks


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
