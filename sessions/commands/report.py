"""``lunarsim report FILE.mcap``: the mission statistics (report 3.4.7) and a trajectory plot, from a
recording alone, with no live system. What the file cannot vouch for (channels skipped, samples that do not decode,
a lander map that is not the scenario's grid, gaps the recorder noted) is said below the table."""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING

import msgspec

from bus import paths, process
from schemas.scenario_limits import clip

if TYPE_CHECKING:
    from sessions.recording import Recording


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", type=Path, metavar="FILE.mcap", help="a session recorded by lunarsim run or record")
    parser.add_argument("--json", type=paths.output_file,
                        metavar="OUT", help="write the statistics as JSON (report.json's "
                        "fields)")
    parser.add_argument("--plot", type=paths.output_file,
                        metavar="PNG", help="trajectory plot (default: FILE.png beside "
                        "the recording)")
    parser.add_argument("--no-plot", action="store_true", help="do not draw the trajectory plot")
    parser.add_argument("--scenario", type=Path, metavar="FILE", help="scenario (default: the one the "
                        "recording embeds)")
    parser.add_argument("--world", help="world to report on (default: the recorded one)")


def run(args: argparse.Namespace) -> int:
    from rich.console import Console

    from schemas.scenario import load_scenario
    from sessions.format import embedded_scenario
    from sessions.recording import check_recording
    from sessions.report import NothingToReport, report_from_samples
    from sessions.summary import summary_table

    if args.plot is not None and args.plot.suffix.lower() != ".png":
        raise process.UsageError(f"--plot {clip(str(args.plot))}: the plot is a PNG; give a path ending in .png")

    recording = check_recording(args.input)
    scenario = load_scenario(args.scenario) if args.scenario else embedded_scenario(recording.metadata,
                                                                                     str(args.input))
    if scenario is None:
        raise process.UsageError(f"{args.input} embeds no scenario (recorded without --scenario): pass "
                                 "--scenario FILE")
    world = args.world or recording.world or "default"
    malformed: Counter[str] = Counter()
    try:
        report = report_from_samples(scenario, recording.samples(), world, malformed)
    except NothingToReport as exc:
        raise process.UsageError(f"{args.input}: {exc} (world {world!r}; pass --world?)") from None
    console = Console()
    console.print(summary_table(report))
    for note in _notes(recording, malformed):
        print(f"warning: {note}", flush=True)
    if args.json:
        args.json.write_text(json.dumps(msgspec.to_builtins(report), indent=2) + "\n")
        console.print(f"statistics written to {args.json}")
    if not args.no_plot:
        from sessions.plot import draw_trajectories

        png = draw_trajectories(recording.samples(), scenario, args.plot or args.input.with_suffix(".png"))
        console.print(f"trajectory plot written to {png}")
    return 0


def _notes(recording: Recording, malformed: Counter[str]) -> list[str]:
    """What the figures above do not cover, one line each."""
    gaps = recording.gap_note()
    notes = [note for note in (recording.foreign_note(), gaps and f"{gaps}: the figures hold only what was recorded")
             if note]
    if malformed:
        notes.append(f"{recording.path}: skipped {sum(malformed.values())} malformed samples "
                     f"({', '.join(sorted(malformed))})")
    return notes
