"""What ``lunarsim run`` shows: which agents have connected while it starts, a live table per rover while it
runs, a summary table at the end."""

from __future__ import annotations

import time
from collections.abc import Callable

from rich.console import Console
from rich.live import Live
from rich.table import Table

from schemas import messages as m

START_UP_LINE_PERIOD_S = 2.0
"""In a log, how often a line says which agents have connected while the run starts."""


def rover_table(state: m.WorldState | None, report: m.MissionReport | None, title: str) -> Table:
    table = Table(title=title, title_justify="left")
    for column in ("rover", "state", "goal", "to goal (m)", "covered (m)", "action"):
        table.add_column(column, justify="right" if column not in ("state", "action") else "left")
    for r in state.rovers if state else []:
        table.add_row(str(r.id), r.state if r.alive else f"{r.state} (agent lost)", str(r.goal_index + 1),
                      f"{r.distance_to_goal_m:.1f}", f"{r.distance_covered_m:.1f}", r.action)
    if report:
        table.caption = (f"collisions: {report.rover_collisions} rover, {report.obstacle_collisions} obstacle"
                         f"  ·  reached {report.rovers_reached_final_goal}/{report.rovers_total}"
                         f"  ·  stuck {report.rovers_stuck}")
    return table


class StartUp:
    """Which agents have joined the run (their liveliness tokens), shown until the world's clock runs: a hundred
    rover processes take seconds to connect on two cores (3.3 s forked warm, about 25 s started cold), and a view
    with nothing in it looks hung."""

    def __init__(self, rovers: int, lander_key: str, now: Callable[[], float] = time.monotonic) -> None:
        self.rovers, self.lander_key, self.now = rovers, lander_key, now
        self.started = now()
        self.joined: set[str] = set()  # token keys of the agents connected

    def note(self, token_key: str, alive: bool) -> None:
        if alive:
            self.joined.add(token_key)
        else:
            self.joined.discard(token_key)

    def _who(self) -> str:
        rovers = len(self.joined - {self.lander_key})
        lander = "the lander" if self.lander_key in self.joined else "not yet the lander"
        return f"{rovers}/{self.rovers} rover agents and {lander}"

    def waiting(self) -> str:
        return f"connecting: {self._who()} ({self.now() - self.started:.0f} s)"

    def done(self) -> str:
        return f"{self._who()} connected in {self.now() - self.started:.1f} s; clock running"


class ProgressView:
    """A refreshing table on a terminal; a plain line every few seconds in a log or CI."""

    def __init__(self, console: Console, title: str, quiet: bool = False,
                 now: Callable[[], float] = time.monotonic) -> None:
        self.console = console
        self.now = now
        self.title = title
        self.quiet = quiet
        self.live: Live | None = None
        self._last_line = 0.0
        self._started = False  # the start-up has been said

    def __enter__(self) -> ProgressView:
        if self.console.is_terminal and not self.quiet:
            self.live = Live(rover_table(None, None, self.title), console=self.console, refresh_per_second=4)
            self.live.__enter__()
        return self

    def update(self, state: m.WorldState | None, report: m.MissionReport | None, start_up: StartUp | None = None
               ) -> None:
        """``start_up``: shown while there is no state yet; once one comes, what connected is said once."""
        if start_up is not None and self._show_start_up(state, start_up):
            return
        if self.live is not None:
            self.live.update(rover_table(state, report, f"{self.title}  ·  t = {_stamp(state):.1f} s"))
        elif not self.quiet and state is not None and self.now() - self._last_line >= 5.0:
            self._last_line = self.now()
            finished = sum(r.state in ("done", "stuck") for r in state.rovers)
            self.console.print(f"t = {state.stamp:7.1f} s  finished {finished}/{len(state.rovers)}"
                               + (f"  collisions {report.rover_collisions + report.obstacle_collisions}"
                                  if report else ""))

    def _show_start_up(self, state: m.WorldState | None, start_up: StartUp) -> bool:
        """True while the start-up is what there is to show."""
        if self.quiet or self._started:
            return False
        if state is not None:
            self._started, self._last_line = True, 0.0
            self.console.print(start_up.done())  # above the live table, or a line of the log
            return False
        if self.live is not None:
            self.live.update(rover_table(None, None, f"{self.title}  ·  {start_up.waiting()}"))
        elif self.now() - self._last_line >= START_UP_LINE_PERIOD_S:
            self._last_line = self.now()
            self.console.print(start_up.waiting())
        return True

    def __exit__(self, *exc: object) -> None:
        if self.live is not None:
            self.live.__exit__(None, None, None)


def _stamp(state: m.WorldState | None) -> float:
    return state.stamp if state else 0.0
