"""What the lander and the ground station publish: the lander's status and traverse map, the ground's commands and
their answers. Part of the wire contract; every payload is ``schemas.messages.X`` to its users."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from schemas.base import GoalKind, Message
from schemas.scenario_limits import Coordinate
from schemas.wire_limits import (
    MAX_CELL_M,
    MAX_MAP_BYTES,
    MAX_TARGETS,
    Count,
    GoalIndex,
    Label,
    RoverId,
    RoverIds,
    Seconds,
    Stamp,
    Text,
)


class LanderStatus(Message):
    stamp: Seconds
    phase: Literal["dispatch", "calibration", "migration", "observation", "complete"]
    rover_goals: dict[RoverId, GoalIndex] = Field(default_factory=dict, max_length=MAX_TARGETS,
                                                  description="rover id -> goal index")
    connected: RoverIds = Field(default_factory=list)
    relay_chain: RoverIds = Field(default_factory=list)
    rejected: Count = Field(0, description="samples the lander has rejected since it started")
    map_lost: bool = Field(False, description="the lander joined this run under way without a saved state of it: "
                           "its plan and traverse map began again")


class LanderMap(Message):
    """The lander's traverse map (``lander_agent.mapping``): one class code per cell, for viewers and the recorder.

    Cell (row j, column i) covers [origin_x + i * cell_m, + cell_m) x [origin_z + j * cell_m, + cell_m), in map
    (scenario) coordinates. ``cells`` is the zlib-compressed uint8 array, ``height`` rows of ``width``, row
    order z; ``classes`` names each code.
    """

    stamp: Seconds
    cell_m: float = Field(gt=0, le=MAX_CELL_M)
    origin_x: Coordinate
    origin_z: Coordinate
    width: int = Field(ge=1, le=MAX_MAP_BYTES)
    height: int = Field(ge=1, le=MAX_MAP_BYTES)
    classes: list[Label] = Field(max_length=256)
    cells: bytes = Field(max_length=MAX_MAP_BYTES)

    @model_validator(mode="after")
    def _bounded_grid(self) -> LanderMap:
        if self.width * self.height > MAX_MAP_BYTES:
            raise ValueError(f"a {self.width} x {self.height} grid is more than {MAX_MAP_BYTES:,} cells")
        return self


MISSION_COMMANDS = ("set_target", "stop", "return")
"""Carried out by the lander (needs N5, N6)."""
RECORDER_COMMANDS = ("snapshot",)
"""Carried out by a recorder in snapshot mode: write the last N seconds."""
PLAYBACK_COMMANDS = ("pause", "resume", "step", "seek")
"""Carried out by a replay: ``step`` publishes the next sample, ``seek`` jumps to ``seconds`` in."""


class GroundCommand(Message):
    """From the ground station. Mission commands go to the lander; targets are in map (scenario) coordinates.

    Each process carries out the commands that are its own and ignores the rest.
    """

    request_id: Label = ""
    command: Literal["set_target", "stop", "return", "snapshot", "pause", "resume", "step", "seek"]
    rover_id: RoverId | None = Field(None, description="None: every rover (set_target only)")
    x: Coordinate | None = Field(None, description="set_target: the target in map coordinates, m")
    z: Coordinate | None = None
    kind: GoalKind = "waypoint"
    seconds: Stamp | None = Field(None, description="seek: seconds from the start of the recording")


class CommandResult(Message):
    request_id: Label
    accepted: bool
    detail: Text = ""
