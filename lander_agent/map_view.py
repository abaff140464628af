"""The lander's map as a viewer gets it: no more than ``VIEW_CELLS`` cells, whatever the map on the wire holds.

A ``LanderMap`` may carry up to 2**30 cells in about a megabyte of zlib (a legitimate map of a large traverse, or
a forged sample), and each viewer widens its cells several times over (the Foxglove grid takes five bytes a cell
and the SDK copies them; the web page inflates them in the browser). Past the bound the map is coarsened:
blocks of k x k cells become one cell k times as wide, of the block's strongest class (``STRENGTH``), so an
obstacle, a crater rim or a rover in a block stays on the picture. The payload is inflated a slice at a time, so
coarsening holds a few megabytes however large the map. The lander's own statistics, ``map.npz`` and the replay
report's scoring keep the full map (``mapping.from_message``).
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Iterator

import msgspec
import numpy as np

from lander_agent.mapping import CLASSES
from schemas import messages as m

VIEW_CELLS = 1 << 22
"""Cells of a map a viewer is sent (2,048 x 2,048): a 4 km square traverse at the default 1 m cells."""
PAGE_SIDE = 4096
"""Cells a side of the map the web page draws: it is one WebGL texture, and browsers' WebGL gives 4,096 texels a
side on nearly every device (a long traverse's map can be far longer than that and still within ``VIEW_CELLS``)."""
STRENGTH = ("unknown", "free", "crater", "obstacle", "rover")
"""Weakest first: the class a coarse cell takes is the strongest of its block's. A code the map does not name, or
names with a class this version does not know, counts as unknown."""
SLICE_BYTES = 1 << 22
"""Cells inflated at once while coarsening."""


def for_viewers(msg: m.LanderMap, max_cells: int = VIEW_CELLS, max_side: int | None = None) -> m.LanderMap:
    """``msg`` itself if it fits ``max_cells`` (and ``max_side`` cells a side), else the map coarsened to fit; a
    payload that does not fit its shape is a ValueError (as ``mapping.from_message`` raises)."""
    k = block_side(msg.width, msg.height, max_cells, max_side)
    if k == 1:
        return msg
    strength = _strength_of_codes(msg.classes)
    coarse = _strongest_per_block(_inflated(msg.cells, msg.width * msg.height), msg.width, msg.height, k, strength)
    codes = np.array([CLASSES.index(name) for name in STRENGTH], np.uint8)[coarse]
    return msgspec.structs.replace(msg, cell_m=msg.cell_m * k, width=coarse.shape[1], height=coarse.shape[0],
                                   classes=list(CLASSES), cells=zlib.compress(codes.tobytes(), 6))


def block_side(width: int, height: int, max_cells: int, max_side: int | None = None) -> int:
    """The least k whose k x k blocks cover the grid in at most ``max_cells`` cells, ``max_side`` a side."""
    k = max(1, math.isqrt(width * height // max_cells))
    if max_side is not None:
        k = max(k, -(-width // max_side), -(-height // max_side))
    while -(-width // k) * -(-height // k) > max_cells:
        k += 1
    return k


def _strength_of_codes(classes: list[str]) -> np.ndarray:
    table = np.zeros(256, np.uint8)
    for code, name in enumerate(classes[:256]):
        table[code] = STRENGTH.index(name) if name in STRENGTH else 0
    return table


def _inflated(cells: bytes, size: int) -> Iterator[bytes]:
    """The payload's ``size`` bytes, a slice at a time; fewer or more than ``size`` is a ValueError."""
    inflater = zlib.decompressobj()
    left, pending = size, cells
    try:
        while left:
            part = inflater.decompress(pending, min(left, SLICE_BYTES))
            pending = inflater.unconsumed_tail
            if not part:
                raise ValueError(f"lander map: {size - left} cells for a grid of {size}")
            left -= len(part)
            yield part
        extra = inflater.decompress(pending, 1)
    except zlib.error as exc:
        raise ValueError(f"lander map: cells are not zlib data ({exc})") from None
    if extra:
        raise ValueError(f"lander map: more than {size} cells for a grid of {size}")


def _strongest_per_block(parts: Iterator[bytes], width: int, height: int, k: int,
                         strength: np.ndarray) -> np.ndarray:
    """Strength (index into ``STRENGTH``) of the strongest cell of each k x k block, (rows, columns) uint8.

    The cells come in row order, in slices of any length: a slice's whole rows fold together, the pieces of a row
    at either end of it one by one."""
    out = np.zeros((-(-height // k), -(-width // k)), np.uint8)
    position = 0
    for part in parts:
        values = strength[np.frombuffer(part, np.uint8)]
        head = values[:(width - position % width) % width]
        whole = (len(values) - len(head)) // width * width
        _fold_run(out, head, position, width, k)
        if whole:
            _fold_rows(out, values[len(head):len(head) + whole].reshape(-1, width), (position + len(head)) // width, k)
        _fold_run(out, values[len(head) + whole:], position + len(head) + whole, width, k)
        position += len(values)
    return out


def _fold_rows(out: np.ndarray, rows: np.ndarray, first: int, k: int) -> None:
    """Whole rows from row ``first`` on: the maximum of each band of k rows, then of each k columns of it."""
    lead = -first % k  # rows before the next band begins
    body = rows[lead:]
    whole = len(body) // k * k
    pieces = [rows[:lead].max(axis=0, keepdims=True)] if lead and len(rows) else []
    if whole:
        pieces.append(body[:whole].reshape(-1, k, rows.shape[1]).max(axis=1))
    if len(body) > whole:
        pieces.append(body[whole:].max(axis=0, keepdims=True))
    bands = np.concatenate(pieces)
    strongest = np.maximum.reduceat(bands, np.arange(0, rows.shape[1], k), axis=1)
    into = out[first // k:first // k + len(bands)]
    np.maximum(into, strongest, out=into)


def _fold_run(out: np.ndarray, run: np.ndarray, position: int, width: int, k: int) -> None:
    """Part of one row, its first cell at ``position`` of the grid."""
    if not len(run):
        return
    row, column = divmod(position, width)
    blocks = _block_starts(column, len(run), k)
    into = out[row // k, column // k:column // k + len(blocks)]
    np.maximum(into, np.maximum.reduceat(run, blocks), out=into)


def _block_starts(first: int, n: int, k: int) -> np.ndarray:
    """Where, in n cells from index ``first`` of the grid's rows or columns, each block of k begins (0 first)."""
    return np.unique(np.r_[0, np.arange(-first % k, n, k)])
