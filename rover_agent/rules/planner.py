"""A shortest-path planner over the rover's memory of what it has seen (``occupancy``), to get out of dead ends.

Greedy avoidance (walk toward the goal, take the free direction nearest it) only knows the current view, so
in a maze of staggered baffles it walks back into the same dead end. Here the rover remembers the static
things it has seen in a sparse occupancy grid in its own frame (the lander frame of its dead-reckoned
``Pose`` and of its goals) and plans a shortest path through every cell not known to be blocked. Unknown
cells count as free (optimistic planning): rerunning the plan at every decision as walls get discovered does
what D* Lite does, only more simply. The search is A* made fast with jump points; it has an expansion
budget, and when the goal is out of reach the rover still gets the path that brings it nearest the goal.

Pure standard library: this runs on the rover's small flight computer.
"""

from __future__ import annotations

import bisect
import heapq
import itertools
import math
from collections.abc import Iterable, Sequence
from typing import TYPE_CHECKING

from rover_agent.rules.occupancy import TIE, Cell, OccupancyGrid, Point, disc_offsets, segment_clear

if TYPE_CHECKING:
    from shared.pose import Pose

SQRT2 = math.sqrt(2.0)
PLAN_REACH_CELLS = 4096
"""A plan goes at most this many cells towards its goal (``_within_reach``): 4 km at the default 1 m cells."""
_NEIGHBOURS = ((1, 0, 1.0), (-1, 0, 1.0), (0, 1, 1.0), (0, -1, 1.0),
               (1, 1, SQRT2), (1, -1, SQRT2), (-1, 1, SQRT2), (-1, -1, SQRT2))
_ALL_DIRECTIONS = tuple((di, dj) for di, dj, _ in _NEIGHBOURS)


def _forbidden(grid: OccupancyGrid, clearance_m: float, ends: Sequence[Cell],
               avoid: frozenset[Cell] = frozenset()) -> frozenset[Cell]:
    """Cells the rover's centre must not enter: too near a blocked cell, or in ``avoid`` (cells kept clear for
    this plan only, already inflated: rovers standing in the way).

    The ends (start, goal) are always allowed, and when one lies within the clearance so are the unblocked
    cells around it, so a rover standing near a wall can step away from it and a goal next to a rock can
    still be reached.
    """
    inflated = grid.inflated(clearance_m) | avoid
    allowed: set[Cell] = set()
    for ci, cj in ends:
        allowed.add((ci, cj))
        if (ci, cj) in inflated:
            allowed.update((ci + di, cj + dj) for di, dj in disc_offsets(clearance_m / grid.cell_m)
                           if not grid.blocked(ci + di, cj + dj))
    return inflated - allowed if allowed & inflated else inflated


def plan(grid: OccupancyGrid, start_xz: Point, goal_xz: Point, clearance_m: float,
         max_expansions: int = 20000, avoid: frozenset[Cell] = frozenset()) -> list[Point] | None:
    """Shortest 8-connected path from the start to the goal through cells clear of known obstacles.

    Returns the cell centres after the start up to the goal (the last point is the goal itself). When the
    goal is walled off, or the budget runs out first, returns the path to the cell nearest the goal that the
    search reached, so the rover still makes progress while it discovers more of the world; that path is
    empty when the start is already the nearest. None only when the start is walled in: the rover's region
    is finite (unknown counts as free, so the walls it has seen close it).
    """
    goal_xz = _within_reach(start_xz, goal_xz, PLAN_REACH_CELLS * grid.cell_m)
    start, goal = grid.cell_of(*start_xz), grid.cell_of(*goal_xz)
    goal_point = (float(goal_xz[0]), float(goal_xz[1]))
    if start == goal:
        return [goal_point]
    forbidden = _forbidden(grid, clearance_m, (start, goal), avoid)
    search = _JumpSearch(forbidden, start, goal)
    jumps = search.run(max_expansions)
    if jumps is not None:
        cells, reached = _interpolate(jumps), True
    else:  # no way to the goal, or no budget left: plain A* finds the best progress or proves the start walled in
        found = _astar(start, goal, forbidden, max_expansions, search.box)
        if found is None:
            return None
        cells, reached = found
    path = [grid.centre_of(i, j) for i, j in cells[1:]]
    if reached:
        path[-1] = goal_point
    return path


def _within_reach(start_xz: Point, goal_xz: Point, reach_m: float) -> Point:
    """The goal, or the point ``reach_m`` towards it when it lies farther: what the rover has seen spans a few
    hundred metres, and beyond it every cell is free, so the way there is straight; a goal a thousand
    kilometres off (a typing slip in a ground command) made each plan walk and fence a box that size (6.7 s and
    650 MB a decision)."""
    dx, dz = goal_xz[0] - start_xz[0], goal_xz[1] - start_xz[1]
    distance = math.hypot(dx, dz)
    if distance <= reach_m:
        return goal_xz
    f = reach_m / distance
    return start_xz[0] + f * dx, start_xz[1] + f * dz


def _box(forbidden: frozenset[Cell], start: Cell, goal: Cell) -> tuple[int, int, int, int]:
    """(lo_i, hi_i, lo_j, hi_j): the bounding box of the forbidden cells, start and goal, plus a free ring.

    The searches treat the cells just outside it as a fence. That loses no shortest path, since clamping a
    path's cells into the box never lengthens it (each coordinate only gets closer) and only moves them onto
    the free ring, and no nearest approach to the goal either. The ring is outside every wall, so a region
    that reaches it is not walled in.
    """
    i_all = [i for i, _ in forbidden] + [start[0], goal[0]]
    j_all = [j for _, j in forbidden] + [start[1], goal[1]]
    return min(i_all) - 1, max(i_all) + 1, min(j_all) - 1, max(j_all) + 1


def _interpolate(jumps: list[Cell]) -> list[Cell]:
    """Every cell of a jump point path: consecutive jump points lie on one straight or diagonal line."""
    cells = [jumps[0]]
    for (ai, aj), (bi, bj) in itertools.pairwise(jumps):
        si, sj = (bi > ai) - (bi < ai), (bj > aj) - (bj < aj)
        cells.extend((ai + si * k, aj + sj * k) for k in range(1, max(abs(bi - ai), abs(bj - aj)) + 1))
    return cells


class _JumpSearch:
    """Jump point search (Harabor and Grastien), in its variant without corner cutting, on a fenced box.

    Plain A* on open ground pushes every cell of the many equally short paths through its heap, and in a
    cul-de-sac it floods the whole pocket cell by cell: around 40 ms in pure Python for a 100 m pocket. JPS
    stops only at cells where the walls can change the best direction (jump points) and covers the lines in
    between at once. A straight line is answered by bisecting per-line sorted lists of walls and of jump
    points rather than by stepping along it, which makes it cheap enough for the flight computer.

    The unbounded grid is fenced (see ``_box``), which makes every line end.
    """

    def __init__(self, forbidden: frozenset[Cell], start: Cell, goal: Cell) -> None:
        self.forbidden, self.start, self.goal = forbidden, start, goal
        self.box = _box(forbidden, start, goal)
        self.lo_i, self.hi_i, self.lo_j, self.hi_j = self.box
        self.rows: dict[int, list[int]] = {}  # j -> sorted i of forbidden cells in that row
        self.cols: dict[int, list[int]] = {}  # i -> sorted j
        for i, j in forbidden:
            self.rows.setdefault(j, []).append(i)
            self.cols.setdefault(i, []).append(j)
        for line in (*self.rows.values(), *self.cols.values()):
            line.sort()
        self._forced_cache: dict[tuple[bool, int, int], list[int]] = {}
        self.work = 0

    def run(self, budget: int) -> list[Cell] | None:
        """Jump points from start to goal, or None when the goal is out of reach or the budget ran out."""
        start, goal = self.start, self.goal
        gi, gj = goal
        g: dict[Cell, float] = {start: 0.0}
        parent: dict[Cell, Cell] = {}
        h0 = _octile(start[0] - gi, start[1] - gj)
        heap = [(h0, h0, start)]
        while heap:
            f, hc, cell = heapq.heappop(heap)
            gc = g[cell]
            if f - hc > gc + TIE:  # stale entry: reached more cheaply since
                continue
            if cell == goal:
                return _trace_cells(parent, cell)
            self.work += 1
            if self.work > budget:
                return None
            i, j = cell
            for di, dj in self._directions(cell, parent.get(cell)):
                n = self._diagonal(i, j, di, dj) if di and dj else self._straight(i, j, di, dj)
                if n is None:
                    continue
                ng = gc + _octile(n[0] - i, n[1] - j)
                if ng < g.get(n, math.inf):
                    g[n], parent[n] = ng, cell
                    hn = _octile(n[0] - gi, n[1] - gj)
                    heapq.heappush(heap, (ng + hn, hn, n))
        return None

    def _directions(self, cell: Cell, parent: Cell | None) -> Sequence[Cell]:
        """Directions worth jumping in from a jump point, given the direction it was reached in."""
        if parent is None:
            return _ALL_DIRECTIONS
        (i, j), (pi, pj) = cell, parent
        di, dj = (i > pi) - (i < pi), (j > pj) - (j < pj)
        if di and dj:
            return ((di, 0), (0, dj), (di, dj))
        out = [(di, dj)]
        blocked = self.forbidden
        for s in (1, -1):  # a wall beside-behind with free space beside: the forced neighbours
            side, behind = ((i, j + s), (i - di, j + s)) if di else ((i + s, j), (i + s, j - dj))
            if behind in blocked and side not in blocked:
                out += [(0, s), (di, s)] if di else [(s, 0), (s, dj)]
        return out

    def _straight(self, i: int, j: int, di: int, dj: int) -> Cell | None:
        if di:
            x = self._stop(True, j, i, di)
            return None if x is None else (x, j)
        z = self._stop(False, i, j, dj)
        return None if z is None else (i, z)

    def _diagonal(self, i: int, j: int, di: int, dj: int) -> Cell | None:
        """Walk diagonally until a cell from which a straight line finds a jump point."""
        blocked, goal = self.forbidden, self.goal
        lo_i, hi_i, lo_j, hi_j = self.lo_i, self.hi_i, self.lo_j, self.hi_j
        while True:
            if (i + di, j) in blocked or (i, j + dj) in blocked:
                return None
            i, j = i + di, j + dj
            if not (lo_i <= i <= hi_i and lo_j <= j <= hi_j) or (i, j) in blocked:
                return None
            self.work += 1
            if (i, j) == goal or self._stop(True, j, i, di) is not None or self._stop(False, i, j, dj) is not None:
                return i, j

    def _stop(self, along_i: bool, line: int, pos: int, step: int) -> int | None:
        """The first jump point after ``pos`` moving by ``step`` along a row (``along_i``) or column, or None
        when a wall or the fence comes first."""
        walls = (self.rows if along_i else self.cols).get(line, ())
        forced = self._forced(along_i, line, step)
        gi, gj = self.goal
        goal_pos = (gi if gj == line else None) if along_i else (gj if gi == line else None)
        if step > 0:
            k = bisect.bisect_right(walls, pos)
            wall = walls[k] if k < len(walls) else (self.hi_i if along_i else self.hi_j) + 1
            k = bisect.bisect_right(forced, pos)
            stop = forced[k] if k < len(forced) else wall
            if goal_pos is not None and pos < goal_pos < stop:
                stop = goal_pos
            return stop if stop < wall else None
        k = bisect.bisect_left(walls, pos)
        wall = walls[k - 1] if k else (self.lo_i if along_i else self.lo_j) - 1
        k = bisect.bisect_left(forced, pos)
        stop = forced[k - 1] if k else wall
        if goal_pos is not None and stop < goal_pos < pos:
            stop = goal_pos
        return stop if stop > wall else None

    def _forced(self, along_i: bool, line: int, step: int) -> list[int]:
        """Sorted cells of a line where a move along it by ``step`` has a forced neighbour: the cell beside and
        behind is forbidden, the cell beside is free. Built the first time the search walks that line."""
        key = (along_i, line, step)
        found = self._forced_cache.get(key)
        if found is None:
            blocked = self.forbidden
            lines = self.rows if along_i else self.cols
            cells = set()
            for side in (line - 1, line + 1):
                for w in lines.get(side, ()):
                    x = w + step
                    beside, here = ((x, side), (x, line)) if along_i else ((side, x), (line, x))
                    if beside not in blocked and here not in blocked:
                        cells.add(x)
            found = self._forced_cache[key] = sorted(cells)
        return found


def _trace_cells(parent: dict[Cell, Cell], cell: Cell) -> list[Cell]:
    cells = [cell]
    while cell in parent:
        cell = parent[cell]
        cells.append(cell)
    cells.reverse()
    return cells


_STRIDE = 1 << 22
_OFFSET = 1 << 21
"""Cells are packed into one int inside the search (int hashing and adding beat tuples by about 2x), which
caps |i|, |j| below 2**21 cells: 2000 km at 1 m cells."""


def _astar(start: Cell, goal: Cell, forbidden: frozenset[Cell], budget: int,
           box: tuple[int, int, int, int]) -> tuple[list[Cell], bool] | None:
    """Plain A* with the octile heuristic, fenced like the jump point search, for when that did not reach
    the goal: it returns the path to the reached cell nearest the goal once the budget is spent or the
    rover's region is exhausted, or None when that region is walled in. Ties go to the cell nearer the goal;
    diagonal steps may not cut the corner of a forbidden cell."""
    stride, gi, gj = _STRIDE, goal[0], goal[1]
    lo_i, hi_i, lo_j, hi_j = box
    blocked = {(i + _OFFSET) * stride + j + _OFFSET for i, j in _with_fence(forbidden, box)}
    moves = [(di, dj, di * stride + dj, cost, di * stride if di and dj else 0, dj if di and dj else 0)
             for di, dj, cost in _NEIGHBOURS]
    k_diag = SQRT2 - 2.0
    start_key = (start[0] + _OFFSET) * stride + start[1] + _OFFSET
    goal_key = (gi + _OFFSET) * stride + gj + _OFFSET
    g = {start_key: 0.0}
    parent: dict[int, int] = {}
    cell_ij = {start_key: start}
    h0 = _octile(start[0] - gi, start[1] - gj)
    heap = [(h0, h0, start_key)]
    best, best_h, expanded = start_key, h0, 0
    while heap:
        f, hc, key = heapq.heappop(heap)
        gc = g[key]
        if f - hc > gc + TIE:  # stale entry: the cell was reached more cheaply since
            continue
        if key == goal_key:
            return _trace(parent, key, cell_ij), True
        if hc < best_h:
            best, best_h = key, hc
        expanded += 1
        if expanded > budget:
            return _trace(parent, best, cell_ij), False
        i, j = cell_ij[key]
        for di, dj, dk, cost, side_a, side_b in moves:
            n = key + dk
            if n in blocked or (side_a and (key + side_a in blocked or key + side_b in blocked)):
                continue
            ng = gc + cost
            if ng < g.get(n, math.inf):
                g[n], parent[n] = ng, key
                ni, nj = i + di, j + dj
                cell_ij[n] = (ni, nj)
                dx, dz = abs(ni - gi), abs(nj - gj)
                hn = dx + dz + k_diag * (dx if dx < dz else dz)
                heapq.heappush(heap, (ng + hn, hn, n))
    if all(lo_i < i < hi_i and lo_j < j < hi_j for i, j in cell_ij.values()):
        return None  # the region never reached the free ring round every wall: walled in
    return _trace(parent, best, cell_ij), False


def _with_fence(forbidden: frozenset[Cell], box: tuple[int, int, int, int]) -> Iterable[Cell]:
    lo_i, hi_i, lo_j, hi_j = box
    yield from forbidden
    for i in range(lo_i - 1, hi_i + 2):
        yield i, lo_j - 1
        yield i, hi_j + 1
    for j in range(lo_j, hi_j + 1):
        yield lo_i - 1, j
        yield hi_i + 1, j


def _octile(di: int, dj: int) -> float:
    dx, dz = abs(di), abs(dj)
    return dx + dz + (SQRT2 - 2.0) * min(dx, dz)


def _trace(parent: dict[int, int], key: int, cell_ij: dict[int, Cell]) -> list[Cell]:
    keys = [key]
    while key in parent:
        key = parent[key]
        keys.append(key)
    return [cell_ij[k] for k in reversed(keys)]


def _farthest_visible(points: Sequence[Point], anchor: int, forbidden: frozenset[Cell], cell_m: float) -> int:
    for far in range(len(points) - 1, anchor + 1, -1):
        if segment_clear(points[anchor], points[far], forbidden, cell_m):
            return far
    return anchor + 1


def next_waypoint(grid: OccupancyGrid, pose: Pose, goal_xz: Point, clearance_m: float, max_step_m: float,
                  max_expansions: int = 20000, avoid: frozenset[Cell] = frozenset()) -> Point | None:
    """Where to move next: the end of the first straight leg of the plan, at most ``max_step_m`` away along it
    (short steps let the rover look again before trusting what the map only guesses). None when the rover is
    walled in, or already as near as it can get to a walled-off goal."""
    start = (pose.x, pose.z)
    path = plan(grid, start, goal_xz, clearance_m, max_expansions, avoid)
    if not path:
        return None
    points = [start, *path]
    forbidden = _forbidden(grid, clearance_m, (grid.cell_of(*start), grid.cell_of(*path[-1])), avoid)
    x, z = points[_farthest_visible(points, 0, forbidden, grid.cell_m)]  # the first straight leg
    length = math.hypot(x - pose.x, z - pose.z)
    if length <= max_step_m:
        return x, z
    f = max_step_m / length
    return pose.x + f * (x - pose.x), pose.z + f * (z - pose.z)
