"""The mission report as a table for the terminal: what ``lunarsim run`` prints at the end and ``lunarsim report``
prints from a recording."""

from __future__ import annotations

from rich.table import Table

from schemas import messages as m


def summary_table(report: m.MissionReport) -> Table:
    table = Table(title=f"Mission report: {report.scenario} (seed {report.seed})", title_justify="left")
    table.add_column("statistic")
    table.add_column("value", justify="right")
    rows = [
        ("relative path length (m)", f"{report.relative_path_length_m:.2f}"),
        ("average distance covered (m)", f"{report.average_distance_covered_m:.2f}"),
        ("average path efficiency (report 3.4.7: every rover)", f"{report.average_path_efficiency:.3f}"
         + (" (above 1: rovers stopped short)" if report.average_path_efficiency > 1 else "")),
        ("path efficiency of the rovers that reached their goal", "-" if report.reached_path_efficiency is None
         else f"{report.reached_path_efficiency:.3f}"),
        ("total distance covered (m)", f"{report.total_distance_covered_m:.2f}"),
        ("rovers that reached final goal", f"{report.rovers_reached_final_goal}/{report.rovers_total}"
         + (f" ({report.rovers_holding_relay_spots} held daisy-chain spots instead)"
            if report.rovers_holding_relay_spots else "")),
        ("rover collisions", str(report.rover_collisions)),
        ("obstacle collisions", str(report.obstacle_collisions)),
        ("rovers stuck", str(report.rovers_stuck)),
        ("mission duration (sim s)", f"{report.mission_duration_s:.1f}"),
        ("wall time (s)", f"{report.wall_time_s:.1f}" if report.wall_time_s is not None else "- (from a recording)"),
        ("mission complete", "yes" if report.complete else "no (time limit or interrupted)"),
    ]
    if report.map_corridor_mapped is not None:
        found, precision = report.map_obstacles_found, report.map_obstacle_precision
        rows.append(("traverse map: corridor mapped / obstacles found / precision",
                     " / ".join("-" if v is None else f"{v:.0%}" for v in (report.map_corridor_mapped, found,
                                                                          precision))))
    if report.power_budget_efficiency is not None:  # the scenario has a sun
        rows += [("power budget efficiency", f"{report.power_budget_efficiency:.3f}"),
                 ("energy drawn (Wh)", f"{report.energy_used_wh:.4f}"),
                 ("battery / cold shutdowns", f"{report.power_shutdowns} / {report.cold_shutdowns}")]
    for row in rows:
        table.add_row(*row)
    return table
