"""``lunarsim batch --in-process``: each seed's mission in one worker process (``harness.loopback``), not a
``lunarsim run`` of a process per agent.

A lockstep mission gives the same report in process as through processes (tests/e2e/test_loopback_equals_processes.py
and tests/e2e/test_batch_in_process.py check it), so a sweep whose product is its reports, Table 2, need not pay for
processes and Zenoh: on the 2-core VM of docs/benchmarks.md a crater mission takes a few seconds in process against
several times that through ``lunarsim run``. A run folder holds what the batch reads, the same files as a run's: its
``report.json`` (with the lander's map scored, as ``lunarsim run`` scores it), the lander's photo archive and its
traverse map. No recording, logs or processes' state: use ``lunarsim run`` for a mission to watch or replay.
"""

from __future__ import annotations

import multiprocessing
import time
from collections.abc import Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, TypeVar

if TYPE_CHECKING:
    from schemas.scenario import Scenario


class SeededRun(Protocol):
    """A run of the batch (``deploy.batch.Run``): its seed, and the folder its report goes to."""

    seed: int
    out: Path


Run = TypeVar("Run", bound=SeededRun)


def run_all(runs: list[Run], scenario: Scenario, jobs: int, max_sim_time: float) -> Iterator[tuple[Run, str]]:
    """Each run as it ends, with why it failed ("" if it did not), ``jobs`` at a time in worker processes (spawned:
    a worker starts from nothing of this process's but its arguments). A worker that dies (killed, out of
    memory) fails the runs it held; the rest go on in a new pool."""
    pending = list(runs)
    while pending:
        yield from _in_pool(pending, scenario, jobs, max_sim_time)


def _in_pool(pending: list[Run], scenario: Scenario, jobs: int, max_sim_time: float) -> Iterator[tuple[Run, str]]:
    """Runs taken from ``pending`` until it is empty, or until the pool breaks."""
    with ProcessPoolExecutor(max_workers=jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        active: dict[Future, Run] = {}
        while pending or active:
            while pending and len(active) < jobs:
                run = pending.pop(0)
                active[pool.submit(run_seed, scenario, run.seed, run.out, max_sim_time)] = run
            done, _ = wait(active, return_when=FIRST_COMPLETED)
            broken = False
            for future in done:
                broken |= isinstance(future.exception(), BrokenProcessPool)
                yield active.pop(future), _failure(future)
            if broken:
                for future, run in active.items():
                    future.exception()  # every one of them ended with the pool
                    yield run, _failure(future)
                return


def _failure(future: Future) -> str:
    exc = future.exception()
    if exc is None:
        return ""
    text = str(exc).strip().replace("\n", " | ") or "(no message)"
    return f"in process: {type(exc).__name__}: {text}"


def run_seed(scenario: Scenario, seed: int, out: Path, max_sim_time: float) -> None:
    """One lockstep mission of ``scenario`` with ``seed``, its report written into ``out`` as ``lunarsim run``
    writes it (``wall_time_s`` here is the mission's in this worker)."""
    import msgspec

    from deploy.run_report import with_map_figures, write_report
    from harness.loopback import run_mission
    from lander_agent.archive import PhotoArchive
    from rover_agent.registry import load_behaviour

    scenario = scenario.with_overrides(seed=seed)
    behaviour = load_behaviour(scenario.behaviour)
    out.mkdir(parents=True, exist_ok=True)
    started = time.monotonic()
    world = run_mission(scenario, max_sim_time, PhotoArchive(out / "lander_archive"), behaviour, map_folder=out)
    report = msgspec.structs.replace(world.report(), wall_time_s=round(time.monotonic() - started, 3))
    write_report(with_map_figures(report, scenario, out), out)
