"""``lunarsim report FILE.mcap``: the mission statistics (report 3.4.7) and a trajectory plot, from a
recording alone, with no live system."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from bus import process


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", type=Path, metavar="FILE.mcap", help="a session recorded by lunarsim run or record")
    parser.add_argument("--json", type=Path, metavar="OUT", help="write the statistics as JSON (report.json's "
                        "fields)")
    parser.add_argument("--plot", type=Path, metavar="PNG", help="trajectory plot (default: FILE.png beside "
                        "the recording)")
    parser.add_argument("--no-plot", action="store_true", help="do not draw the trajectory plot")
    parser.add_argument("--scenario", type=Path, metavar="FILE", help="scenario (default: the one the "
                        "recording embeds)")
    parser.add_argument("--world", help="world to report on (default: the recorded one)")


def run_from_args(args: argparse.Namespace) -> int:
    from mcap.exceptions import McapError
    from rich.console import Console

    from sessions.format import SESSION_METADATA, read_metadata, read_samples, scenario_for
    from sessions.report import NothingToReport, report_from_samples
    from sessions.summary import summary_table

    if not args.input.is_file():
        raise process.UsageError(f"{args.input}: no such file")
    scenario = scenario_for(args.input, args.scenario)
    if scenario is None:
        raise process.UsageError(f"{args.input} embeds no scenario (recorded without --scenario): pass "
                                 "--scenario FILE")
    world = args.world or read_metadata(args.input).get(SESSION_METADATA, {}).get("world", "default")
    try:
        report = report_from_samples(scenario, read_samples(args.input), world)
    except NothingToReport as exc:
        raise process.UsageError(f"{args.input}: {exc} (world {world!r}; pass --world?)") from None
    except McapError as exc:
        raise process.UsageError(f"{args.input}: damaged MCAP recording ({exc}); try 'lunarsim recover'") from None
    console = Console()
    console.print(summary_table(report))
    if args.json:
        args.json.write_text(json.dumps(report.model_dump(), indent=2) + "\n")
        console.print(f"statistics written to {args.json}")
    if not args.no_plot:
        from sessions.plot import draw_trajectories

        png = draw_trajectories(args.input, scenario, args.plot or args.input.with_suffix(".png"))
        console.print(f"trajectory plot written to {png}")
    return 0
