"""Rover agents for tests that drive one by hand, without a world."""

from __future__ import annotations

from rover_agent.agent import RoverAgent
from schemas import messages as m
from schemas.keyspace import Keyspace
from schemas.params import RoverParams

RUN = "r1"


def joined_agent(rover_id: int, keys: Keyspace, params: RoverParams, **kwargs) -> RoverAgent:
    """An agent that has had its run's first clock, as every agent on a bus has before it acts on its sensors."""
    agent = RoverAgent(rover_id, keys, params, **kwargs)
    agent.on_clock(m.Clock(tick=0, sim_time=0.0, time_scale=1.0, running=False, run=RUN))
    return agent
