"""LunarSim as a PettingZoo ``ParallelEnv``: one agent a rover, over the lockstep world in this process.

A step is one round of a lockstep tick (``harness.rounds``): every rover hears what reached its keys (the clock,
perception, radio...) and answers; the world and the lander run in between with the code of ``lunarsim run
--lockstep``. A policy answering with the shipped rover agent (``rover_env.policy.AgentPolicy``) gives the report
of ``lunarsim run --lockstep --seed`` of the same scenario and seed (tests/e2e/test_rover_env.py), and a rover's
observation is what its agent would receive, nothing more. (A reply to an answer can reach a rover within the
tick here, a tick later over Zenoh: ``docs/guides/research.md``.)

A policy that never acks a clock (the array actions do not) is asked for an answer every tick, so it steps once
a tick at least; the shipped agent acks with its next timer, and its ticks with nothing to hear are skipped.
By default every agent stays until the mission ends (complete: terminated; out of time or ``max_cycles``:
truncated), since a finished rover still answers its lander (photos, map reports) in the processes too. With
``leave_when_done`` a rover whose status says it is done or stuck is terminated at once and leaves the agent list
while the others go on, as multi-agent research environments do.

Each agent's ``infos`` carry ``action_mask``: which ``command`` and ``goal`` values its rover can act on now
(``ArrayActions.mask``); an action outside it is still published, and the world refuses it as it would.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

from gymnasium import spaces
from pettingzoo import ParallelEnv

from harness.rounds import Heard, Rounds
from rover_env import spaces as sp
from rover_env.actions import ActionError, ArrayActions, checked_messages
from rover_env.rewards import Rewards, RewardWeights
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.scenario import Scenario

CLOCK_MODEL = {ks.CLOCK: m.Clock}
LEFT_STATES = frozenset({"done", "stuck"})


def agent_name(rover_id: int) -> str:
    return f"rover{rover_id}"


def decode(topic: str, payload: bytes) -> m.Message:
    return codec.decode(CLOCK_MODEL.get(topic) or m.TOPIC_MODELS[topic], payload)


class LunarSimEnv(ParallelEnv):
    """``reset(seed=s)`` replays the scenario with seed ``s`` (None: the scenario's own), bit for bit."""

    metadata: ClassVar[dict] = {"name": "lunarsim_v0", "render_modes": []}

    def __init__(self, scenario: Scenario, max_sim_time: float = 600.0, max_cycles: int | None = None,
                 rewards: RewardWeights | None = None, leave_when_done: bool = False) -> None:
        self.scenario = scenario
        self.leave_when_done = leave_when_done
        self.max_sim_time = max_sim_time
        self.max_cycles = max_cycles
        self.weights = rewards or RewardWeights()
        ids = list(range(1, len(scenario.rovers) + 1))
        self.possible_agents = [agent_name(rid) for rid in ids]
        self._ids = dict(zip(self.possible_agents, ids, strict=True))
        params = scenario.rover_params
        self._obs_space = sp.observation_space(params, len(ids) + 1)
        self._empty = sp.empty_observation(self._obs_space)
        self._action_spaces = {agent: sp.action_space(params) for agent in self.possible_agents}
        """One action space object an agent, so seeding one agent's sampling leaves the others' alone."""
        self.agents: list[str] = []
        self.rounds: Rounds | None = None

    def observation_space(self, agent: str) -> spaces.Dict:
        _known(agent, self._ids)
        return self._obs_space

    def action_space(self, agent: str) -> spaces.Dict:
        _known(agent, self._ids)
        return self._action_spaces[agent]

    def reset(self, seed: int | None = None, options: dict | None = None):
        scenario = self.scenario.with_overrides(seed=seed) if seed is not None else self.scenario
        self.rounds = Rounds(scenario, self.max_sim_time)
        self.rewards = Rewards(self.rounds.world, self.weights)
        ids = self.rounds.rover_ids
        self._arrays = {rid: ArrayActions(self.rounds.keys, rid, [o for o in ids if o != rid],
                                          self._action_spaces[agent_name(rid)]) for rid in ids}
        self.agents = list(self.possible_agents)
        self.cycles = 0
        self._report: m.MissionReport | None = None
        observations, _, infos = self._observe(self.rounds.advance({}))
        return observations, infos

    def step(self, actions: Mapping[str, object]):
        if self.rounds is None or not self.agents:
            raise RuntimeError("step() after the episode ended: call reset() first")
        for agent in actions:
            if agent not in self.agents:
                raise ActionError(f"no live agent {agent!r}: this episode's are {', '.join(self.agents)}")
        answers = {self._ids[agent]: self._messages(agent, action) for agent, action in actions.items()}
        heard = self.rounds.advance(answers)
        self.cycles += 1
        observations, rewards, infos = self._observe(heard)
        over = self.rounds.over or (self.max_cycles is not None and self.cycles >= self.max_cycles)
        done = over and self.rounds.world.complete
        terminations = {agent: done or self._left(agent) for agent in self.agents}
        truncations = {agent: over and not terminations[agent] for agent in self.agents}
        self.agents = [] if over else [agent for agent in self.agents if not terminations[agent]]
        return observations, rewards, terminations, truncations, infos

    def _left(self, agent: str) -> bool:
        """With ``leave_when_done``: its rover says it is done or stuck (an array action's goal report, or the status
        a message policy sent, once the world has it), so nothing it does changes the mission."""
        rid = self._ids[agent]
        said = {self._arrays[rid].state, self.rounds.world.referee.status[rid].state}
        return self.leave_when_done and bool(said & LEFT_STATES)

    def report(self) -> m.MissionReport:
        """The mission's statistics (``report.json``) as of now; the final ones once the episode is over."""
        if self.rounds is None:
            raise RuntimeError("no episode yet: call reset() first")
        if self._report is None and self.rounds.over:
            self._report = self.rounds.finish().report()
        return self._report or self.rounds.world.report()

    def close(self) -> None:
        self.rounds = None

    def _messages(self, agent: str, action: object) -> list[Out]:
        rid = self._ids[agent]
        if isinstance(action, list):
            return checked_messages(self.rounds.keys, rid, action)
        return self._arrays[rid].messages(action, self.rounds.world.clock.sim_time)

    def _observe(self, heard: Heard):
        observations, rewards, infos = {}, {}, {}
        world = self.rounds.world
        for agent in self.agents:
            rid = self._ids[agent]
            samples = heard.get(rid, [])
            decoded = [(topic, decode(topic, payload)) for topic, payload in samples]
            for topic, msg in decoded:
                self._arrays[rid].hear(topic, msg)
            observations[agent] = sp.observe(decoded, self._empty)
            rewards[agent] = self.rewards.round(rid, decoded)
            infos[agent] = {"samples": samples, "tick": world.clock.tick, "sim_time": world.clock.sim_time,
                            "action_mask": self._arrays[rid].mask()}
        return observations, rewards, infos


def _known(agent: str, ids: Mapping[str, int]) -> None:
    if agent not in ids:
        raise KeyError(f"no agent {agent!r}: this mission's agents are {', '.join(ids)}")
