"""The rover's occupancy memory and path planner: placing hits, clearing by free rays, shortest paths around
walls, and the maze of scenarios/maze.yaml where greedy avoidance gets trapped."""

from __future__ import annotations

import heapq
import itertools
import math
import random
from collections.abc import Sequence
from pathlib import Path

import pytest

from rover_agent.behaviour import Hit
from rover_agent.rules.occupancy import Point
from rover_agent.rules.planner import (
    PLAN_REACH_CELLS,
    OccupancyGrid,
    _farthest_visible,
    _forbidden,
    disc_offsets,
    next_waypoint,
    plan,
)
from schemas.scenario import load_scenario
from shared.pose import Pose

MAZE = Path(__file__).resolve().parents[3] / "scenarios" / "maze.yaml"
MAZE_START = (-500.0, 95.0)
MAZE_GOAL = (-507.6, -52.8)
CLEARANCE = 1.2
SQRT2 = math.sqrt(2.0)

Segment = tuple[tuple[float, float], tuple[float, float], float]  # centreline end points, thickness


# ---- helpers ----

def _blocked_cells(grid: OccupancyGrid) -> frozenset[tuple[int, int]]:
    return frozenset(grid._blocked)


def simplify(path: Sequence[Point], grid: OccupancyGrid, clearance_m: float,
             start_xz: Point | None = None) -> list[Point]:
    """The straight legs a rover walks along a planned path (``next_waypoint`` takes the first): intermediate
    points dropped while the straight line between kept points stays clear.

    A cell path zigzags in 45-degree steps; the rover should instead walk long straight legs, as the report's
    rovers do. From each kept point it jumps to the farthest later point in clear line of sight. With
    ``start_xz`` the first leg is checked from the start, which is not returned (as ``plan`` leaves it out);
    without it the path's first point is the anchor and is kept.
    """
    points = ([start_xz] if start_xz is not None else []) + list(path)
    if len(points) <= 2:
        return list(path)
    forbidden = _forbidden(grid, clearance_m, (grid.cell_of(*points[0]), grid.cell_of(*points[-1])))
    kept, anchor = [points[0]], 0
    while anchor < len(points) - 1:
        anchor = _farthest_visible(points, anchor, forbidden, grid.cell_m)
        kept.append(points[anchor])
    return kept[1:] if start_xz is not None else kept


def _inflated(grid: OccupancyGrid, clearance: float) -> set[tuple[int, int]]:
    """Cells whose centre is within the clearance of a blocked cell's centre (computed here, not by the module)."""
    out = set()
    reach = math.ceil(clearance / grid.cell_m)
    for i, j in _blocked_cells(grid):
        for di in range(-reach, reach + 1):
            for dj in range(-reach, reach + 1):
                if math.hypot(di, dj) * grid.cell_m <= clearance + 1e-9:
                    out.add((i + di, j + dj))
    return out


def _samples(route: list[tuple[float, float]], step: float = 0.05):
    """Points every ``step`` metres along a polyline."""
    for (ax, az), (bx, bz) in itertools.pairwise(route):
        n = max(1, math.ceil(math.hypot(bx - ax, bz - az) / step))
        for k in range(n + 1):
            yield ax + (bx - ax) * k / n, az + (bz - az) * k / n


def _route_cells(grid: OccupancyGrid, route: list[tuple[float, float]]) -> set[tuple[int, int]]:
    return {grid.cell_of(x, z) for x, z in _samples(route)}


def _wall_cells(grid: OccupancyGrid, a: tuple[float, float], b: tuple[float, float], thickness: float) -> set:
    """Cells covered by a thick wall: its centreline sampled every 0.5 m, and across its thickness."""
    (ax, az), (bx, bz) = a, b
    length = math.hypot(bx - ax, bz - az)
    ux, uz = (bx - ax) / length, (bz - az) / length
    half = thickness / 2 - 1e-3  # inside the wall, not on its surface
    across = [-half + 0.5 * k for k in range(int(2 * half / 0.5) + 1)] + [half]
    cells = set()
    for k in range(int(length / 0.5) + 1):
        x, z = ax + ux * 0.5 * k, az + uz * 0.5 * k
        cells.update(grid.cell_of(x - uz * o, z + ux * o) for o in across)
    cells.add(grid.cell_of(bx, bz))
    return cells


def _maze_segments(sealed: bool) -> tuple[list[Segment], list[tuple[float, float, float]]]:
    """Wall segments and rocks of scenarios/maze.yaml; ``sealed`` extends the corridor's side walls north of the
    start and south of the goal, so that the only way south is through the baffles' openings."""
    scenario = load_scenario(MAZE)
    segments = [(a, b, w.thickness_m) for w in scenario.obstacles.walls for a, b in itertools.pairwise(w.points)]
    if sealed:
        segments += [((x, 75.0), (x, 110.0), 1.0) for x in (-540.0, -450.0)]
        segments += [((x, -10.0), (x, -70.0), 1.0) for x in (-540.0, -450.0)]
    rocks = [(r.x, r.z, r.radius_m) for r in scenario.obstacles.rocks]
    return segments, rocks


def _maze_grid(sealed: bool) -> tuple[OccupancyGrid, list[Segment]]:
    grid = OccupancyGrid(1.0)
    segments, rocks = _maze_segments(sealed)
    cells = set()
    for a, b, thickness in segments:
        cells |= _wall_cells(grid, a, b, thickness)
    for x, z, r in rocks:
        ci, cj = grid.cell_of(x, z)
        cells.update((ci + di, cj + dj) for di, dj in disc_offsets(r))
    grid.block(cells)
    return grid, segments


def _distance_to_segment(px: float, pz: float, seg: Segment) -> float:
    (ax, az), (bx, bz), _ = seg
    dx, dz = bx - ax, bz - az
    t = max(0.0, min(1.0, ((px - ax) * dx + (pz - az) * dz) / (dx * dx + dz * dz)))
    return math.hypot(px - ax - t * dx, pz - az - t * dz)


def _wall_gap(route: list[tuple[float, float]], segments: list[Segment]) -> float:
    """Smallest distance from the route to the surface of any wall."""
    return min(_distance_to_segment(x, z, s) - s[2] / 2 for x, z in _samples(route, 0.1) for s in segments)


def _crossings(route: list[tuple[float, float]], z_line: float) -> list[float]:
    """x where the route crosses the line z = z_line (a vertex on the line counts once)."""
    out = []
    for (ax, az), (bx, bz) in itertools.pairwise(route):
        if (az > z_line) != (bz > z_line):
            out.append(ax + (bx - ax) * (z_line - az) / (bz - az))
    return out


def _reference_cost(forbidden: set, start: tuple[int, int], goal: tuple[int, int],
                    bound: int) -> tuple[float | None, bool, float]:
    """Dijkstra on a window ``bound`` cells around the origin, 8-connected, no corner cutting: the yardstick for
    the planner. Returns the cost to the goal (None: unreachable), whether the start is walled in (its region
    never reaches the window's edge, beyond which everything is free) and the octile distance from the goal
    of the nearest cell reached."""
    dist = {start: 0.0}
    heap = [(0.0, start)]
    walled_in, nearest = True, math.inf
    while heap:
        d, (i, j) = heapq.heappop(heap)
        if (i, j) == goal:
            return d, False, 0.0
        if d > dist[(i, j)]:
            continue
        walled_in = walled_in and max(abs(i), abs(j)) < bound
        nearest = min(nearest, _octile(i - goal[0], j - goal[1]))
        for di, dj in itertools.product((-1, 0, 1), repeat=2):
            n = (i + di, j + dj)
            if (di, dj) == (0, 0) or n in forbidden or max(abs(n[0]), abs(n[1])) > bound:
                continue
            if di and dj and ((i + di, j) in forbidden or (i, j + dj) in forbidden):
                continue
            nd = d + (SQRT2 if di and dj else 1.0)
            if nd < dist.get(n, math.inf):
                dist[n] = nd
                heapq.heappush(heap, (nd, n))
    return None, walled_in, nearest


def _octile(di: int, dj: int) -> float:
    return max(abs(di), abs(dj)) + (SQRT2 - 1) * min(abs(di), abs(dj))


def _cost(start: tuple[float, float], path: list[tuple[float, float]]) -> float:
    return sum(math.dist(a, b) for a, b in itertools.pairwise([start, *path]))


# ---- the grid ----

def test_observe_places_hits_in_the_world_cell():
    grid = OccupancyGrid(1.0)
    grid.observe(Pose(0.0, 0.0, 90.0), [Hit(0.0, 5.0, "obstacle")], radius=10.0)
    assert _blocked_cells(grid) == {grid.cell_of(5.0, 0.0)}
    assert grid.blocked(*grid.cell_of(5.0, 0.0))

    grid = OccupancyGrid(1.0)
    pose = Pose(10.0, -4.0, 180.0)  # facing -z: left is +x
    grid.observe(pose, [Hit(-90.0, 3.0, "terrain"), Hit(45.0, 4 * SQRT2, "lander")], radius=10.0)
    assert _blocked_cells(grid) == {grid.cell_of(13.0, -4.0), grid.cell_of(6.0, -8.0)}


def test_cells_are_centred_on_multiples_of_the_cell_size():
    grid = OccupancyGrid(0.5)
    assert grid.cell_of(1.0, -1.0) == (2, -2)
    assert grid.cell_of(1.24, -1.26) == (2, -3)
    assert grid.centre_of(2, -3) == (1.0, -1.5)


def test_rovers_and_crater_terrain_are_not_remembered():
    grid = OccupancyGrid(1.0)
    grid.observe(Pose(0.0, 0.0, 0.0), [Hit(0.0, 3.0, "rover"), Hit(10.0, 6.0, "crater_terrain")], radius=10.0)
    assert _blocked_cells(grid) == frozenset()


def test_free_rays_clear_a_stale_cell_once_seen_free_more_often_than_hit():
    grid = OccupancyGrid(1.0)
    pose = Pose(0.0, 0.0, 0.0)
    grid.observe(pose, [Hit(0.0, 5.0, "obstacle")], radius=10.0)
    cell = grid.cell_of(0.0, 5.0)
    assert grid.blocked(*cell)
    grid.observe(pose, [], radius=10.0, free_angles=[0.0])
    assert grid.blocked(*cell), "one free look against one hit: keep the obstacle (ties block)"
    grid.observe(pose, [], radius=10.0, free_angles=[0.0])
    assert not grid.blocked(*cell)
    grid.observe(pose, [Hit(0.0, 5.0, "obstacle")], radius=10.0)
    assert grid.blocked(*cell), "seen again: blocked again"


def test_a_free_ray_does_not_outvote_a_hit_in_the_same_scan_or_clear_beyond_the_radius():
    grid = OccupancyGrid(1.0)
    pose = Pose(0.0, 0.0, 0.0)
    grid.observe(pose, [Hit(0.0, 5.0, "obstacle"), Hit(0.0, 12.0, "obstacle")], radius=20.0)
    for _ in range(3):  # the ray at 1 degree grazes the cell at 5 m but the hit inside it is seen each time
        grid.observe(pose, [Hit(0.0, 5.0, "obstacle")], radius=10.0, free_angles=[1.0])
    assert grid.blocked(0, 5)
    assert grid.blocked(0, 12), "12 m is beyond the 10 m radius of the free ray"


def test_a_hit_beyond_the_radius_is_no_obstacle_kept():
    """No sensor sees farther; a forged hit a thousand kilometres off stretched every plan's search to it."""
    grid = OccupancyGrid(1.0)
    grid.observe(Pose(0.0, 0.0, 0.0), [Hit(0.0, 1e6, "obstacle"), Hit(0.0, 10.0, "obstacle")], radius=10.0)
    assert _blocked_cells(grid) == {grid.cell_of(0.0, 10.0)}


# ---- planning ----

def test_open_space_path_ends_at_the_goal_and_simplifies_to_one_straight_leg():
    grid = OccupancyGrid(1.0)
    start, goal = (0.0, 0.0), (30.3, 12.6)
    path = plan(grid, start, goal, CLEARANCE)
    assert path is not None and path[-1] == goal
    assert all(math.dist(a, b) <= SQRT2 + 1e-9 for a, b in itertools.pairwise([start, *path[:-1]]))
    assert simplify(path, grid, CLEARANCE, start_xz=start) == [goal]
    assert simplify(path, grid, CLEARANCE) == [path[0], goal]


def test_a_plan_goes_a_bounded_way_towards_a_far_goal():
    """A goal a thousand kilometres off (a slip in a ground command): the plan heads for it over what the rover
    has seen, a few kilometres at most, rather than search a box that size round a wall (6.7 s a decision)."""
    grid = OccupancyGrid(1.0)
    grid.block((x, 5) for x in range(-20, 21))  # a wall across the way
    start, goal = (0.0, 0.0), (0.0, 1e6)
    path = plan(grid, start, goal, CLEARANCE)
    assert path is not None
    end = path[-1]
    assert end == pytest.approx((0.0, PLAN_REACH_CELLS * grid.cell_m))  # on the way to the goal, within reach
    assert all(not grid.blocked(*grid.cell_of(*p)) for p in path)


def test_plan_goes_through_the_gap_of_a_wall_and_keeps_its_clearance():
    grid = OccupancyGrid(1.0)
    grid.block((x, 10) for x in range(-15, 13))  # a wall across the way, open east of x = 12
    start, goal = (0.0, 0.0), (0.0, 20.0)
    path = plan(grid, start, goal, CLEARANCE)
    assert path is not None and path[-1] == goal
    inflated = _inflated(grid, CLEARANCE)
    assert not _route_cells(grid, [start, *path]) & inflated
    route = [start, *simplify(path, grid, CLEARANCE, start_xz=start)]
    assert len(route) <= 4
    assert not _route_cells(grid, route) & inflated
    assert all(x > 12 + CLEARANCE for x in _crossings(route, 10.0)) and _crossings(route, 10.0)
    assert _cost(start, path) < 40.0  # round the wall's end (x 14 at z 10 is 36.3 away), no detour


def test_cells_kept_clear_for_one_plan_are_gone_round_and_left_off_the_map():
    """Rovers standing in the way (``avoid``) are walked round in this plan only: the map does not keep them."""
    grid = OccupancyGrid(1.0)
    grid.block((x, 10) for x in range(-15, 13))  # the wall, open east of x = 12
    knot = frozenset((x, z) for x in range(10, 20) for z in range(7, 14))  # rovers packed in the gap
    start, goal = (0.0, 0.0), (0.0, 20.0)
    path = plan(grid, start, goal, CLEARANCE, avoid=knot)
    assert path is not None and path[-1] == goal
    assert not _route_cells(grid, [start, *path]) & (knot | _inflated(grid, CLEARANCE))
    assert all(x < -15 - CLEARANCE for x in _crossings([start, *path], 10.0))  # round the wall's other end
    assert not grid.blocked(15, 10) and plan(grid, start, goal, CLEARANCE)[-1] == goal


def _allowed_ends(grid: OccupancyGrid, inflated: set, ends, clearance: float) -> set:
    """The ends, and when an end lies within the clearance the unblocked cells within it: the rover near a
    wall may step away, a goal next to a rock may be reached."""
    allowed = set(ends)
    for ci, cj in ends:
        if (ci, cj) in inflated:
            allowed |= {c for c in _inflated_around(ci, cj, clearance) if not grid.blocked(*c)}
    return allowed


def _inflated_around(ci: int, cj: int, clearance: float) -> set:
    reach = math.ceil(clearance)
    return {(ci + di, cj + dj) for di in range(-reach, reach + 1) for dj in range(-reach, reach + 1)
            if math.hypot(di, dj) <= clearance + 1e-9}


@pytest.mark.parametrize("seed", range(3))
def test_plan_matches_a_reference_shortest_path_on_random_grids(seed):
    """The jump point search must stay optimal, never enter a forbidden cell or cut its corner, and tell a
    walled-in start from a walled-off goal; start and goal may lie anywhere, even on blocked cells."""
    rng = random.Random(seed)
    reached = 0
    for _ in range(80):
        grid = OccupancyGrid(1.0)
        size = rng.randrange(5, 25)
        grid.block((rng.randrange(size), rng.randrange(size)) for _ in range(int(rng.random() * 0.4 * size * size)))
        clearance = rng.choice([0.0, 1.0, 1.5])
        s, g = (rng.randrange(size), rng.randrange(size)), (rng.randrange(size), rng.randrange(size))
        if s == g:
            continue
        inflated = _inflated(grid, clearance)
        forbidden = inflated - _allowed_ends(grid, inflated, (s, g), clearance)
        want, walled_in, nearest = _reference_cost(forbidden, s, g, bound=size + 3)
        path = plan(grid, grid.centre_of(*s), grid.centre_of(*g), clearance, max_expansions=3000)
        assert (path is None) == walled_in
        if path is None:
            continue
        cells = [s, *(grid.cell_of(*p) for p in path)]
        for (ai, aj), (bi, bj) in itertools.pairwise(cells):
            assert max(abs(bi - ai), abs(bj - aj)) == 1
            assert (bi, bj) not in forbidden
            assert ai == bi or aj == bj or ((bi, aj) not in forbidden and (ai, bj) not in forbidden)
        if want is None:  # walled-off goal: the nearest approach
            assert _octile(cells[-1][0] - g[0], cells[-1][1] - g[1]) == pytest.approx(nearest)
            continue
        assert cells[-1] == g
        assert _cost(grid.centre_of(*s), path) == pytest.approx(want)
        reached += 1
    assert reached > 40


def test_enclosed_start_has_no_path():
    grid = OccupancyGrid(1.0)
    ring = {(i, j) for i in range(-5, 6) for j in range(-5, 6) if max(abs(i), abs(j)) == 5}
    grid.block(ring)
    assert plan(grid, (0.0, 0.0), (40.0, 3.0), CLEARANCE) is None
    assert next_waypoint(grid, Pose(0.0, 0.0, 0.0), (40.0, 3.0), CLEARANCE, 5.0) is None


def test_walled_off_goal_still_gives_progress_to_its_nearest_approach():
    grid = OccupancyGrid(1.0)
    goal = (40.0, 0.0)
    grid.block((40 + i, j) for i in range(-4, 5) for j in range(-4, 5) if max(abs(i), abs(j)) == 4)
    path = plan(grid, (0.0, 0.0), goal, CLEARANCE)
    assert path is not None and path[-1] != goal
    assert path[-1] == (34.0, 0.0)  # just outside the ring (x 36) and its clearance, straight towards the goal
    assert not _route_cells(grid, [(0.0, 0.0), *path]) & _inflated(grid, CLEARANCE)
    assert plan(grid, (34.0, 0.0), goal, CLEARANCE) == [], "already as near as it gets"
    assert next_waypoint(grid, Pose(34.0, 0.0, 90.0), goal, CLEARANCE, 5.0) is None


def test_budget_spent_before_a_far_goal_still_gives_progress():
    grid = OccupancyGrid(1.0)
    grid.block((x, 20) for x in range(-60, 61))  # forces a long search
    start, goal = (0.0, 0.0), (0.0, 400.0)
    path = plan(grid, start, goal, CLEARANCE, max_expansions=50)
    assert path is not None and path[-1] != goal
    assert math.dist(path[-1], goal) < math.dist(start, goal)


def test_start_next_to_a_wall_can_step_away():
    grid = OccupancyGrid(1.0)
    grid.block((x, 1) for x in range(-10, 11))
    path = plan(grid, (0.0, 0.0), (0.0, -20.0), CLEARANCE)
    assert path is not None and path[-1] == (0.0, -20.0)


def test_next_waypoint_is_within_the_step_along_the_first_leg():
    grid = OccupancyGrid(1.0)
    grid.block((x, 10) for x in range(-15, 13))
    pose, goal = Pose(0.0, 0.0, 0.0), (0.0, 20.0)
    leg_x, leg_z = simplify(plan(grid, (0.0, 0.0), goal, CLEARANCE), grid, CLEARANCE, start_xz=(0.0, 0.0))[0]
    x, z = next_waypoint(grid, pose, goal, CLEARANCE, max_step_m=4.0)
    assert math.hypot(x, z) == pytest.approx(4.0)
    leg = math.hypot(leg_x, leg_z)
    assert (x / 4.0, z / 4.0) == pytest.approx((leg_x / leg, leg_z / leg))
    assert next_waypoint(grid, pose, goal, CLEARANCE, max_step_m=100.0) == pytest.approx((leg_x, leg_z))


# ---- the maze ----

def test_maze_through_every_baffle_opening():
    """The corridor of scenarios/maze.yaml sealed beyond the start and the goal: the only way south is east
    round the baffle at z 55, west at z 25 and east again at z 0, which greedy avoidance never finds."""
    grid, segments = _maze_grid(sealed=True)
    path = plan(grid, MAZE_START, MAZE_GOAL, CLEARANCE)
    assert path is not None and path[-1] == MAZE_GOAL
    route = [MAZE_START, *simplify(path, grid, CLEARANCE, start_xz=MAZE_START)]
    inflated = _inflated(grid, CLEARANCE)
    assert not _route_cells(grid, [MAZE_START, *path]) & inflated
    assert not _route_cells(grid, route) & inflated
    assert _wall_gap(route, segments) > 0.5  # the rover's body (0.5 m radius) never touches a wall
    for z_line, low, high in ((55.0, -475.0, -450.0), (25.0, -540.0, -515.0), (0.0, -475.0, -450.0)):
        xs = _crossings(route, z_line)
        assert len(xs) == 1 and low + 0.5 < xs[0] < high - 0.5, (z_line, xs)


def test_maze_as_shipped_has_a_wall_free_path():
    """As shipped the corridor is open at both ends, and with the whole maze known the shortest way goes
    round it: the planner must still find a path that crosses no wall."""
    grid, segments = _maze_grid(sealed=False)
    path = plan(grid, MAZE_START, MAZE_GOAL, CLEARANCE)
    assert path is not None and path[-1] == MAZE_GOAL
    route = [MAZE_START, *simplify(path, grid, CLEARANCE, start_xz=MAZE_START)]
    assert not _route_cells(grid, route) & _inflated(grid, CLEARANCE)
    assert _wall_gap(route, segments) > 0.5


def _ray_distance(x: float, z: float, bearing: float, segments: list[Segment], rocks, radius: float) -> float:
    """Distance along a ray to the nearest axis-aligned thick wall or rock, or inf within the radius."""
    dx, dz = math.sin(math.radians(bearing)), math.cos(math.radians(bearing))
    best = math.inf
    for (ax, az), (bx, bz), t in segments:
        lo_x, hi_x = min(ax, bx) - t / 2, max(ax, bx) + t / 2
        lo_z, hi_z = min(az, bz) - t / 2, max(az, bz) + t / 2
        t0, t1 = 0.0, radius
        for p, d, lo, hi in ((x, dx, lo_x, hi_x), (z, dz, lo_z, hi_z)):
            if abs(d) < 1e-12:
                if not lo <= p <= hi:
                    t0, t1 = 1.0, 0.0
                continue
            a, b = (lo - p) / d, (hi - p) / d
            t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
        if t0 <= t1:
            best = min(best, t0)
    for rx, rz, r in rocks:
        along = (rx - x) * dx + (rz - z) * dz
        across2 = (rx - x) ** 2 + (rz - z) ** 2 - along * along
        if along > 0 and across2 < r * r:
            best = min(best, along - math.sqrt(r * r - across2))
    return best if best <= radius else math.inf


@pytest.mark.parametrize("sealed", [True, False])
def test_rover_discovering_the_maze_reaches_the_goal(sealed):
    """The point of the planner: starting with an empty map, seeing only 10 m over 210 degrees, replanning at
    every step with unknown as free, the rover finds its way through the maze without touching a wall."""
    segments, rocks = _maze_segments(sealed)
    radius, fov, rays = 10.0, 210.0, 50
    angles = [-fov / 2 + fov * k / (rays - 1) for k in range(rays)]
    grid = OccupancyGrid(1.0)
    pose = Pose(*MAZE_START, 180.0)
    for _ in range(120):
        if math.dist((pose.x, pose.z), MAZE_GOAL) < radius / 2:
            break
        hits, free = [], []
        for a in angles:
            d = _ray_distance(pose.x, pose.z, pose.heading + a, segments, rocks, radius)
            (free.append(a) if d == math.inf else hits.append(Hit(a, d, "obstacle")))
        grid.observe(pose, hits, radius, free_angles=free)
        target = next_waypoint(grid, pose, MAZE_GOAL, CLEARANCE, max_step_m=0.9 * radius)
        assert target is not None
        bearing = math.degrees(math.atan2(target[0] - pose.x, target[1] - pose.z)) % 360.0
        if abs((bearing - pose.heading + 180.0) % 360.0 - 180.0) > fov / 2 - 5:
            pose = Pose(pose.x, pose.z, bearing)  # turn to look where it is going first, as the behaviour does
            continue
        leg = [(pose.x, pose.z), target]
        assert _wall_gap(leg, segments) > 0.5, f"walked into a wall from {leg[0]} to {leg[1]}"
        pose = Pose(target[0], target[1], bearing)
    assert math.dist((pose.x, pose.z), MAZE_GOAL) < radius / 2
