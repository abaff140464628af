"""Application messages carried inside radio payloads (rover <-> lander, rover <-> rover).

The radio itself moves opaque bytes (report 10.4.3); these payloads say what they are with a tag,
so a receiver can tell a goal report from anything else and reject what it does not know.
"""

from __future__ import annotations

import math
import struct
from typing import Annotated, Literal

import msgspec
from msgspec import Meta

from schemas import codec
from schemas.messages import Message
from schemas.wire_limits import (
    COV_ROUNDING_M2,
    MAX_ACKED_SEQS,
    MAX_CELL_M,
    MAX_LABELS,
    MAX_MAP_REPORT_CELLS,
    MAX_PNG_BYTES,
    MAX_VARIANCE_M2,
    Coordinate,
    Count,
    GoalIndex,
    Label,
    Seconds,
    Stamp,
)


class GoalReport(Message, kw_only=True):
    """A rover tells the lander it finished (or gave up on) a goal, so the lander sends the next one."""

    goal_index: GoalIndex
    outcome: Literal["reached", "stuck", "relay"]
    photos_pending: Annotated[Count, Meta(description="its crater photos not yet acknowledged: a daisy chain "
                                          "stands until they are in")] = 0


class PhotoReport(Message, kw_only=True):
    """A crater photo on its way to the lander; the rover holds it until a PhotoAck comes back."""

    goal_index: GoalIndex
    label: Label
    stamp: Seconds
    png: Annotated[bytes, Meta(max_length=MAX_PNG_BYTES)]


class PhotoAck(Message, kw_only=True):
    """The lander archived these photos (by label): the rover may forget them."""

    labels: Annotated[list[Label], Meta(max_length=MAX_LABELS)]


class CraterFound(Message, kw_only=True):
    """Told to the rovers in range when a rover stands on the rim of the crater of a goal (report 6.4)."""

    goal_index: GoalIndex


class MapReport(Message, kw_only=True):
    """Map cells a rover perceived, in the lander's frame (lander at the origin, the map's axes), for the
    lander's traverse map (``lander_agent.mapping``). The rover holds it until a MapAck names its ``seq``.

    ``cells`` packs little-endian int16 pairs (ix, iz): the cell [ix, ix + 1) x [iz, iz + 1) in units of
    ``cell_m``; ``kinds`` has one byte per cell (``MAP_KINDS``). ``x``, ``z``: the rover's dead-reckoned
    position when it built the report.
    """

    seq: Count
    cell_m: Annotated[float, Meta(gt=0, le=MAX_CELL_M)]
    x: Coordinate
    z: Coordinate
    cells: Annotated[bytes, Meta(max_length=4 * MAX_MAP_REPORT_CELLS)]
    kinds: Annotated[bytes, Meta(max_length=MAX_MAP_REPORT_CELLS)]

    def __post_init__(self) -> None:
        if len(self.cells) != 4 * len(self.kinds):
            raise ValueError(f"cells holds {len(self.cells)} bytes for {len(self.kinds)} kinds (4 bytes a cell)")
        if any(k >= len(MAP_KINDS) for k in self.kinds):
            raise ValueError(f"kinds: a code outside 0..{len(MAP_KINDS) - 1}")

    @classmethod
    def build(cls, seq: int, cell_m: float, x: float, z: float, cells: list[tuple[int, int, int]]) -> MapReport:
        """From (ix, iz, kind) cells; indices must fit int16."""
        flat = [v for ix, iz, _ in cells for v in (ix, iz)]
        return cls(seq=seq, cell_m=cell_m, x=round(x, 3), z=round(z, 3), cells=struct.pack(f"<{len(flat)}h", *flat),
                   kinds=bytes(k for _, _, k in cells))

    def cell_list(self) -> list[tuple[int, int, int]]:
        """The (ix, iz, kind) cells, in this report's cell size."""
        flat = struct.unpack(f"<{len(self.kinds) * 2}h", self.cells)
        return [(flat[2 * i], flat[2 * i + 1], k) for i, k in enumerate(self.kinds)]


MAP_KINDS = ("free", "obstacle", "crater")
"""What a MapReport cell can be: seen free (on the rover's track or along a ray), an obstacle (a rock, a wall,
the lander), or crater terrain (crater ground or ground too steep to climb)."""


class MapAck(Message, kw_only=True):
    """The lander folded these map reports (by ``seq``) into its map: the rover may forget them."""

    seqs: Annotated[list[Count], Meta(max_length=MAX_ACKED_SEQS)]


class StationRequest(Message, kw_only=True):
    """A rover near a waypoint or crater its team shares asks the lander for its station there (need N7).

    Stations go out in the order rovers ask, each on the asking rover's side: at a waypoint from the inside of
    the formation out, on a crater's crest outwards from where the rover comes, so no rover has to squeeze
    between others already standing (``lander_agent.stations``). ``x``, ``z``:
    the rover's dead-reckoned position in the lander's frame.
    """

    goal_index: GoalIndex
    x: Coordinate
    z: Coordinate




class PoseEstimate(Message, kw_only=True):
    """A rover's estimate of its own place, for the rovers in range that may see it (report 7.2.2: rovers exchange
    position estimates). Lander frame; ``cov_*``: its covariance, square metres; ``stamp``: when it held (simulated
    seconds); ``moving``: the rover was walking then, or may have set off since, so it may be elsewhere by now
(``rover_agent.estimation.sightings``)."""

    stamp: Stamp
    x: Coordinate
    z: Coordinate
    cov_xx: Annotated[float, Meta(ge=0, le=MAX_VARIANCE_M2)]
    cov_xz: Annotated[float, Meta(ge=-MAX_VARIANCE_M2, le=MAX_VARIANCE_M2)]
    cov_zz: Annotated[float, Meta(ge=0, le=MAX_VARIANCE_M2)]
    moving: bool = False

    def __post_init__(self) -> None:
        """Positive semi-definite, give or take the sender's rounding of each entry: a receiver fuses it as the
        noise of a sighting, and one that is not a covariance turns the receiver's own variances negative."""
        bound = math.sqrt((self.cov_xx + COV_ROUNDING_M2) * (self.cov_zz + COV_ROUNDING_M2)) + COV_ROUNDING_M2
        if abs(self.cov_xz) > bound:
            raise ValueError(f"cov_xz {self.cov_xz} makes no covariance with cov_xx {self.cov_xx} and cov_zz "
                             f"{self.cov_zz}")


class StopCommand(Message, kw_only=True):
    """The lander tells a rover to stop where it is until it is given a new goal (need N6)."""


RADIO_TYPES: dict[str, type[Message]] = {"goal_report": GoalReport, "photo_report": PhotoReport, "photo_ack": PhotoAck,
                                         "crater_found": CraterFound, "stop_command": StopCommand,
                                         "map_report": MapReport, "map_ack": MapAck,
                                         "station_request": StationRequest, "pose_estimate": PoseEstimate}
_TAGS = {model: tag for tag, model in RADIO_TYPES.items()}


def pack(message: Message) -> bytes:
    return msgspec.msgpack.encode((_TAGS[type(message)], codec.encode(message)))


def unpack(payload: bytes) -> Message:
    try:
        tag, body = msgspec.msgpack.decode(payload)
    except Exception as exc:  # not msgpack, or not a pair
        raise codec.DecodeError(f"radio payload: not a [tag, body] pair ({type(exc).__name__})") from None
    model = RADIO_TYPES.get(tag) if isinstance(tag, str) else None
    if model is None or not isinstance(body, bytes):
        raise codec.DecodeError(f"radio payload: unknown tag {tag!r}")
    return codec.decode(model, body)
