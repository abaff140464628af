"""Which radio links of a world state a picture draws (the trajectory plot, the Foxglove scene).

A state may list every pair of a thousand rovers and the lander (500,500 links), and the same pair again and
again; drawn one by one they took seconds and gigabytes a state. Each pair is drawn once, the daisy chain's
first, at most ``MAX_LINKS_DRAWN`` in all.
"""

from __future__ import annotations

from collections.abc import Container

from schemas.messages import WorldState

MAX_LINKS_DRAWN = 20_000
"""Links drawn of one state: every pair of 200 nodes, more than a picture can show apart."""


def drawn_links(state: WorldState, known: Container[int]) -> tuple[list[tuple[int, int]], list[tuple[int, int]]]:
    """(daisy chain, other links) to draw: each pair once, both ends ``known``, links touching a relay first."""
    relays = set(state.relays)
    chain: dict[tuple[int, int], None] = {}
    plain: dict[tuple[int, int], None] = {}
    for a, b in state.comm_links:
        if a in known and b in known and a != b:
            (chain if a in relays or b in relays else plain)[(min(a, b), max(a, b))] = None
    chain_drawn = list(chain)[:MAX_LINKS_DRAWN]
    return chain_drawn, list(plain)[:MAX_LINKS_DRAWN - len(chain_drawn)]
