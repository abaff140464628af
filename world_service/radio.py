"""The radio model (report 10.4): who hears whom, and which transmissions arrive.

Node 0 is the lander, nodes 1..N the rovers. Two nodes are linked when both lie within the range
of the link (the lander's own range for its links, ``comm_range`` between rovers). Delivery is
transitive (report 10.4.1): a message reaches every target in the sender's connected component.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CommGraph:
    ids: np.ndarray  # node ids, lander (0) first
    adjacency: np.ndarray  # bool (n, n), no self links
    component: np.ndarray  # component label per node

    def partners(self, node_id: int) -> list[int]:
        i = self._index(node_id)
        return [int(x) for x in self.ids[self.adjacency[i]]] if i is not None else []

    def connected(self, a: int, b: int) -> bool:
        ia, ib = self._index(a), self._index(b)
        return ia is not None and ib is not None and self.component[ia] == self.component[ib]

    def links(self) -> list[tuple[int, int]]:
        i, j = np.nonzero(np.triu(self.adjacency))
        return [(int(self.ids[a]), int(self.ids[b])) for a, b in zip(i, j, strict=True)]

    def _index(self, node_id: int) -> int | None:
        hits = np.nonzero(self.ids == node_id)[0]
        return int(hits[0]) if len(hits) else None


def build_graph(ids: np.ndarray, x: np.ndarray, z: np.ndarray, comm_range: float, lander_range: float) -> CommGraph:
    """Graph of nodes at (x, z); ``ids[0]`` must be the lander."""
    d = np.hypot(x[:, None] - x[None, :], z[:, None] - z[None, :])
    reach = np.full(d.shape, comm_range)
    reach[0, :] = reach[:, 0] = lander_range
    adjacency = d <= reach
    np.fill_diagonal(adjacency, False)
    return CommGraph(ids, adjacency, _components(adjacency))


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
