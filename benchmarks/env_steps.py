"""Environment steps per second of ``rover_env.LunarSimEnv``, against the plain lockstep mission of the same scenario.

For 5, 20 and 100 rovers (crater_observation respawned in the report's formation), it prints:
- **agent-steps/s**: rounds stepped times rovers, one core, for three policies:
  - ``idle``: array actions that say nothing: every tick is one round, the environment's own cost plus the
    world's (``harness.rounds``, observation arrays, rewards);
  - ``random``: actions sampled from the action spaces (moves, rotations, photos, radio): what an untrained
    learner costs, photo rendering included, over its first ``--random-rounds`` rounds (half its rovers
    broadcast to all the others each round, so a tick's chatter runs to the 64-round cap);
  - ``agent``: the shipped rover agent as the policy (``rover_env.policy.AgentPolicy``): rounds only where a
    rover hears something;
- **vectorised**: over ``--workers`` worker processes (``rover_env.vector``): the idle policy stepping
  environments in the workers from this process (``VectorEnv``: observations through pipes), and the shipped
  agent's whole episodes in a pool (``evaluate``: two seeds a worker);
- **plain**: ``harness.loopback.run_mission`` of the same scenario for the same simulated time, against the
  agent policy's episode: simulated seconds per wall second of each, and their ratio (the environment's cost).
Where the time goes: ``--profile`` prints the top of a cProfile of the idle run.

    python benchmarks/env_steps.py [--rovers 5 20 100] [--sim-seconds 60] [--workers 2] [--random-rounds 1000]
                                   [--json FILE]
    python benchmarks/env_steps.py --quick    # 5 rovers for 3 simulated seconds, one worker
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import sys
import time
from functools import partial
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import host
import quick

from harness.loopback import run_mission
from rover_env import spaces as sp
from rover_env.env import LunarSimEnv
from rover_env.policy import AgentPolicy
from rover_env.vector import VectorEnv, evaluate
from schemas.scenario import Scenario, load_scenario

SCENARIO = Path(__file__).resolve().parents[1] / "scenarios" / "crater_observation.yaml"
QUICK = {"rovers": [5], "sim_seconds": 3.0, "random_rounds": 20, "workers": 1}


def scenario(rovers: int) -> Scenario:
    return load_scenario(SCENARIO).with_overrides(rovers=rovers)


def make_env(rovers: int, sim_seconds: float) -> LunarSimEnv:
    return LunarSimEnv(scenario(rovers), max_sim_time=sim_seconds)


def idle_action() -> dict:
    return {"command": 0, "move": np.zeros(2, np.float32), "rotate": np.zeros(1, np.float32), "speed": 0,
            "goal": 0, "radio": 0, "radio_out": np.zeros(sp.RADIO_FLOATS, np.float32)}


def single(env: LunarSimEnv, policy: str, max_rounds: int) -> dict:
    """Agent-steps a second of one episode under ``policy``, stopped after ``max_rounds`` rounds."""
    observations, infos = env.reset(seed=1)
    agents = AgentPolicy()
    agents.reset(env)
    for i, agent in enumerate(env.possible_agents):
        env.action_space(agent).seed(i)
    idle, steps, start = idle_action(), 0, time.perf_counter()
    while env.agents and env.cycles < max_rounds:
        if policy == "idle":
            actions = dict.fromkeys(env.agents, idle)
        elif policy == "random":
            # no goal reports: random ones say "stuck" at once and end the episode
            actions = {agent: {**env.action_space(agent).sample(), "goal": 0} for agent in env.agents}
        else:
            actions = agents.act(observations, infos)
        steps += len(env.agents)
        observations, _, _, _, infos = env.step(actions)
    wall = time.perf_counter() - start
    sim = env.rounds.world.clock.sim_time
    return {"agent_steps_per_s": round(steps / wall), "rounds": env.cycles, "sim_s": round(sim, 1),
            "wall_s": round(wall, 2), "sim_s_per_wall_s": round(sim / wall, 1)}


def vectorised(rovers: int, sim_seconds: float, workers: int, rounds: int) -> dict:
    """Agent-steps a second of ``workers`` environments stepped together with the idle policy."""
    with VectorEnv(partial(make_env, rovers, sim_seconds), workers) as envs:
        names = [name for name, _ in envs.reset()[0][1].items() if name.startswith("rover")]
        actions = [dict.fromkeys(names, idle_action())] * workers
        start = time.perf_counter()
        for _ in range(rounds):
            envs.step(actions)
        wall = time.perf_counter() - start
    return {"workers": workers, "agent_steps_per_s": round(rounds * workers * rovers / wall)}


def episodes(rovers: int, sim_seconds: float, workers: int) -> dict:
    """Agent-steps a second of the shipped agent's whole episodes, two a worker, run in a pool."""
    start = time.perf_counter()
    results = evaluate(partial(make_env, rovers, sim_seconds), AgentPolicy, range(1, 2 * workers + 1), workers)
    wall = time.perf_counter() - start
    return {"workers": workers, "episodes": len(results),
            "agent_steps_per_s": round(sum(r["rounds"] for r in results) * rovers / wall)}


def plain(rovers: int, sim_seconds: float) -> dict:
    start = time.perf_counter()
    world = run_mission(scenario(rovers).with_overrides(seed=1), sim_seconds)
    wall = time.perf_counter() - start
    return {"sim_s": round(world.clock.sim_time, 1), "wall_s": round(wall, 2),
            "sim_s_per_wall_s": round(world.clock.sim_time / wall, 1)}


def measure(rovers: int, sim_seconds: float, workers: int, max_rounds: int) -> dict:
    result = {policy: single(make_env(rovers, sim_seconds), policy, max_rounds if policy == "random" else 10**9)
              for policy in ("idle", "random", "agent")}
    result["vectorised"] = vectorised(rovers, sim_seconds, workers, result["idle"]["rounds"] // 2)
    result["episodes"] = episodes(rovers, sim_seconds, workers)
    result["plain"] = plain(rovers, sim_seconds)
    result["agent_cost"] = round(result["plain"]["sim_s_per_wall_s"] / result["agent"]["sim_s_per_wall_s"], 2)
    return result


def show(rovers: int, r: dict) -> None:
    print(f"{rovers:>4} rovers | idle {r['idle']['agent_steps_per_s']:>7,} | random "
          f"{r['random']['agent_steps_per_s']:>7,} | agent {r['agent']['agent_steps_per_s']:>7,} | "
          f"{r['vectorised']['workers']} workers: idle {r['vectorised']['agent_steps_per_s']:>7,}, agent episodes "
          f"{r['episodes']['agent_steps_per_s']:>7,} agent-steps/s | "
          f"sim s per wall s: agent policy {r['agent']['sim_s_per_wall_s']}, plain run {r['plain']['sim_s_per_wall_s']}"
          f" ({r['agent_cost']}x)", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rovers", type=int, nargs="+", default=[5, 20, 100])
    parser.add_argument("--sim-seconds", type=float, default=60.0, help="simulated seconds an episode")
    parser.add_argument("--workers", type=int, default=2, help="environments in the vectorised run")
    parser.add_argument("--random-rounds", type=int, default=1000,
                        help="rounds of the random policy (its radio chatter grows with the square of the team)")
    parser.add_argument("--profile", action="store_true", help="profile the idle policy of the first team size")
    parser.add_argument("--json", type=Path, help="write the figures here")
    args = quick.parse_args(parser, QUICK)
    about = {"host": host.describe(), "code": host.code_version(), "sim_seconds": args.sim_seconds}
    print(host.line(about["host"]), f"| commit {about['code']['commit']}")
    if args.profile:
        profile = cProfile.Profile()
        profile.runcall(single, make_env(args.rovers[0], args.sim_seconds), "idle", 10**9)
        pstats.Stats(profile).sort_stats("tottime").print_stats(15)
    results = {}
    for rovers in args.rovers:
        results[rovers] = measure(rovers, args.sim_seconds, args.workers, args.random_rounds)
        show(rovers, results[rovers])
    if args.json:
        args.json.write_text(json.dumps({**about, "results": results}, indent=2))


if __name__ == "__main__":
    main()
