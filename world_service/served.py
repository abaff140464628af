"""What the world service's loop (``service``), its lockstep schedule (``lockstep``) and its photographer need of a
world: the simulation (``sim.World``) and the hardware twin (``twin.world.TwinWorld``) both offer it.

A world does no I/O: samples in, (key, message) pairs out. The service subscribes to its ``input_keys``, hands it
what arrives (``receive``) and the agents' liveliness (``set_alive``), steps it (``step``) on its clock, publishes
what it returns, and at the end publishes its final state and report.
"""

from __future__ import annotations

from collections.abc import Collection
from typing import TYPE_CHECKING, ClassVar, Protocol, runtime_checkable

from bus.rejections import Rejections
from schemas import keyspace as ks
from schemas import messages as m
from schemas.messages import Out
from schemas.scenario import Scenario
from world_service.clock import Clock

if TYPE_CHECKING:
    from world_service.camera.photos import PhotoJob


@runtime_checkable
class ServedWorld(Protocol):
    RENDERS_PHOTOS: ClassVar[bool]
    """The service starts a camera process to render the world's photo jobs."""
    RESUMABLE: ClassVar[bool]
    """The service saves the world's state for a restart to resume."""
    INPUT_TOPICS: ClassVar[tuple[str, ...]]
    """Rover topics the world takes from the agents."""

    scenario: Scenario
    keys: ks.Keyspace
    clock: Clock
    rejected: Rejections
    dropped_messages: int
    """Set by the service: samples its inbox dropped over its bound."""

    @classmethod
    def input_keys(cls, keys: ks.Keyspace) -> list[str]:
        """The key expressions the service subscribes to for this world."""
        ...

    @property
    def rover_ids(self) -> Collection[int]: ...

    @property
    def complete(self) -> bool: ...

    def receive(self, key: str, payload: bytes) -> list[Out]:
        """Handle one sample; a bad one is counted and answered with nothing, never raised."""
        ...

    def count_rejected(self, key: str, exc: Exception) -> None:
        """A sample the service refused for the world (a malformed ack), counted as the world's own refusals."""
        ...

    def set_alive(self, rover_id: int, alive: bool) -> None: ...

    def set_lander_alive(self, alive: bool) -> None:
        """The lander agent came or went: a mission whose rovers have finished ends without it in the end
        (``outcome.completion.LANDER_GONE_S``)."""
        ...

    def step(self) -> list[Out]:
        """Advance one tick; what to publish for it, the clock last."""
        ...

    def take_photo_jobs(self) -> list[PhotoJob]: ...

    def render(self, job: PhotoJob) -> m.Photo: ...

    def observed_state(self) -> m.WorldState:
        """The ground truth to publish, counted into the statistics."""
        ...

    def report(self) -> m.MissionReport: ...
