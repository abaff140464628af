"""What ``lunarsim run`` shows: a live table per rover while it runs, a summary table at the end."""

from __future__ import annotations

import time

from rich.console import Console
from rich.live import Live
from rich.table import Table

from schemas import messages as m


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


def summary_table(report: m.MissionReport) -> Table:
    table = Table(title=f"Mission report: {report.scenario} (seed {report.seed})", title_justify="left")
    table.add_column("statistic")
    table.add_column("value", justify="right")
    rows = [
        ("relative path length (m)", f"{report.relative_path_length_m:.2f}"),
        ("average distance covered (m)", f"{report.average_distance_covered_m:.2f}"),
        ("average path efficiency", f"{report.average_path_efficiency:.3f}"),
        ("total distance covered (m)", f"{report.total_distance_covered_m:.2f}"),
        ("rovers that reached final goal", f"{report.rovers_reached_final_goal}/{report.rovers_total}"),
        ("rover collisions", str(report.rover_collisions)),
        ("obstacle collisions", str(report.obstacle_collisions)),
        ("rovers stuck", str(report.rovers_stuck)),
        ("mission duration (sim s)", f"{report.mission_duration_s:.1f}"),
        ("wall time (s)", f"{report.wall_time_s:.1f}"),
        ("mission complete", "yes" if report.complete else "no (time limit or interrupted)"),
    ]
    if report.map_corridor_mapped is not None:
        found, precision = report.map_obstacles_found, report.map_obstacle_precision
        rows.append(("traverse map: corridor mapped / obstacles found / precision",
                     " / ".join("-" if v is None else f"{v:.0%}" for v in (report.map_corridor_mapped, found,
                                                                          precision))))
    if report.power_budget_efficiency is not None:  # the scenario has a sun (issue 8)
        rows += [("power budget efficiency", f"{report.power_budget_efficiency:.3f}"),
                 ("energy drawn (Wh)", f"{report.energy_used_wh:.4f}"),
                 ("battery / cold shutdowns", f"{report.power_shutdowns} / {report.cold_shutdowns}")]
    for row in rows:
        table.add_row(*row)
    return table


class ProgressView:
    """A refreshing table on a terminal; a plain line every few seconds in a log or CI."""

    def __init__(self, console: Console, title: str, quiet: bool = False) -> None:
        self.console = console
        self.title = title
        self.quiet = quiet
        self.live: Live | None = None
        self._last_line = 0.0

    def __enter__(self) -> ProgressView:
        if self.console.is_terminal and not self.quiet:
            self.live = Live(rover_table(None, None, self.title), console=self.console, refresh_per_second=4)
            self.live.__enter__()
        return self

    def update(self, state: m.WorldState | None, report: m.MissionReport | None) -> None:
        if self.live is not None:
            self.live.update(rover_table(state, report, f"{self.title}  ·  t = {_stamp(state):.1f} s"))
        elif not self.quiet and state is not None and time.monotonic() - self._last_line >= 5.0:
            self._last_line = time.monotonic()
            finished = sum(r.state in ("done", "stuck") for r in state.rovers)
            self.console.print(f"t = {state.stamp:7.1f} s  finished {finished}/{len(state.rovers)}"
                               + (f"  collisions {report.rover_collisions + report.obstacle_collisions}"
                                  if report else ""))

    def __exit__(self, *exc: object) -> None:
        if self.live is not None:
            self.live.__exit__(None, None, None)


def _stamp(state: m.WorldState | None) -> float:
    return state.stamp if state else 0.0
