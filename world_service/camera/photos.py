"""Photos: what a PhotoAction froze (``PhotoJob``), how it becomes a PNG, and the camera process that renders
photos beside the world's clock.

A 160x120 photo is 30-90 ms of NumPy. On a thread of the world's process it would hold the GIL between NumPy
calls and stall every Zenoh call of the clock loop by up to a switch interval; in a process of its own it runs
on the other core. That process is spawned, never forked from a process running Zenoh's threads, and rebuilds
the ground from the scenario alone (the terrain is a pure function of the scenario and its seed), so its photos
are byte for byte the ones the world would render itself.
"""

from __future__ import annotations

import atexit
import contextlib
import logging
import multiprocessing
import os
import signal
import sys
import threading
from concurrent.futures import BrokenExecutor, Future, ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np
import setproctitle

from bus import heap
from bus.lifeline import exit_when_orphaned
from bus.priority import Priority, lower
from bus.process import freeze_before_fork
from schemas import messages as m
from schemas.params import RoverParams
from schemas.scenario import Scenario
from world_service.camera import rendering
from world_service.scene import Scene
from world_service.terrain.heightmap import FULL_GRID_LIMIT, Heightmap
from world_service.terrain.views import DenseView

log = logging.getLogger("lunarsim.world")

PHOTO_TILT_DEG = 8.0
"""Photos look slightly down, so a crater seen from its rim fills the frame."""


@dataclass(frozen=True)
class PhotoJob:
    """What a photo shows, frozen at the moment it was asked for."""

    rover_id: int
    stamp: float
    label: str
    due_tick: int  # when the photo reaches the rover: the camera's capture time later
    x: float
    z: float
    heading: float
    others_x: np.ndarray
    others_z: np.ndarray


def render_photo(terrain: rendering.HeightField, scene: Scene, params: RoverParams, job: PhotoJob) -> m.Photo:
    image = rendering.render(terrain, scene, job.others_x, job.others_z, params.behaviour.rover_radius, job.x, job.z,
                          job.heading, params.camera, tilt_deg=PHOTO_TILT_DEG)
    return m.Photo(stamp=job.stamp, label=job.label, png=rendering.encode_png(image))


def build_ground(scenario: Scenario) -> rendering.HeightField:
    """The scenario's terrain, drawn from a generator seeded as the world's is when it builds its own; held
    whole when it is small enough, which samples faster and gives the same heights."""
    terrain = Heightmap.from_scenario(scenario, np.random.default_rng(scenario.seed))
    if terrain.base is None and terrain.nx * terrain.nz <= FULL_GRID_LIMIT:
        return DenseView(terrain)
    return terrain


class CameraProcess:
    """One worker process that renders photo jobs; ``submit`` returns a future of the ``m.Photo``.

    ``priority`` (``bus.priority``): in real time a photo may come a little late, a sensor sample may not. A
    hundred rovers at a crater keep the camera rendering a third of a core, and at the world's priority it takes
    that from the world and the rover agents just when their samples are due; ``idle``, it renders on what the
    world leaves, sharing that with the agents. In lockstep the clock waits for the render, so it keeps the
    world's priority (``equal``).

    The ground (the terrain, Numba's loops: most of a CPU second) is built when asked (``prepare``) or at the
    first photo, not as the process starts: many runs take no photo, or stop before their first (the test suite's
    short runs, a maze), and should not pay for it (``Photographer.await_camera`` says when it is asked).
    """

    def __init__(self, scenario: Scenario, priority: Priority = "equal") -> None:
        self.pool = ProcessPoolExecutor(max_workers=1, mp_context=_context(), initializer=_start,
                                        initargs=(scenario, priority, os.getpid()))
        self.started = self.pool.submit(os.getpid)  # start the process now, not at the first photo
        self._building: Future | None = None

    def submit(self, job: PhotoJob) -> Future:
        return self.pool.submit(_render, job)

    def ready(self) -> Future:
        """Done once the process is up and, if it was asked to (``prepare``), has built its ground."""
        return self._building or self.started

    def prepare(self) -> None:
        """Build the ground now, in the camera process, if not built yet: a photo asked for later waits only for
        what is left of the build."""
        self._building = self.pool.submit(_prepare)

    def close(self) -> None:
        """Stop the process; one still building its ground for a photo nobody will ask for now (a mission that
        ended before its first) is stopped at once rather than waited for."""
        if self._building is not None and not self._building.done() and self.started.done():
            with contextlib.suppress(OSError, BrokenExecutor):
                os.kill(self.started.result(), signal.SIGKILL)
        self.pool.shutdown(wait=True, cancel_futures=True)


def _context() -> multiprocessing.context.BaseContext:
    """Forked where the platform can: the world has imported NumPy, pydantic and the schemas by then, so the camera
    starts with them in memory (about 0.4 CPU seconds of a cold start).
    Safe because the world starts it before it opens its Zenoh session (``service.start_camera``); started later,
    from a world with Zenoh's threads running, it is spawned."""
    if "fork" in multiprocessing.get_all_start_methods() and threading.active_count() == 1:
        sys.stdout.flush()  # else the child would write out the world's buffered output again
        sys.stderr.flush()
        freeze_before_fork()
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("spawn")


_scenario: Scenario | None = None
_ground: tuple[rendering.HeightField, Scene, RoverParams] | None = None


def _start(scenario: Scenario, priority: Priority, world_pid: int) -> None:
    global _scenario
    # forked, it would show as a second world service (its command line) in ps, pkill -f and the launcher's count
    setproctitle.setproctitle(f"lunarsim camera of world {world_pid}")
    # a Ctrl-C at the terminal reaches every process of the run: the world stops its camera (``close``), and one
    # interrupted mid-photo only printed a traceback into the world's log and broke the pool the world still used
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    exit_when_orphaned(world_pid)  # a world killed with SIGKILL cannot shut its pool down
    lower(priority)
    heap.keep_freed_memory()  # a photo's rays are a few arrays of 0.5 MB, made and dropped each photo
    _scenario = scenario
    atexit.register(_exit_now)


def _prepare() -> None:
    """``_prepared`` for ``CameraProcess.prepare``, returning nothing: the ground's arrays stay in this process rather
    than being pickled back to the world."""
    _prepared()


def _prepared() -> tuple[rendering.HeightField, Scene, RoverParams]:
    global _ground
    if _ground is None:
        from world_service.terrain import height_grid  # Numba: loaded in the camera process, not in the world's

        _ground = (build_ground(_scenario), Scene.from_scenario(_scenario), _scenario.rover_params)
        height_grid.warm_up()
    return _ground


def _exit_now() -> None:
    """The process's end, without tearing its interpreter down: unloading Numba's compiled loops and the terrain
    took most of a second, which the world's last moments (its report, the launcher's wait for it) waited out.
    Nothing is left to save: the pool only ends its worker once every photo is back."""
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)


def _render(job: PhotoJob) -> m.Photo:
    terrain, scene, params = _prepared()
    return render_photo(terrain, scene, params, job)
