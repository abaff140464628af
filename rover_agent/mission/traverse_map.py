"""The rover's share of the traverse map: what it perceived, placed with its dead-reckoned pose, for the lander.

The lander maps the path between A and B (report 3.4.4) from these reports alone (``lander_agent.mapping``).
A rover folds in a scan only while it stands still with a known pose (after an action has settled, once per
pose), because its dead-reckoned pose is updated only when an action ends. Each ray of the scan says what
it met: the hit's cell gets the hit's kind, the cells before it (or up to the perception radius when the ray
met nothing) are seen free. Hits on rovers are left out (they move); the lander counts as an obstacle, steep
ground as crater terrain. The rover keeps one point per map cell and kind, so a report carries only what
is new, and holds every report until the lander acknowledges it, sending it again when it has radio
partners (store and forward, as with photos). Pure Python: no NumPy on a flight computer.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from schemas import radio
from schemas.params import RoverParams

FREE, OBSTACLE, CRATER = (radio.MAP_KINDS.index(k) for k in ("free", "obstacle", "crater"))
KIND_OF_HIT = {"obstacle": OBSTACLE, "lander": OBSTACLE, "terrain": CRATER, "crater_terrain": CRATER}
"""Map kind of each perception hit kind; 'rover' hits are not mapped."""
CELL_INDEX_LIMIT = 32767
"""Cells are sent as int16: points farther than this many cells from the lander are not reported."""

MappedCell = tuple[int, int, int]
"""A cell and what was seen in it: (ix, iz, kind)."""


class MapRecorder:
    def __init__(self, params: RoverParams) -> None:
        p = params.perception
        self.mapping = params.mapping
        self.cell = params.mapping.cell_m
        self.radius = p.perception_radius
        self.fov = p.field_of_view_degrees
        self.step_deg = p.ray_step_deg
        self.rays = [-self.fov / 2 + i * self.step_deg for i in range(p.perception_granularity)]
        self.known: set[MappedCell] = set()
        self._to_fold: tuple[float, float, float, tuple] | None = None
        self.pending: list[MappedCell] = []
        self.outbox: dict[int, radio.MapReport] = {}
        self.next_seq = 0
        self.last_pose: tuple[float, float, float] | None = None
        self.last_send = -math.inf

    def fold_later(self, x: float, z: float, heading_deg: float, hits: tuple) -> None:
        """Keep a scan to fold once the agent's answer is out (``catch_up``): folding is most of the handling of a
        perception, and no decision reads the map."""
        self._to_fold = (x, z, heading_deg, hits)

    def catch_up(self) -> None:
        """Fold the scan kept by ``fold_later``, if any; every sample's handling calls this first."""
        if self._to_fold is not None:
            scan, self._to_fold = self._to_fold, None
            self.fold_scan(*scan)

    def fold_scan(self, x: float, z: float, heading_deg: float, hits: Iterable) -> None:
        """Note what a scan from a standing rover at (x, z) facing ``heading_deg`` saw (hits: angle, distance,
        kind as ``decisions.Hit``). A second scan from the same pose adds nothing and is skipped."""
        if self.last_pose == (x, z, heading_deg):
            return
        self.last_pose = (x, z, heading_deg)
        self._add(x, z, FREE)
        reach = dict.fromkeys(range(len(self.rays)), (self.radius, None))
        for hit in hits:
            ray = round((hit.angle_deg + self.fov / 2) / self.step_deg)
            if 0 <= ray < len(self.rays) and (reach[ray][1] is None or hit.distance_m < reach[ray][0]):
                reach[ray] = (hit.distance_m, hit.kind)
        for ray, (distance, kind) in reach.items():
            dx, dz = math.sin(math.radians(heading_deg + self.rays[ray])), math.cos(math.radians(heading_deg
                                                                                                + self.rays[ray]))
            self._free_along(x, z, dx, dz, min(distance, self.radius))  # a forged hit may lie beyond sight
            if kind in KIND_OF_HIT:
                self._add(x + dx * distance, z + dz * distance, KIND_OF_HIT[kind])

    def _free_along(self, x: float, z: float, dx: float, dz: float, distance: float) -> None:
        """Cells a ray crossed before it met something: sampled every half cell, short of the hit's cell.

        ``_add`` inlined, and a sample in the same cell as the one before it skipped before its cell is even made
        a tuple: a scan walks about 20,000 samples, and this runs while the world waits for the rover's answer to
        its perception (in lockstep), or while a process of 250 agents falls behind (a quarter of its time)."""
        cell, known, pending, floor = self.cell, self.known, self.pending, math.floor
        s = step = cell / 2
        end = distance - cell / 2
        last_ix = last_iz = None
        while s < end:
            ix, iz = floor((x + dx * s) / cell), floor((z + dz * s) / cell)
            s += step
            if ix == last_ix and iz == last_iz:
                continue
            last_ix, last_iz = ix, iz
            point = (ix, iz, FREE)
            if point not in known and abs(ix) <= CELL_INDEX_LIMIT and abs(iz) <= CELL_INDEX_LIMIT:
                known.add(point)
                pending.append(point)

    def _add(self, x: float, z: float, kind: int) -> None:
        ix, iz = math.floor(x / self.cell), math.floor(z / self.cell)
        if max(abs(ix), abs(iz)) > CELL_INDEX_LIMIT or (ix, iz, kind) in self.known:
            return
        self.known.add((ix, iz, kind))
        self.pending.append((ix, iz, kind))

    def due(self, now: float, x: float, z: float, reachable: bool) -> list[radio.MapReport]:
        """Every ``report_period_s``: pack what is new into reports, and return the oldest unacknowledged
        ones to send (none while the rover has no radio partner: nothing could carry them)."""
        if now - self.last_send < self.mapping.report_period_s:
            return []
        self.last_send = now
        while self.pending:
            chunk, self.pending = (self.pending[:self.mapping.max_cells_per_report],
                                   self.pending[self.mapping.max_cells_per_report:])
            self.outbox[self.next_seq] = radio.MapReport.build(self.next_seq, self.cell, x, z, chunk)
            self.next_seq += 1
        if not reachable:
            return []
        return [self.outbox[seq] for seq in sorted(self.outbox)[:self.mapping.max_reports_per_send]]

    def next_due(self) -> float:
        """When ``due`` next sends: the agent's lockstep wake time counts it among its timers."""
        return self.last_send + self.mapping.report_period_s

    def ack(self, seqs: Iterable[int]) -> None:
        for seq in seqs:
            self.outbox.pop(seq, None)

