"""The editor's scenarios, read and validated in a worker process and within the sizes a scenario file may have.

A scenario from the page is untrusted and costly to read: parsing, validating and drawing one near the bounds
takes seconds, and pydantic holds the GIL while it validates. Done on the event loop, that would stall every page,
the live view's stream and ``/api/info`` included. So aiohttp refuses a body beyond ``MAX_REQUEST_BYTES`` before
reading it, each job (parse, validate, draw the preview, encode the answer) runs in one worker process, so uploads
take one core at most, at most ``MAX_PENDING`` wait for it, and no answer is larger than ``MAX_RESPONSE_BYTES``.

The jobs are plain functions of bytes, run by ``Worker.run``; each returns an ``Answer`` (status and JSON body),
never raises for bad input.
"""

from __future__ import annotations

import asyncio
import contextlib
import functools
import json
import multiprocessing
import signal
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

from schemas.errors import LunarSimError
from schemas.scenario import Scenario, ScenarioError
from schemas.scenario_limits import MAX_ROCKS, MAX_SCENARIO_BYTES
from web import editor
from web.scene import scenario_scene

T = TypeVar("T")

JSON_EXPANSION = 3
"""The page sends a scenario as the model's JSON, every default spelled out: about three times the YAML file
it came from at most (a crater given by x, z and radius grows by its three defaults)."""
MAX_REQUEST_BYTES = JSON_EXPANSION * MAX_SCENARIO_BYTES
"""Largest request body: the largest scenario file the loader accepts, as the page's JSON."""
SCENE_BYTES_PER_ROCK = 100
"""A rock in the preview's JSON (about 80 bytes: a scattered rock's coordinates keep every digit)."""
MAX_RESPONSE_BYTES = 2 * MAX_REQUEST_BYTES + MAX_ROCKS * SCENE_BYTES_PER_ROCK
"""Largest answer: the scenario echoed back and drawn once more for the preview, its rock fields scattered into
as many rocks as the model allows."""
MAX_PENDING = 4
"""Uploads read or waiting for the worker at once; more are refused as busy, so bodies held in memory stay
bounded (``MAX_PENDING`` x ``MAX_REQUEST_BYTES``)."""


@dataclass(frozen=True)
class LaunchPlan:
    """What the event loop needs to start a run the worker has validated and saved."""

    scenario: Scenario
    scene: dict
    path: Path
    time_scale: float


@dataclass(frozen=True)
class Answer:
    status: int
    body: bytes
    plan: LaunchPlan | None = None


def answer(payload: dict, status: int = 200) -> Answer:
    """The JSON answer, or a refusal when it would exceed ``MAX_RESPONSE_BYTES``."""
    body = json.dumps(payload, separators=(",", ":")).encode()
    if len(body) > MAX_RESPONSE_BYTES:
        return error(f"the answer would be {_mib(len(body))}, more than the {_mib(MAX_RESPONSE_BYTES)} the editor "
                     "sends: edit this scenario as a file and run it with lunarsim run", 413)
    return Answer(status, body)


def error(message: str, status: int = 400) -> Answer:
    return Answer(status, json.dumps({"ok": False, "error": message}).encode())


def _mib(n: int) -> str:
    return f"{n / 1024**2:.1f} MiB"


def mib(n: int) -> str:
    """A limit in MiB as the user reads it: 1 MiB, 0.5 MiB."""
    return f"{n / 1024**2:g} MiB"


def _answering(job: Callable[..., Answer]) -> Callable[..., Answer]:
    """A job whose bad input becomes a 400 answer naming the problem, as the page shows it."""

    @functools.wraps(job)
    def run(*args: object) -> Answer:
        try:
            return job(*args)
        except (ScenarioError, ValueError) as exc:
            return error(str(exc))

    return run


def request_object(body: bytes) -> dict:
    try:
        data = json.loads(body)
    except (ValueError, RecursionError):
        raise ValueError("request body is not JSON") from None
    if not isinstance(data, dict):
        raise ValueError("expected a JSON object")
    return data


def summary(scenario: Scenario) -> str:
    obstacles = scenario.obstacles
    return (f"{scenario.name}: {len(scenario.rovers)} rovers, {len(scenario.craters)} craters, "
            f"{len(scenario.mission)} goals, {len(obstacles.rocks)} rocks, {len(obstacles.walls)} walls, "
            f"{len(obstacles.rock_fields)} rock fields")


@_answering
def validate(body: bytes) -> Answer:
    data = request_object(body)
    scenario = editor.scenario_from_page(data.get("scenario"))
    preview = scenario_scene(scenario) if data.get("scene") else None
    return answer({"ok": True, "scenario": editor.scenario_json(scenario), "scene": preview,
                   "summary": summary(scenario)})


@_answering
def save(body: bytes, workspace: editor.Workspace) -> Answer:
    data = request_object(body)
    scenario = editor.scenario_from_page(data.get("scenario"))
    path = workspace.save(str(data.get("name") or scenario.name), scenario)
    return answer({"ok": True, "path": str(path), "name": path.stem})


@_answering
def prepare_launch(body: bytes, workspace: editor.Workspace) -> Answer:
    """Validate and save the scenario, and draw the scene the live view switches to once the run starts."""
    data = request_object(body)
    scenario = editor.scenario_from_page(data.get("scenario"))
    time_scale = float(data.get("time_scale") or 1.0)
    path = workspace.save(str(data.get("name") or scenario.name), scenario)
    plan = LaunchPlan(scenario, scenario_scene(scenario), path, time_scale)
    return Answer(200, b"", plan)


@_answering
def load(workspace: editor.Workspace, name: str) -> Answer:
    try:
        scenario = workspace.load(name)
    except ScenarioError as exc:
        return error(str(exc), 404)
    return answer({"ok": True, "scenario": editor.scenario_json(scenario)})


@_answering
def profile_import(body: bytes) -> Answer:
    data = request_object(body)
    scenario = editor.profile_scenario(data.get("profile"), str(data.get("name") or "profile"))
    return answer({"ok": True, "scenario": editor.scenario_json(scenario)})


@_answering
def profile_export(body: bytes) -> Answer:
    scenario = editor.scenario_from_page(request_object(body).get("scenario"))
    return answer({"ok": True, "profile": editor.profile_of(scenario)})


class Busy(LunarSimError):
    """``MAX_PENDING`` uploads are already in hand."""


class WorkerDied(LunarSimError):
    """The worker process ended during a job (killed, or out of memory)."""


def _ignore_interrupt() -> None:
    """Ctrl-C reaches the whole process group: the view stops the worker itself, without a traceback."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


class Worker:
    """One worker process for the jobs above, started on first use and started again if it dies."""

    def __init__(self, max_pending: int = MAX_PENDING) -> None:
        self.max_pending = max_pending
        self.pending = 0
        self.running = 0
        self._pool: ProcessPoolExecutor | None = None

    @contextlib.contextmanager
    def admit(self) -> Iterator[None]:
        """Hold a place while the body is read and the job runs; ``Busy`` when none is left."""
        if self.pending >= self.max_pending:
            raise Busy
        self.pending += 1
        try:
            yield
        finally:
            self.pending -= 1

    async def run(self, job: Callable[..., T], *args: object) -> T:
        """``job(*args)`` in the worker; ``WorkerDied`` if the worker ended under it (it starts again next time)."""
        self.running += 1
        try:
            return await asyncio.get_running_loop().run_in_executor(self._executor(), job, *args)
        except BrokenProcessPool:
            self._pool = None
            raise WorkerDied from None
        finally:
            self.running -= 1

    def _executor(self) -> ProcessPoolExecutor:
        # spawn, not fork: the view's process runs Zenoh's threads, which a forked child would inherit mid-state.
        if self._pool is None:
            self._pool = ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"),
                                             initializer=_ignore_interrupt)
        return self._pool

    def close(self) -> None:
        """Stop the worker now, even mid-job: the view is going away and no one waits for the answer."""
        pool, self._pool = self._pool, None
        if pool is None:
            return
        if hasattr(pool, "terminate_workers"):  # Python 3.14 on
            pool.terminate_workers()
            return
        # Before 3.14 the pool has no public way to end a job under way, which shutdown() would wait out.
        processes = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            process.terminate()
