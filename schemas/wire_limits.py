"""The bounds of every field that travels between processes: what a receiver can hold, sum, index and show.

A sample is untrusted even from a process holding a valid certificate (a rover may be buggy or taken over), so a
well-formed value must still fit what the receiver does with it: an integer the codec can encode once summed over
every rover, a label that can be logged and shown, bytes that fit in memory a thousand rovers over. A value out of
these bounds fails the message model's validation, and the receiver counts it as any other rejected sample.

The bounds are msgspec ``Meta`` annotations, what the wire models (msgspec Structs) check on decoding; the pydantic
scenario models that hold a wire type take it through ``schemas.scenario_types``, which reads the same ``Meta``.

Bounds are generous, not physical, as in ``schemas.scenario_limits``: each only rules out what no mission uses.
"""

from __future__ import annotations

import sys
from typing import Annotated

from msgspec import Meta

from schemas.scenario_limits import COORDINATE_LIMIT_M, MAX_RATE_HZ, MAX_ROVERS

COUNT_LIMIT = 2**31 - 1
"""A counter a process reports (samples rejected, photos pending): summed over every rover and the lander, the total
stays far inside the codec's int64, and a sender saturates here rather than fail to encode."""
INDEX_LIMIT = 100_000
"""Goal indices and goal counts: far beyond any mission plan, small enough to index and to print."""
ACTION_ID_LIMIT = 2**63
"""Action ids travel as int64."""
ACTION_ID_STRIDE = 2**20
"""Action ids are ``base * ACTION_ID_STRIDE + n``, ``base`` the simulated millisecond of the agent's first action of
a life and ``n`` counting its actions from 1. So the world knows the highest id an agent can have taken by now, and
refuses an id from the future (``highest_action_id``) instead of letting it lock the rover's own ids out as stale."""
ACTION_ID_LEAD_S = 1.0
"""How far ahead of the world's clock an action id may be based: an agent's clock comes from the world's samples and
lags it; nothing legitimate leads it."""
MAX_ID = MAX_ROVERS
"""Rover ids are 1..MAX_ROVERS; 0 is the lander."""
MAX_TARGETS = MAX_ROVERS + 1
"""Ids one radio transmission, partner list or chain can name: every rover and the lander."""
MAX_RAYS = 4096
"""Hits in one perception scan: one per ray, and ``perception_granularity`` is at most 4096."""
MAX_TEXT = 200
"""A free-text field (a status detail, a refusal's reason): one log or table line."""
MAX_LABEL = 64
"""A photo label: a name to index and show, never a file name."""
MAX_LABELS = 4096
"""Labels in one PhotoAck."""
MAX_IMAGE_SIDE = 4096
"""Pixels along a photo's side: the camera's ``width`` and ``height`` are at most this."""
MAX_PNG_BYTES = MAX_IMAGE_SIDE * MAX_IMAGE_SIDE * 3 + 2**20
"""A photo of the largest camera, not compressed at all, and its PNG framing."""
MAX_RADIO_PAYLOAD = MAX_PNG_BYTES + 2**16
"""One radio transmission: a photo report is the largest thing a rover sends."""
MAX_MAP_REPORT_CELLS = 20_000
"""Cells in one MapReport: ``mapping.max_cells_per_report`` is at most this."""
MAX_MAP_BYTES = 2**30
"""One compressed LanderMap, and the cells it unpacks to (``lander_agent.mapping.from_message``)."""
MAX_CELL_M = 100.0
"""A map cell's side: ``mapping.cell_m`` is at most this."""
MAX_ACKED_SEQS = 4096
"""Sequence numbers in one MapAck."""
SECONDS_LIMIT = 1e9
"""Simulated seconds anywhere (stamps, seek positions, wake times): 31 years."""
ANGLE_LIMIT_DEG = 3600.0
"""A rotation or bearing in degrees: ten turns, more than any behaviour asks for in one action."""
DISTANCE_LIMIT_M = 4 * COORDINATE_LIMIT_M
"""A distance or relative offset: across the whole frame and back."""

MAX_VARIANCE_M2 = COORDINATE_LIMIT_M ** 2
"""A position variance (square metres): an estimate unsure by the whole frame carries nothing more."""
COV_ROUNDING_M2 = 5e-7
"""A sender rounds each covariance entry to 6 decimals (``rover_agent.estimation.estimator``): a receiver's check
that the entries make a covariance allows for it."""
MAX_HEADING_VARIANCE_RAD2 = 1e4
"""A heading variance (square radians): past a turn's square the heading is anything; the bound leaves room for a
long mission's rotations to add up without the estimate failing to travel."""

_NO_CONTROL = r"^[^\x00-\x1f\x7f]*$"
"""Printable text: no newline, escape or other control character that would forge a log line or a table row."""

Count = Annotated[int, Meta(ge=0, le=COUNT_LIMIT)]
Tally = Annotated[int, Meta(ge=0, le=2**63 - 1)]
"""A sum of counts (the world's counters over every rover): what int64 holds."""
GoalIndex = Annotated[int, Meta(ge=0, lt=INDEX_LIMIT)]
GoalCount = Annotated[int, Meta(ge=1, le=INDEX_LIMIT)]
RoverId = Annotated[int, Meta(ge=0, le=MAX_ID)]
ActionId = Annotated[int, Meta(ge=0, le=ACTION_ID_LIMIT - 1)]
Tick = Annotated[int, Meta(ge=0, le=2**63 - 1)]
Seconds = Annotated[float, Meta(ge=-SECONDS_LIMIT, le=SECONDS_LIMIT)]
Stamp = Annotated[float, Meta(ge=0, le=SECONDS_LIMIT)]
"""Simulated time since the start."""
Degrees = Annotated[float, Meta(ge=-ANGLE_LIMIT_DEG, le=ANGLE_LIMIT_DEG)]
Metres = Annotated[float, Meta(ge=-DISTANCE_LIMIT_M, le=DISTANCE_LIMIT_M)]
Distance = Annotated[float, Meta(ge=0, le=DISTANCE_LIMIT_M)]
Text = Annotated[str, Meta(max_length=MAX_TEXT, pattern=_NO_CONTROL)]
Label = Annotated[str, Meta(max_length=MAX_LABEL, pattern=_NO_CONTROL)]
RoverIds = Annotated[list[RoverId], Meta(max_length=MAX_TARGETS)]
Coordinate = Annotated[float, Meta(ge=-COORDINATE_LIMIT_M, le=COORDINATE_LIMIT_M)]
"""A position in the lander's or the map's frame, m."""
Rate = Annotated[float, Meta(gt=0, le=MAX_RATE_HZ)]
"""A sensor or status rate, Hz."""
FLOAT_MAX = sys.float_info.max


def finite(**meta: object) -> Meta:
    """A float's ``Meta`` with both sides bounded: msgspec has no switch for nan and inf, but a nan fails every
    bound and an inf a side bounded by ``FLOAT_MAX``, so a side the field leaves open gets that bound.
    ``schemas.scenario_types`` reads ``FLOAT_MAX`` as pydantic's ``allow_inf_nan=False``."""
    if "ge" not in meta and "gt" not in meta:
        meta["ge"] = -FLOAT_MAX
    if "le" not in meta and "lt" not in meta:
        meta["le"] = FLOAT_MAX
    return Meta(**meta)  # type: ignore[arg-type]


Finite = Annotated[float, finite()]
"""A float with no bound of its own: any finite value (a nan compares false with every check a receiver makes)."""


def saturate(count: int) -> int:
    """A sender's counter as it may travel: at most ``COUNT_LIMIT``."""
    return min(count, COUNT_LIMIT)


def highest_action_id(sim_time: float) -> int:
    """The highest action id an agent can have taken by ``sim_time``: its base is at most the current millisecond
    (plus ``ACTION_ID_LEAD_S``), and no agent takes ``ACTION_ID_STRIDE`` actions in one millisecond."""
    return min(ACTION_ID_LIMIT - 1, (int((sim_time + ACTION_ID_LEAD_S) * 1000) + 1) * ACTION_ID_STRIDE)
