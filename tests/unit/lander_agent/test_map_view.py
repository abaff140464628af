"""The map a viewer gets: within its bound whatever the wire carries, each coarse cell its block's strongest class,
inflated a slice at a time."""

from __future__ import annotations

import tracemalloc
import zlib

import numpy as np
import pytest

from lander_agent import map_view, mapping
from schemas import messages as m

CODE_OF = {name: mapping.CLASSES.index(name) for name in mapping.CLASSES}


def _map(codes: np.ndarray, classes: list[str] | None = None, cells: bytes | None = None) -> m.LanderMap:
    return m.LanderMap(stamp=1.0, cell_m=0.5, origin_x=-3.0, origin_z=7.0, width=codes.shape[1], height=codes.shape[0],
                       classes=list(mapping.CLASSES) if classes is None else classes,
                       cells=zlib.compress(codes.tobytes()) if cells is None else cells)


def _codes(msg: m.LanderMap) -> np.ndarray:
    return np.frombuffer(zlib.decompress(msg.cells), np.uint8).reshape(msg.height, msg.width)


def _whole_grid_at_once(msg: m.LanderMap, k: int) -> np.ndarray:
    """The same coarsening done the plain way, the whole grid in memory: padded, reshaped, maximum of each block."""
    strength = [map_view.STRENGTH.index(n) if n in map_view.STRENGTH else 0 for n in msg.classes]
    strength = np.array(strength + [0] * (256 - len(strength)), np.uint8)[_codes(msg)]
    rows, columns = -(-msg.height // k), -(-msg.width // k)
    padded = np.zeros((rows * k, columns * k), np.uint8)
    padded[:msg.height, :msg.width] = strength
    strongest = padded.reshape(rows, k, columns, k).max(axis=(1, 3))
    return np.array([CODE_OF[n] for n in map_view.STRENGTH], np.uint8)[strongest]


def test_a_map_within_the_bound_is_passed_on_as_it_is():
    msg = _map(np.ones((3, 4), np.uint8))
    assert map_view.for_viewers(msg, max_cells=12) is msg


def test_a_coarse_cell_takes_the_strongest_class_of_its_block():
    u, f, o, c, r = (CODE_OF[n] for n in ("unknown", "free", "obstacle", "crater", "rover"))
    codes = np.array([[f, o, c, f, u],
                      [c, f, u, u, f],
                      [r, o, f, c, u],
                      [u, u, u, u, u]], np.uint8)
    coarse = map_view.for_viewers(_map(codes), max_cells=6)  # 2 x 2 blocks: 2 rows of 3
    assert (coarse.width, coarse.height, coarse.cell_m) == (3, 2, 1.0)
    assert (coarse.origin_x, coarse.origin_z, coarse.classes) == (-3.0, 7.0, list(mapping.CLASSES))
    assert _codes(coarse).tolist() == [[o, c, f], [r, c, u]]


def test_coarsening_a_slice_at_a_time_matches_the_whole_grid_at_once(monkeypatch):
    """Any shape, bound and slice length (rows cut anywhere by the inflater); classes in another order, and codes
    without a name or with a name this version does not know, which count as unknown."""
    rng = np.random.default_rng(7)
    for case in range(300):
        height, width = (int(n) for n in rng.integers(1, 50, 2))
        codes = (rng.integers(0, 7, (height, width)) * (rng.random((height, width)) < rng.random())).astype(np.uint8)
        classes = list(mapping.CLASSES) if case % 2 else ["free", "unknown", "rover", "obstacle", "moss"]
        msg = _map(codes, classes)
        bound = int(rng.integers(1, max(2, width * height)))
        monkeypatch.setattr(map_view, "SLICE_BYTES", int(rng.integers(1, 3 * width + 2)))
        coarse = map_view.for_viewers(msg, max_cells=bound)
        k = map_view.block_side(width, height, bound)
        assert coarse.width * coarse.height <= bound and coarse.cell_m == msg.cell_m * k
        np.testing.assert_array_equal(_codes(coarse), _whole_grid_at_once(msg, k), err_msg=f"case {case}")


def test_the_block_is_the_least_that_fits():
    def fits(width: int, height: int, k: int, bound: int, side: int | None) -> bool:
        columns, rows = -(-width // k), -(-height // k)
        return columns * rows <= bound and (side is None or max(columns, rows) <= side)

    for width, height, bound, side in [(10, 10, 25, None), (1, 2**30, 2**22, None), (2**15, 2**15, 2**22, None),
                                       (7, 3, 1, None), (99, 1, 10, None), (40_000, 60, 2**22, 4096),
                                       (60, 40_000, 2**22, 4096), (5000, 5000, 2**22, 4096), (10, 10, 100, 3)]:
        k = map_view.block_side(width, height, bound, side)
        assert fits(width, height, k, bound, side) and (k == 1 or not fits(width, height, k - 1, bound, side))


def test_the_page_gets_a_long_traverse_within_a_texture_side():
    """40 km by 60 m at 1 m cells: within the viewers' cells, but no browser draws a texture 40,000 texels wide."""
    codes = np.full((60, 40_000), CODE_OF["free"], np.uint8)
    assert map_view.for_viewers(_map(codes)).width == 40_000  # Foxglove and ROS 2 get it whole
    page = map_view.for_viewers(_map(codes), max_side=map_view.PAGE_SIDE)
    assert (page.width, page.height, page.cell_m) == (4000, 6, 5.0)


@pytest.mark.parametrize(("cells", "message"), [
    (zlib.compress(bytes(99)), "99 cells for a grid of 100"),
    (zlib.compress(bytes(101)), "more than 100 cells"),
    (b"not zlib at all", "not zlib data"),
])
def test_a_payload_that_does_not_fit_its_shape_is_refused(monkeypatch, cells: bytes, message: str):
    monkeypatch.setattr(map_view, "SLICE_BYTES", 7)
    with pytest.raises(ValueError, match=message):
        map_view.for_viewers(_map(np.zeros((10, 10), np.uint8), cells=cells), max_cells=9)


def test_a_map_of_a_quarter_billion_cells_is_coarsened_in_a_few_megabytes():
    """A zlib megabyte that unpacks to 2**28 cells (a valid sample; the wire allows four times as many)."""
    side = 1 << 14
    inflater = zlib.compressobj(6)
    row = np.tile(np.array([CODE_OF["free"], CODE_OF["obstacle"]], np.uint8), side // 2).tobytes()
    cells = b"".join([inflater.compress(row) for _ in range(side)] + [inflater.flush()])
    msg = m.LanderMap(stamp=1.0, cell_m=1.0, origin_x=0.0, origin_z=0.0, width=side, height=side,
                      classes=list(mapping.CLASSES), cells=cells)
    tracemalloc.start()
    try:
        coarse = map_view.for_viewers(msg)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert (coarse.width, coarse.height, coarse.cell_m) == (2048, 2048, 8.0)
    assert (_codes(coarse) == CODE_OF["obstacle"]).all()
    assert peak < 64 * 2**20, f"{peak / 2**20:.0f} MiB"
