"""Rover agents, and their default behaviour, for tests that drive one by hand, without a world."""

from __future__ import annotations

import math

from rover_agent.agent import RoverAgent
from rover_agent.behaviour import DefaultBehaviour
from rover_agent.decisions import Goal, Hit, MoveTo, View
from schemas import messages as m
from schemas.keyspace import Keyspace
from schemas.params import RoverParams
from shared.pose import Pose

RUN = "r1"


def joined_agent(rover_id: int, keys: Keyspace, params: RoverParams, **kwargs) -> RoverAgent:
    """An agent that has had its run's first clock, as every agent on a bus has before it acts on its sensors."""
    agent = RoverAgent(rover_id, keys, params, **kwargs)
    agent.on_clock(m.Clock(tick=0, sim_time=0.0, time_scale=1.0, running=False, run=RUN))
    return agent


# ---- the default behaviour with scripted views ----

PARAMS = RoverParams()
RADIUS = PARAMS.perception.perception_radius  # 10 m
ORIGIN = Pose(0.0, 0.0, 0.0)
BOXED_IN = [Hit(float(a), 1.0, "obstacle") for a in range(-105, 106, 5)]
"""Rocks all round, a metre off: blocked everywhere in view."""


def fresh_behaviour(goal: Goal | None = None) -> DefaultBehaviour:
    """Rover 1's default behaviour, on its way to ``goal`` (50 m straight ahead by default)."""
    b = DefaultBehaviour(1, PARAMS)
    b.start_goal(goal or goal_at())
    return b


def goal_at(x: float = 0.0, z: float = 50.0, kind: str = "waypoint", index: int = 0, total: int = 1) -> Goal:
    return Goal(index, total, kind, x, z)


def view_of(goal: Goal | None = None, pose: Pose = ORIGIN, hits=(), pitch: float = 0.0, time: float = 0.0) -> View:
    return View(time, pose, goal or goal_at(), tuple(hits), pitch)


def angle_of(move: MoveTo) -> float:
    """The move's direction, degrees right of ahead."""
    return math.degrees(math.atan2(move.x, move.z))
