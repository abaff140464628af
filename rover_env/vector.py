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

import contextlib
import multiprocessing as mp
from collections.abc import Callable, Iterable
from concurrent.futures import ProcessPoolExecutor
from multiprocessing.connection import Connection

import msgspec

from rover_env.env import LunarSimEnv
from rover_env.policy import Policy, run_episode

EPISODE = "__episode__"


def _work(pipe: Connection, make_env: Callable[[], LunarSimEnv], seed: int, stride: int) -> None:
    worker = _Worker(make_env(), seed, stride)
    try:
        while True:
            command, actions = pipe.recv()
            if command == "close":
                return
            try:
                pipe.send(("ok", worker.reset() if command == "reset" else worker.step(actions)))
            except Exception as exc:  # to the caller, who raises it naming this worker: not lost on our stderr
                pipe.send(("error", f"{type(exc).__name__}: {exc} (episode seed {worker.seed})"))
    except (EOFError, KeyboardInterrupt):  # the caller has gone
        return
    finally:
        worker.env.close()
        pipe.close()


class _Worker:
    def __init__(self, env: LunarSimEnv, seed: int, stride: int) -> None:
        self.env, self.seed, self.stride = env, seed, stride

    def reset(self):
        return self.env.reset(seed=self.seed)

    def step(self, actions: dict):
        observations, rewards, terminations, truncations, infos = self.env.step(actions)
        if self.env.agents:
            return observations, rewards, terminations, truncations, infos
        ended = {"seed": self.seed, "report": msgspec.to_builtins(self.env.report())}
        self.seed += self.stride
        observations, reset_infos = self.reset()
        return observations, rewards, terminations, truncations, {**reset_infos, EPISODE: ended}


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
        """Safe to call twice, and after a worker has died: every worker is joined or killed."""
        for pipe in self.pipes:
            with contextlib.suppress(OSError, EOFError):
                pipe.send(("close", None))
        for worker in self.workers:
            worker.join(timeout=10)
            if worker.is_alive():
                worker.kill()
                worker.join()
        for pipe in self.pipes:
            pipe.close()
        self.pipes, self.workers = [], []

    def _all(self, command: str, payloads: list) -> list:
        for pipe, payload in zip(self.pipes, payloads, strict=True):
            pipe.send((command, payload))
        answers = [pipe.recv() for pipe in self.pipes]
        for i, (status, value) in enumerate(answers):
            if status == "error":
                raise RuntimeError(f"environment {i} of {len(answers)}: {value}")
        return [value for _, value in answers]

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
    return {"seed": seed, "report": msgspec.to_builtins(report), "returns": returns, "rounds": env.cycles}
