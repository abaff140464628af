"""The radio model (report 10.4): who hears whom, and which transmissions arrive.

Node 0 is the lander, nodes 1..N the rovers. Two nodes are linked when both lie within the range of
the link (the lander's own range for its links, ``comm_range`` between rovers) and, unless switched
off, see each other: the straight line between their antennas clears the terrain and crosses no wall.
Delivery is transitive (report 10.4.1): a message reaches every target in the sender's component.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

from world_service import geometry as geo
from world_service.scene import FEW_PAIRS, CircleGrid

LOS_STEP_M = 2.0
"""Spacing of the terrain samples along a link's line of sight (at most LOS_MAX_SAMPLES per link)."""
LOS_MAX_SAMPLES = 64
MIN_CELL_M = 1.0
"""Grid cell of the rover pair search when the radio range is shorter (a zero range would make no grid)."""
Pairs = tuple[np.ndarray, np.ndarray]


@dataclass(frozen=True)
class CommGraph:
    ids: np.ndarray  # node ids, lander (0) first
    adjacency: np.ndarray  # bool (n, n), no self links
    component: np.ndarray  # component label per node

    def partners(self, node_id: int) -> list[int]:
        i = self._index(node_id)
        return self.ids[self.adjacency[i]].tolist() if i is not None else []

    def connected(self, a: int, b: int) -> bool:
        ia, ib = self._index(a), self._index(b)
        return ia is not None and ib is not None and bool(self.component[ia] == self.component[ib])

    def connected_to_lander(self) -> np.ndarray:
        """Bool per node: in the lander's component (the lander itself included)."""
        return self.component == self.component[0]

    def links(self) -> list[tuple[int, int]]:
        return list(self._links)

    def relays(self) -> list[int]:
        """Rovers that carry another rover's traffic on its shortest route to the lander: the daisy chain."""
        return list(self._relays)

    # The world publishes links and relays with every state (5 Hz) but rebuilds the graph once a second; with
    # 500 rovers working them out again was 2.7 ms a state, so a graph works them out once.

    @functools.cached_property
    def _links(self) -> tuple[tuple[int, int], ...]:
        i, j = np.nonzero(np.triu(self.adjacency))
        return tuple((int(self.ids[a]), int(self.ids[b])) for a, b in zip(i, j, strict=True))

    @functools.cached_property
    def _relays(self) -> tuple[int, ...]:
        n = len(self.ids)
        parent = np.full(n, -1)
        seen = np.zeros(n, bool)
        seen[0] = True
        frontier = np.array([0])
        while len(frontier):
            reached = self.adjacency[frontier]
            nxt = []
            for row, node in enumerate(frontier):
                new = np.nonzero(reached[row] & ~seen)[0]
                parent[new], seen[new] = node, True
                nxt.extend(new.tolist())
            frontier = np.array(nxt, int)
        return tuple(sorted(int(self.ids[p]) for p in set(parent[parent > 0].tolist())))

    def _index(self, node_id: int) -> int | None:
        return self._indices.get(node_id)

    @functools.cached_property
    def _indices(self) -> dict[int, int]:
        """Node id to row: every rover's partners are looked up once a second, and radio deliveries in between."""
        return {node: i for i, node in enumerate(self.ids.tolist())}


def build_graph(ids: np.ndarray, x: np.ndarray, z: np.ndarray, comm_range: float, lander_range: float,
                sight=None) -> CommGraph:
    """Graph of nodes at (x, z); ``ids[0]`` must be the lander. ``sight(i, j)`` filters pairs in range."""
    i, j = _pairs_in_range(x, z, comm_range, lander_range)
    if sight is not None:
        seen = sight(i, j)
        i, j = i[seen], j[seen]
    adjacency = np.zeros((len(ids), len(ids)), bool)
    adjacency[i, j] = adjacency[j, i] = True
    return CommGraph(ids, adjacency, _components(adjacency))


def _pairs_in_range(x: np.ndarray, z: np.ndarray, comm_range: float, lander_range: float) -> Pairs:
    """Node pairs (i < j, in row order) within range of each other; rovers by grid look-up when the range is
    finite. The matrix of every distance made a graph of 1,000 rovers cost 16.6 ms instead of 5.5, where each
    rover has a handful of neighbours within its 10 m."""
    n = len(x)
    if not math.isfinite(comm_range) or n * n <= FEW_PAIRS:
        reach = np.full((n, n), comm_range)
        reach[0, :] = reach[:, 0] = lander_range
        return np.nonzero(np.triu(np.hypot(x[:, None] - x[None, :], z[:, None] - z[None, :]) <= reach, 1))
    rx, rz = x[1:], z[1:]
    a, b = CircleGrid(rx, rz, np.zeros(n - 1), max(comm_range, MIN_CELL_M)).pairs(rx, rz, comm_range)
    upper = a < b
    lander = np.nonzero(np.hypot(x[0] - rx, z[0] - rz) <= lander_range)[0] + 1
    i = np.concatenate([np.zeros(len(lander), int), a[upper] + 1])
    j = np.concatenate([lander, b[upper] + 1])
    order = np.lexsort((j, i))
    return i[order], j[order]


def line_of_sight(terrain, edges: np.ndarray, edge_height: np.ndarray, x: np.ndarray, z: np.ndarray,
                  antenna: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Whether node i sees node j for each pair: the antenna-to-antenna line clears the terrain and the walls.

    ``antenna`` is each node's antenna height above the ground (the lander's mast is taller than a rover's).
    """
    if not len(i):
        return np.zeros(0, bool)
    x0, z0, x1, z1 = x[i], z[i], x[j], z[j]
    length = np.hypot(x1 - x0, z1 - z0)
    steps = min(LOS_MAX_SAMPLES, max(2, int(np.ceil(length.max() / LOS_STEP_M)) + 1))
    f = np.linspace(0.0, 1.0, steps)[None, :]
    px, pz = x0[:, None] + f * (x1 - x0)[:, None], z0[:, None] + f * (z1 - z0)[:, None]
    ground = terrain.height(px.ravel(), pz.ravel()).reshape(px.shape)
    top0, top1 = ground[:, :1] + antenna[i, None], ground[:, -1:] + antenna[j, None]
    line = top0 * (1 - f) + top1 * f
    clear = np.all(ground[:, 1:-1] <= line[:, 1:-1], axis=1)
    if len(edges):
        clear &= ~_under_a_wall(x0, z0, x1, z1, length, top0[:, 0], top1[:, 0], terrain, edges, edge_height)
    return clear


def _under_a_wall(x0, z0, x1, z1, length, top0, top1, terrain, edges, edge_height) -> np.ndarray:
    """Pairs whose line crosses a wall below the wall's top."""
    dx, dz = (x1 - x0) / np.maximum(length, 1e-9), (z1 - z0) / np.maximum(length, 1e-9)
    t = geo.ray_segments(x0, z0, dx, dz, edges[:, 0], edges[:, 1], edges[:, 2], edges[:, 3])
    crossing = t <= length[:, None]
    if not crossing.any():
        return np.zeros(len(x0), bool)
    f = np.where(crossing, t, 0.0) / np.maximum(length, 1e-9)[:, None]
    line = top0[:, None] * (1 - f) + top1[:, None] * f
    wall_top = terrain.height(x0[:, None] + dx[:, None] * np.where(crossing, t, 0.0),
                              z0[:, None] + dz[:, None] * np.where(crossing, t, 0.0)) + edge_height[None, :]
    return np.any(crossing & (line < wall_top), axis=1)


def _components(adjacency: np.ndarray) -> np.ndarray:
    """Connected-component labels by breadth-first search over the adjacency matrix."""
    n = len(adjacency)
    label = np.full(n, -1)
    for seed in range(n):
        if label[seed] >= 0:
            continue
        frontier = np.zeros(n, bool)
        frontier[seed] = True
        while frontier.any():
            label[frontier] = seed
            frontier = adjacency[frontier].any(axis=0) & (label < 0)
    return label
