"""Environments on every core, two ways.

- ``VectorEnv``: several environments stepped together, each in a worker process, the policy in the caller
  (where a batched network would run). A worker whose episode ends resets at once with its next seed (its first
  seed plus the number of workers, and so on), so each ``step`` steps live episodes; the ended episode's report
  comes back in ``infos["__episode__"]``. Every step pickles every observation through a pipe, so it pays off
  only when a step has work in it.
- ``evaluate``: whole episodes of a policy that can live in the worker (a rule, an evolved genome, the shipped
  agent) on many seeds, in a process pool: what scoring a behaviour on many seeds needs, with no traffic per step.
"""

from __future__ import annotations

import multiprocessing as mp
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor
from multiprocessing.connection import Connection

from rover_env.env import LunarSimEnv
from rover_env.policy import Policy, run_episode

EPISODE = "__episode__"


def _work(pipe: Connection, make_env: Callable[[], LunarSimEnv], seed: int, stride: int) -> None:
    env = make_env()
    try:
        while True:
            command, actions = pipe.recv()
            if command == "close":
                return
            if command == "reset":
                pipe.send(env.reset(seed=seed))
                continue
            observations, rewards, terminations, truncations, infos = env.step(actions)
            if not env.agents:
                infos = {**infos, EPISODE: {"seed": seed, "report": env.report().model_dump()}}
                seed += stride
                observations, reset_infos = env.reset(seed=seed)
                infos = {**reset_infos, EPISODE: infos[EPISODE]}
            pipe.send((observations, rewards, terminations, truncations, infos))
    finally:
        env.close()
        pipe.close()


class VectorEnv:
    """``n`` copies of ``make_env()`` (a picklable callable), seeded ``seed``, ``seed + 1``, ..."""

    def __init__(self, make_env: Callable[[], LunarSimEnv], n: int, seed: int = 0) -> None:
        context = mp.get_context("spawn")  # no forked copies of the caller's threads or sessions
        self.pipes, self.workers = [], []
        for i in range(n):
            mine, theirs = context.Pipe()
            worker = context.Process(target=_work, args=(theirs, make_env, seed + i, n), daemon=True)
            worker.start()
            theirs.close()
            self.pipes.append(mine)
            self.workers.append(worker)

    def reset(self) -> list[tuple[dict, dict]]:
        return self._all("reset", [None] * len(self.pipes))

    def step(self, actions: list[dict]) -> list[tuple]:
        return self._all("step", actions)

    def close(self) -> None:
        for pipe in self.pipes:
            pipe.send(("close", None))
        for worker in self.workers:
            worker.join(timeout=10)
            if worker.is_alive():
                worker.kill()

    def _all(self, command: str, payloads: list) -> list:
        for pipe, payload in zip(self.pipes, payloads, strict=True):
            pipe.send((command, payload))
        return [pipe.recv() for pipe in self.pipes]

    def __enter__(self) -> VectorEnv:
        return self

    def __exit__(self, *_) -> None:
        self.close()


def evaluate(make_env: Callable[[], LunarSimEnv], make_policy: Callable[[], Policy], seeds: Iterable[int],
             workers: int) -> list[dict]:
    """One episode a seed, ``workers`` at a time; for each, in seed order: the seed, the report (as
    ``report.json``), each agent's summed reward and the rounds stepped. Both factories must pickle (a module-level
    function or ``functools.partial`` of one)."""
    with ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn")) as pool:
        jobs = [pool.submit(_episode, make_env, make_policy, seed) for seed in seeds]
        return [job.result() for job in jobs]


def _episode(make_env: Callable[[], LunarSimEnv], make_policy: Callable[[], Policy], seed: int) -> dict:
    env = make_env()
    report, returns = run_episode(env, make_policy(), seed)
    return {"seed": seed, "report": report.model_dump(), "returns": returns, "rounds": env.cycles}
