"""The agents' side of lockstep: answer a tick with an ``Ack`` when the world waits for one.

The world does not wait for every agent after every tick, only for those it sent a sample that may make them
act (``keyspace.ANSWERED_TOPICS``) and those whose own timers are due by the ``wake`` time of their last ack
(see ``world_service.lockstep``). An agent asked for nothing still handles every sample, in order; if its timers
fire on a tick nobody waits for, what it sends is applied whenever it arrives and the run is no longer
reproducible. That is a bug in the agent's ``next_wake``, so it is logged loudly rather than hidden.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from schemas import messages as m
from schemas.messages import Out

log = logging.getLogger("lunarsim.lockstep")


def asked(clock: m.Clock, agent_id: int) -> bool:
    """Whether the world waits for this agent's ack of the tick (every agent's when the clock names none)."""
    return clock.acks is None or agent_id in clock.acks


def lockstep_answer(out: list[Out], clock: m.Clock, agent_id: int, ack_key: str,
                    wake: Callable[[], float]) -> list[Out]:
    """``out`` plus the ack if the world waits for it; a warning if the agent publishes on a tick it was not
    asked for (its timers and ``wake`` disagree). ``wake`` gives the agent's next timer, asked for only with an
    ack: most ticks ask a few agents of many, and an idle rover's clock spent a quarter of its time on it
    (under cProfile)."""
    if asked(clock, agent_id):
        return [*out, (ack_key, m.Ack(tick=clock.tick, wake=wake()))]
    if out:
        log.warning("agent %d publishes %s on tick %d, which the world does not wait for: its next_wake() misses "
                    "a timer, so this lockstep run is not reproducible", agent_id,
                    ", ".join(key.rsplit("/", 1)[-1] for key, _ in out), clock.tick)
    return out
