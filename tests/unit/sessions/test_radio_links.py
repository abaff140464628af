"""The radio links a picture draws of a state: each pair once, the daisy chain's first, a bounded number."""

from __future__ import annotations

from schemas import messages as m
from sessions import radio_links
from sessions.radio_links import drawn_links


def test_each_pair_is_drawn_once_with_both_ends_known_the_chain_apart():
    state = m.WorldState(stamp=1.0, rovers=[], relays=[2],
                         comm_links=[(0, 1), (1, 0), (0, 1), (1, 2), (2, 3), (3, 9), (4, 4), (3, 1)])
    chain, plain = drawn_links(state, {0, 1, 2, 3, 4})
    assert chain == [(1, 2), (2, 3)] and plain == [(0, 1), (1, 3)]


def test_at_most_so_many_links_are_drawn_the_chain_first(monkeypatch):
    monkeypatch.setattr(radio_links, "MAX_LINKS_DRAWN", 5)
    links = [(a, b) for a in range(10) for b in range(a + 1, 10)]  # 45 pairs, rover 9 a relay
    chain, plain = drawn_links(m.WorldState(stamp=1.0, rovers=[], relays=[9], comm_links=links), set(range(10)))
    assert chain == [(0, 9), (1, 9), (2, 9), (3, 9), (4, 9)] and plain == []
