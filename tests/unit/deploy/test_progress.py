"""What ``lunarsim run`` shows while its agents connect: who has joined, then once, when the clock runs, how
long it took; nothing of it when quiet."""

from __future__ import annotations

import io

from rich.console import Console

from deploy.progress import START_UP_LINE_PERIOD_S, ProgressView, StartUp
from schemas import messages as m
from schemas.keyspace import Keyspace

KEYS = Keyspace("progress")


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def _state() -> m.WorldState:
    return m.WorldState(stamp=0.05, rovers=[], comm_links=[], relays=[], counters=m.WorldCounters())


def test_start_up_counts_the_agents_whose_tokens_are_there():
    clock = Clock()
    start_up = StartUp(3, KEYS.alive_lander, now=clock)
    assert start_up.waiting() == "connecting: 0/3 rover agents and not yet the lander (0 s)"
    for rid in (1, 2):
        start_up.note(KEYS.alive_rover(rid), True)
    start_up.note(KEYS.alive_rover(2), False)  # an agent that came and went is not connected
    start_up.note(KEYS.alive_lander, True)
    clock.t += 4.0
    assert start_up.waiting() == "connecting: 1/3 rover agents and the lander (4 s)"
    start_up.note(KEYS.alive_rover(2), True)
    start_up.note(KEYS.alive_rover(3), True)
    clock.t += 0.5
    assert start_up.done() == "3/3 rover agents and the lander connected in 4.5 s; clock running"


def _view(quiet: bool = False, now: Clock | None = None) -> tuple[ProgressView, io.StringIO]:
    out = io.StringIO()
    return ProgressView(Console(file=out, width=120), "crater", quiet, now or Clock()), out


def test_a_log_says_who_connected_every_few_seconds_then_once_how_long_it_took():
    clock = Clock()
    start_up = StartUp(2, KEYS.alive_lander, now=clock)
    view, out = _view(now=clock)
    with view:
        view.update(None, None, start_up)
        start_up.note(KEYS.alive_rover(1), True)
        clock.t += START_UP_LINE_PERIOD_S / 2
        view.update(None, None, start_up)  # too soon for another line
        clock.t += START_UP_LINE_PERIOD_S / 2
        view.update(None, None, start_up)
        start_up.note(KEYS.alive_rover(2), True)
        start_up.note(KEYS.alive_lander, True)
        view.update(_state(), None, start_up)
        view.update(_state(), None, start_up)
    lines = out.getvalue().splitlines()
    assert lines[:3] == ["connecting: 0/2 rover agents and not yet the lander (0 s)",
                         "connecting: 1/2 rover agents and not yet the lander (2 s)",
                         "2/2 rover agents and the lander connected in 2.0 s; clock running"]
    assert lines[3].startswith("t =     0.1 s  finished 0/0")
    assert len(lines) == 4  # the start-up is said once; the next state line waits its period


def test_quiet_shows_nothing_of_the_start_up():
    start_up = StartUp(1, KEYS.alive_lander)
    view, out = _view(quiet=True)
    with view:
        view.update(None, None, start_up)
        view.update(_state(), None, start_up)
    assert out.getvalue() == ""
