"""LunarSim for behaviour research: a PettingZoo environment over the in-process lockstep world.

    from rover_env import parallel_env
    env = parallel_env("crater_observation", max_sim_time=60.0)

``env`` (``LunarSimEnv``) one agent a rover; ``AgentPolicy`` the shipped agent as a policy, ``run_episode`` one
episode, ``VectorEnv`` and ``evaluate`` many at once, ``RewardWeights`` the reward's terms.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from rover_env.actions import ActionError
from rover_env.env import LunarSimEnv
from rover_env.policy import AgentPolicy, Policy, run_episode
from rover_env.rewards import RewardWeights
from rover_env.vector import VectorEnv, evaluate
from schemas.scenario import Scenario, load_scenario

__all__ = ["ActionError", "AgentPolicy", "LunarSimEnv", "Policy", "RewardWeights", "VectorEnv", "evaluate",
           "parallel_env", "run_episode"]


def parallel_env(scenario: Scenario | str | Path, **kwargs: Any) -> LunarSimEnv:
    """The environment, as PettingZoo's own are made: ``parallel_env("crater_observation", max_sim_time=60.0)``.
    ``scenario`` is a ``Scenario``, a scenario file or a shipped scenario's name; ``kwargs`` are
    ``LunarSimEnv``'s."""
    return LunarSimEnv(scenario if isinstance(scenario, Scenario) else load_scenario(scenario), **kwargs)
