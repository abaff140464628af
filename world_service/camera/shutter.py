"""Each rover's camera as the simulated world holds it: one photo at a time, each frozen as a ``PhotoJob`` when it
is asked for and due ``capture_time_s`` later. The world only queues the jobs; rendering is slow, so the service
decides where and when (``photographer``), and the in-process harness renders them itself (``render``).
"""

from __future__ import annotations

import numpy as np

from schemas import messages as m
from schemas.params import RoverParams
from world_service.camera.photos import PhotoJob, render_photo
from world_service.scene import Scene
from world_service.terrain.heightmap import Heightmap
from world_service.terrain.views import UncachedView


class Shutter:
    def __init__(self, terrain: Heightmap, scene: Scene, params: RoverParams, dt: float) -> None:
        self.terrain, self.scene, self.params = terrain, scene, params
        self.capture_ticks = max(1, round(params.camera.capture_time_s / dt))
        self.free_at: dict[int, int] = {}  # rover -> first tick its camera may take another photo
        self.jobs: list[PhotoJob] = []  # taken, not yet handed to whoever renders them

    def busy(self, rid: int, tick: int) -> bool:
        """Still taking the last photo: a flood of photo actions must not queue renders without end."""
        return tick < self.free_at.get(rid, 0)

    def shoot(self, rid: int, label: str, tick: int, sim_time: float, pose: tuple[float, float, float],
              others_x: np.ndarray, others_z: np.ndarray) -> None:
        """A photo of what the rover at ``pose`` (x, z, heading) sees now, with the other rovers where they stand."""
        due = tick + self.capture_ticks
        self.free_at[rid] = due
        self.jobs.append(PhotoJob(rid, sim_time, label, due, *pose, others_x, others_z))

    def take_jobs(self) -> list[PhotoJob]:
        """The photos taken since the last call, to render."""
        jobs, self.jobs = self.jobs, []
        return jobs

    def render(self, job: PhotoJob) -> m.Photo:
        """The photo rendered here (tests, the in-process harness); the service renders in a camera process."""
        return render_photo(UncachedView(self.terrain), self.scene, self.params, job)
