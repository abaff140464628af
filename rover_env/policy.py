"""The shipped rover agent as a policy of the environment: the reference a learned or evolved policy is scored
against, on the same seeds.

Each rover's agent (``rover_agent.agent.RoverAgent`` with the default behaviour, or another ``BaseBehaviour``)
hears the round's samples from ``infos[agent]["samples"]`` and answers with the messages it would publish over
Zenoh; the environment takes those as a message action.
"""

from __future__ import annotations

from typing import Protocol

from harness.loopback import answer, rover_agents
from rover_agent.behaviour import BaseBehaviour
from rover_env.env import LunarSimEnv
from schemas.messages import MissionReport


class AgentPolicy:
    """Fresh agents for each episode: call ``reset`` with the environment after each ``env.reset``."""

    def __init__(self, behaviour: type[BaseBehaviour] | None = None) -> None:
        self.behaviour = behaviour
        self.agents = {}

    def reset(self, env: LunarSimEnv) -> None:
        rounds = env.rounds
        agents = rover_agents(rounds.world.scenario, rounds.keys, rounds.rover_ids, self.behaviour)
        self.agents = {env.possible_agents[i]: agents[rid] for i, rid in enumerate(rounds.rover_ids)}

    def act(self, observations: dict, infos: dict) -> dict[str, list]:
        """The agents read the samples, not the arrays: they were written against messages."""
        return {name: answer(agent, infos[name]["samples"]) for name, agent in self.agents.items() if name in infos}


class Policy(Protocol):
    """What ``run_episode`` and ``rover_env.vector.evaluate`` drive: any object with these two methods."""

    def reset(self, env: LunarSimEnv) -> None: ...

    def act(self, observations: dict, infos: dict) -> dict: ...


def run_episode(env: LunarSimEnv, policy: Policy, seed: int | None = None) -> tuple[MissionReport, dict]:
    """One whole episode under ``policy``; returns the environment's report and the summed reward per agent."""
    observations, infos = env.reset(seed=seed)
    policy.reset(env)
    totals = dict.fromkeys(env.possible_agents, 0.0)
    while env.agents:
        observations, rewards, _, _, infos = env.step(policy.act(observations, infos))
        for agent, reward in rewards.items():
            totals[agent] += reward
    return env.report(), totals
