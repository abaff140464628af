"""What the lander and the ground station publish: the lander's status and traverse map, the ground's commands and
their answers. Part of the wire contract; every payload is ``schemas.messages.X`` to its users."""

from __future__ import annotations

from typing import Annotated, Literal

from msgspec import Meta, field

from schemas.base import GoalKind, Message
from schemas.wire_limits import (
    MAX_CELL_M,
    MAX_MAP_BYTES,
    MAX_TARGETS,
    Coordinate,
    Count,
    GoalIndex,
    Label,
    RoverId,
    RoverIds,
    Seconds,
    Stamp,
    Text,
)


class LanderStatus(Message, kw_only=True):
    stamp: Seconds
    phase: Literal["dispatch", "calibration", "migration", "observation", "complete"]
    rover_goals: Annotated[dict[RoverId, GoalIndex], Meta(max_length=MAX_TARGETS,
                                                          description="rover id -> goal index")] = field(
        default_factory=dict)
    connected: RoverIds = field(default_factory=list)
    relay_chain: RoverIds = field(default_factory=list)
    rejected: Annotated[Count, Meta(description="samples the lander has rejected since it started")] = 0
    map_lost: Annotated[bool, Meta(description="the lander joined this run under way without a saved state of it: "
                                   "its plan and traverse map began again")] = False


class LanderMap(Message, kw_only=True):
    """The lander's traverse map (``lander_agent.mapping``): one class code per cell, for viewers and the recorder.

    Cell (row j, column i) covers [origin_x + i * cell_m, + cell_m) x [origin_z + j * cell_m, + cell_m), in map
    (scenario) coordinates. ``cells`` is the zlib-compressed uint8 array, ``height`` rows of ``width``, row
    order z; ``classes`` names each code.
    """

    stamp: Seconds
    cell_m: Annotated[float, Meta(gt=0, le=MAX_CELL_M)]
    origin_x: Coordinate
    origin_z: Coordinate
    width: Annotated[int, Meta(ge=1, le=MAX_MAP_BYTES)]
    height: Annotated[int, Meta(ge=1, le=MAX_MAP_BYTES)]
    classes: Annotated[list[Label], Meta(max_length=256)]
    cells: Annotated[bytes, Meta(max_length=MAX_MAP_BYTES)]

    def __post_init__(self) -> None:
        if self.width * self.height > MAX_MAP_BYTES:
            raise ValueError(f"a {self.width} x {self.height} grid is more than {MAX_MAP_BYTES:,} cells")


MISSION_COMMANDS = ("set_target", "stop", "return")
"""Carried out by the lander (needs N5, N6)."""
RECORDER_COMMANDS = ("snapshot",)
"""Carried out by a recorder in snapshot mode: write the last N seconds."""
PLAYBACK_COMMANDS = ("pause", "resume", "step", "seek")
"""Carried out by a replay: ``step`` publishes the next sample, ``seek`` jumps to ``seconds`` in."""


class GroundCommand(Message, kw_only=True):
    """From the ground station. Mission commands go to the lander; targets are in map (scenario) coordinates.

    Each process carries out the commands that are its own and ignores the rest.
    """

    request_id: Label = ""
    command: Literal["set_target", "stop", "return", "snapshot", "pause", "resume", "step", "seek"]
    rover_id: Annotated[RoverId | None, Meta(description="None: every rover (set_target only)")] = None
    x: Annotated[Coordinate | None, Meta(description="set_target: the target in map coordinates, m")] = None
    z: Coordinate | None = None
    kind: GoalKind = "waypoint"
    seconds: Annotated[Stamp | None, Meta(description="seek: seconds from the start of the recording")] = None


class CommandResult(Message, kw_only=True):
    request_id: Label
    accepted: bool
    detail: Text = ""
