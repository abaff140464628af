"""The lander's map of the traverse (report 3.4.4: "the path between location A and location B is mapped").

An occupancy grid folded from the rovers' MapReports (``rover_agent.map_report``): what each rover perceived,
placed with its own dead-reckoned pose, so the map carries the rovers' odometry errors as a real one would.
The lander knows the scenario's plan (where it stands, where the rovers start, the goals and the craters it
was sent to), never the ground truth: rocks and walls reach this map only through the rovers' perception.

Classes (``CLASSES``, the code is the index):
- ``unknown``: no rover reported the cell;
- ``free``: explored ground: a rover stood there, or a ray crossed it before meeting anything;
- ``obstacle``: a rock, a wall or the lander was seen there;
- ``crater``: crater terrain (the rim of a crater seen from outside) or ground too steep to climb;
- ``rover``: where a rover last said it was (drawn over the rest).
A cell reported as several kinds takes the strongest: obstacle, then crater, then free.

The grid has ``mapping.cell_m`` cells (1 m by default) in map (scenario) coordinates. It covers the plan's
bounding box (lander, rover starts, goals, craters' outer rims) plus ``MARGIN_M``, and its cells line up
with the cells rovers count from the lander. Points outside are counted in ``cells_outside`` and dropped.
"""

from __future__ import annotations

import math
import os
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from lander_agent.map_legend import with_legend
from schemas import messages as m
from schemas import radio
from schemas.scenario import Scenario
from schemas.scenario_limits import MAP_MARGIN_M
from shared import png

CLASSES = ("unknown", "free", "obstacle", "crater", "rover")
UNKNOWN, FREE, OBSTACLE, CRATER, ROVER = range(len(CLASSES))
CLASS_OF_KIND = np.array([CLASSES.index(k) for k in radio.MAP_KINDS], np.uint8)
"""Grid class of each MapReport kind code."""
PRECEDENCE = (FREE, CRATER, OBSTACLE)
"""Weakest first: a later class overwrites an earlier one in the same cell."""
COLOURS = np.array([[40, 40, 40], [200, 200, 190], [220, 40, 30], [90, 110, 200], [40, 200, 60]], np.uint8)
"""PNG colour per class: unknown dark grey, free light grey, obstacle red, crater blue, rover green."""
MARGIN_M = MAP_MARGIN_M
PNG_MIN_SIDE_PX = 600
"""Cells are drawn as squares of several pixels until the picture's longer side reaches this."""
FOLDED_KEPT = 4096
"""Sequence numbers of one rover's folded reports the map remembers, to skip resends: a bound, so a sender of
endless new numbers costs the lander no memory."""
NPZ_FILE, PNG_FILE = "map.npz", "map.png"


@dataclass(frozen=True)
class GridSpec:
    """Cell (row j, column i) covers [origin_x + i * cell_m, ...) x [origin_z + j * cell_m, ...)."""

    origin_x: float
    origin_z: float
    cell_m: float
    width: int
    height: int

    @classmethod
    def for_scenario(cls, scenario: Scenario, cell_m: float, margin_m: float = MARGIN_M) -> GridSpec:
        lx, lz = scenario.lander.x, scenario.lander.z
        xs = [lx] + [r.x for r in scenario.rovers] + [g.x for g in scenario.mission]
        zs = [lz] + [r.z for r in scenario.rovers] + [g.z for g in scenario.mission]
        for c in scenario.craters:
            xs += [c.x - c.outer_radius, c.x + c.outer_radius]
            zs += [c.z - c.outer_radius, c.z + c.outer_radius]
        i0, i1 = math.floor((min(xs) - margin_m - lx) / cell_m), math.ceil((max(xs) + margin_m - lx) / cell_m)
        j0, j1 = math.floor((min(zs) - margin_m - lz) / cell_m), math.ceil((max(zs) + margin_m - lz) / cell_m)
        return cls(lx + i0 * cell_m, lz + j0 * cell_m, cell_m, i1 - i0, j1 - j0)

    @property
    def shape(self) -> tuple[int, int]:
        return self.height, self.width

    def index(self, x: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(column, row, inside) of map points."""
        i = np.floor((np.asarray(x, float) - self.origin_x) / self.cell_m).astype(int)
        j = np.floor((np.asarray(z, float) - self.origin_z) / self.cell_m).astype(int)
        return i, j, (i >= 0) & (i < self.width) & (j >= 0) & (j < self.height)

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """Cell-centre coordinates: x per column, z per row."""
        return (self.origin_x + (np.arange(self.width) + 0.5) * self.cell_m,
                self.origin_z + (np.arange(self.height) + 0.5) * self.cell_m)


class TraverseMap:
    def __init__(self, spec: GridSpec, lander_xz: tuple[float, float]) -> None:
        self.spec = spec
        self.lander_xz = lander_xz
        self.seen = np.zeros((len(CLASSES), *spec.shape), bool)
        self.rovers: dict[int, tuple[int, float, float]] = {}  # id -> (seq, x, z) of its newest report
        self.folded: dict[int, set[int]] = {}  # rover -> seqs folded lately (``FOLDED_KEPT`` at most)
        self.cells_outside = 0

    @classmethod
    def for_scenario(cls, scenario: Scenario) -> TraverseMap:
        spec = GridSpec.for_scenario(scenario, scenario.rover_params.mapping.cell_m)
        return cls(spec, (scenario.lander.x, scenario.lander.z))

    def fold(self, rover_id: int, report: radio.MapReport) -> bool:
        """Add a rover's report (lander frame); False when it was folded before (a resend whose ack was lost)."""
        folded = self.folded.setdefault(rover_id, set())
        if report.seq in folded:
            return False
        if len(folded) >= FOLDED_KEPT:  # folding is idempotent: forgetting only costs a resend's work
            folded.clear()
        folded.add(report.seq)
        cells = np.frombuffer(report.cells, "<i2").reshape(-1, 2).astype(float)
        kinds = CLASS_OF_KIND[np.frombuffer(report.kinds, np.uint8)]
        x = self.lander_xz[0] + (cells[:, 0] + 0.5) * report.cell_m
        z = self.lander_xz[1] + (cells[:, 1] + 0.5) * report.cell_m
        i, j, inside = self.spec.index(x, z)
        self.cells_outside += int((~inside).sum())
        self.seen[kinds[inside], j[inside], i[inside]] = True
        if report.seq >= self.rovers.get(rover_id, (-1, 0.0, 0.0))[0]:
            self.rovers[rover_id] = (report.seq, self.lander_xz[0] + report.x, self.lander_xz[1] + report.z)
        return True

    def classes(self) -> np.ndarray:
        """The class code of every cell, (height, width) uint8."""
        out = np.zeros(self.spec.shape, np.uint8)
        for code in PRECEDENCE:
            out[self.seen[code]] = code
        _, x, z = zip(*self.rovers.values(), strict=True) if self.rovers else ((), (), ())
        i, j, inside = self.spec.index(np.array(x), np.array(z))
        out[j[inside], i[inside]] = ROVER
        return out

    def to_message(self, stamp: float) -> m.LanderMap:
        s = self.spec
        return m.LanderMap(stamp=stamp, cell_m=s.cell_m, origin_x=s.origin_x, origin_z=s.origin_z, width=s.width,
                           height=s.height, classes=list(CLASSES), cells=zlib.compress(self.classes().tobytes(), 6))

    def save(self, folder: Path) -> None:
        """Write ``map.npz`` and ``map.png`` into ``folder``, each replacing the last one at once."""
        save(folder, self.spec, self.classes())


def from_message(msg: m.LanderMap) -> tuple[GridSpec, np.ndarray]:
    """The grid and class codes a LanderMap carries; a payload that does not fit its shape is a ValueError."""
    try:  # unpacked no further than the grid needs: a small sample must not expand to gigabytes
        raw = zlib.decompressobj().decompress(msg.cells, msg.width * msg.height + 1)
    except zlib.error as exc:
        raise ValueError(f"lander map: cells are not zlib data ({exc})") from None
    if len(raw) != msg.width * msg.height:
        raise ValueError(f"lander map: {len(raw)} cells for a {msg.width} x {msg.height} grid")
    spec = GridSpec(msg.origin_x, msg.origin_z, msg.cell_m, msg.width, msg.height)
    return spec, np.frombuffer(raw, np.uint8).reshape(spec.shape)


def save(folder: Path, spec: GridSpec, classes: np.ndarray) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    tmp = folder / "map.tmp.npz"
    np.savez_compressed(tmp, classes=classes, cell_m=spec.cell_m, origin=np.array([spec.origin_x, spec.origin_z]),
                        class_names=np.array(CLASSES))
    os.replace(tmp, folder / NPZ_FILE)
    tmp = folder / "map.tmp.png"
    tmp.write_bytes(render_png(classes))
    os.replace(tmp, folder / PNG_FILE)


def load(path: Path) -> tuple[GridSpec, np.ndarray]:
    """Read a ``map.npz``; a file that is not one is a ValueError naming it."""
    try:
        with np.load(path) as data:
            classes, cell_m, origin = data["classes"], float(data["cell_m"]), data["origin"]
            names = tuple(str(n) for n in data["class_names"])
    except (OSError, KeyError, ValueError) as exc:
        raise ValueError(f"{path}: not a LunarSim map ({exc})") from None
    if names != CLASSES or classes.ndim != 2:
        raise ValueError(f"{path}: classes {names} / shape {classes.shape} are not this version's map")
    h, w = classes.shape
    return GridSpec(float(origin[0]), float(origin[1]), cell_m, w, h), classes


def render_png(classes: np.ndarray) -> bytes:
    """The map as a PNG, +z up (north up, as the session plots draw it), each cell a square of pixels."""
    scale = max(1, PNG_MIN_SIDE_PX // max(classes.shape))
    rgb = with_legend(COLOURS[np.flipud(classes)].repeat(scale, axis=0).repeat(scale, axis=1), CLASSES, COLOURS)
    return png.encode(rgb.shape[1], rgb.shape[0], rgb.tobytes(), channels=3)
