"""The agents' side of lockstep: act on the clock only when the world waits for it, then acknowledge it.

The world does not wait for every agent after every tick, only for those it sent a sample that may make them
act (``keyspace.ANSWERED_TOPICS``) and those whose own timers are due by the ``wake`` time of their last ack
(see ``world_service.lockstep``). An agent asked for nothing still handles every sample, in order, but its
timers wait for a tick it is asked on: what it sent on any other would take effect whenever it arrived, and the
run would no longer be reproducible. The world learns a wake time only when the ack carrying it takes effect,
two ticks on, so a timer due sooner fires then.
"""

from __future__ import annotations

from schemas import messages as m

Out = tuple[str, m.Message]


def asked(clock: m.Clock, agent_id: int) -> bool:
    """Whether the world waits for this agent's ack of the tick (every agent's when the clock names none)."""
    return clock.acks is None or agent_id in clock.acks


def acts_on(clock: m.Clock, agent_id: int) -> bool:
    """Whether the agent's timers may fire on this clock: it runs, and in lockstep the world waits for it."""
    return clock.running and (not clock.lockstep or asked(clock, agent_id))


def lockstep_answer(out: list[Out], clock: m.Clock, ack_key: str, wake: float) -> list[Out]:
    """``out``, and in lockstep the ack the world waits for, after everything the agent sent for the tick."""
    if not clock.lockstep:
        return out
    return [*out, (ack_key, m.Ack(tick=clock.tick, wake=wake))]
