"""The world's camera at run time: photo jobs rendered in a camera process, published (and saved) when due.

The rendering itself is ``photos`` and ``rendering``, the jobs come from the world's ``shutter``; this is the
service's side of it: when a photo goes out, in real time and in lockstep, and what happens when the camera process
dies.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections.abc import Callable, Iterable
from concurrent.futures import BrokenExecutor, Future
from pathlib import Path
from typing import Protocol

from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.scenario import Scenario
from world_service.camera.photos import CameraProcess, PhotoJob

log = logging.getLogger("lunarsim.world")

CAMERA_START_TIMEOUT_S = 60.0
"""How long the clock waits for the camera process to start (forked from the world: a fraction of a second; spawned,
where the platform cannot fork, about a second of imports)."""


class PhotoSource(Protocol):
    """Where the photos come from: a world's jobs, and a render in its own process should the camera's die."""

    keys: ks.Keyspace
    scenario: Scenario

    def take_photo_jobs(self) -> list[PhotoJob]: ...

    def render(self, job: PhotoJob) -> m.Photo: ...


APPROACH_RADII = 2.0
"""A rover this many crater radii from the centre of a crater goal's crater is on its way to photograph its rim."""


class CraterApproach:
    """When a lockstep camera should build its ground (``Photographer.watch``): once a rover nears a crater the
    mission sends it to photograph. Built at the first photo instead, with the clock waiting, it holds a crater
    mission up for about half a second; built as the clock starts, it takes a core from every short run that
    never gets there (most of the test suite's)."""

    def __init__(self, scenario: Scenario) -> None:
        craters = [scenario.crater_of(goal) for goal in scenario.mission if goal.kind == "crater"]
        self.craters = [(c.x, c.z, (APPROACH_RADII * c.radius_m) ** 2) for c in craters if c is not None]

    def reached(self, positions: Iterable[tuple[float, float]]) -> bool:
        return any((x - cx) ** 2 + (z - cz) ** 2 < reach for x, z in positions for cx, cz, reach in self.craters)


def save_photo(folder: Path, job: PhotoJob, photo: m.Photo) -> None:
    """The world's copy of a photo. The file is named by the world (the rover and the simulated time it was taken):
    the label came from the rover's agent, so it is data, kept in ``index.jsonl``, never part of a path."""
    folder.mkdir(parents=True, exist_ok=True)
    name = f"rover{job.rover_id}_t{job.stamp:09.2f}.png"
    (folder / name).write_bytes(photo.png)
    with open(folder / "index.jsonl", "a", encoding="utf-8") as index:
        index.write(json.dumps({"rover": job.rover_id, "stamp": job.stamp, "label": job.label, "file": name}) + "\n")


class Photographer:
    """Renders the world's photo jobs in a camera process and hands out (and saves) the PNGs when they are due.

    A photo is due ``capture_time_s`` after its PhotoAction. In real time it goes out as soon as it is both
    due and rendered; in lockstep exactly on its due tick, waiting for the render if need be, so runs stay
    reproducible while the render overlaps the ticks before it. Should the camera process die, the photos are
    rendered here instead, and the run goes on.
    """

    def __init__(self, world: PhotoSource, lockstep: bool, camera: CameraProcess | None,
                 photo_dir: Path | None = None) -> None:
        self.world, self.photo_dir = world, photo_dir
        self.wait = lockstep
        self.camera = camera
        self.queued: list[tuple[PhotoJob, Future]] = []
        self.waited_s = 0.0  # lockstep: how long the clock waited for renders
        approach = CraterApproach(world.scenario)
        self.approach = approach if lockstep and camera is not None and approach.craters else None
        if not lockstep and approach.craters:
            self.prepare()  # built while the agents connect, and awaited before the clock (``await_camera``)

    def take(self, tick: int) -> list[Out]:
        """Start the new jobs; the photos due by ``tick`` (the tick about to be stepped), to publish."""
        self.queued += [(job, self._submit(job)) for job in self.world.take_photo_jobs()]
        due = [(job, f) for job, f in self.queued if job.due_tick <= tick and (self.wait or f.done())]
        out = []
        for job, future in due:
            self.queued.remove((job, future))
            t0 = time.perf_counter()
            photo = self._result(job, future)
            self.waited_s += time.perf_counter() - t0
            out.append(self._delivered(job, photo))
        return out

    def _submit(self, job: PhotoJob) -> Future:
        if self.camera is not None:
            try:
                return self.camera.submit(job)
            except BrokenExecutor:
                self._lost_camera()
        done: Future = Future()
        done.set_result(self.world.render(job))
        return done

    def _result(self, job: PhotoJob, future: Future) -> m.Photo:
        try:
            return future.result()
        except BrokenExecutor:
            self._lost_camera()
            return self.world.render(job)

    def await_camera(self, stop: threading.Event, waiting: Callable[[], None]) -> None:
        """Before the clock starts, calling ``waiting`` every half second meanwhile: the camera's process is up, and in
        real time, if the mission has a crater goal, its ground built (asked for as the photographer was made). A
        real-time clock does not wait for a photo, and a rover gives up one not back within ``PHOTO_TIMEOUT_S``
        simulated seconds, which at a high time scale, in a crowd or with Numba's cache still empty (a few seconds to
        compile) a build started later could take. A mission with no crater goal (the shipped behaviour photographs
        only a crater's rim) builds it at its first photo, if any; in lockstep the clock waits for each photo anyway
        (``watch``). A camera that fails to start is lost, as one that dies later; one not up after
        ``CAMERA_START_TIMEOUT_S`` is left to finish while the mission runs."""
        if self.camera is None:
            return
        deadline = time.monotonic() + CAMERA_START_TIMEOUT_S
        while self.camera is not None and not stop.is_set() and time.monotonic() < deadline:
            try:
                self.camera.ready().result(timeout=0.5)
                return
            except TimeoutError:
                waiting()
            except BrokenExecutor:
                self._lost_camera()
                return
        if self.camera is not None and not stop.is_set():
            log.warning("the camera process is not up after %g s; starting the clock anyway", CAMERA_START_TIMEOUT_S)

    def watch(self, published: list[Out]) -> None:
        """Lockstep: have the camera build its ground (``prepare``) once the world's published state shows a rover
        nearing a crater goal's crater (``CraterApproach``)."""
        if self.approach is None:
            return
        for key, message in published:
            if key == self.world.keys.state and self.approach.reached((r.x, r.z) for r in message.rovers):
                self.approach = None
                self.prepare()
                return

    def prepare(self) -> None:
        """Have the camera build its ground in the background (else it builds it at the first photo)."""
        if self.camera is not None:
            try:
                self.camera.prepare()
            except BrokenExecutor:
                self._lost_camera()

    def _lost_camera(self) -> None:
        if self.camera is not None:
            log.error("the camera process died; rendering photos in the world's own process from now on")
            self.camera = None

    def _delivered(self, job: PhotoJob, photo: m.Photo) -> Out:
        if self.photo_dir is not None:
            save_photo(self.photo_dir, job, photo)
        return self.world.keys.rover(job.rover_id, ks.PHOTO), photo

    def finish(self) -> list[Out]:
        """The photos still on their way, to publish."""
        self.wait = True
        return self.take(max((job.due_tick for job, _ in self.queued), default=0))

    def close(self) -> None:
        """Stop the camera process."""
        if self.camera is not None:
            self.camera.close()
