"""``lunarsim export-foxglove``: a recording as Foxglove channels, to open in the Foxglove app.

Writes ``/scene`` (the static scene once, then the rovers, trails and radio links of every world state),
``/tf`` (world -> rover_<id>), ``/rover_<id>/photo`` (the PNG photos) and ``/map`` (the lander's traverse
map as a Grid), all in Foxglove's own protobuf schemas. The scenario comes from the recording's metadata
(``lunarsim record --scenario``) or ``--scenario``; without one only the moving parts are drawn.
``--keep-raw`` copies the original msgpack channels too, so one file serves both Foxglove and ``lunarsim`` tools.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from bus import paths, process


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", type=Path, metavar="IN.mcap", help="a LunarSim recording")
    parser.add_argument("-o", "--output", type=paths.new_file, required=True, metavar="OUT.mcap",
                        help="the Foxglove recording to write")
    parser.add_argument("--scenario", type=Path, metavar="FILE", help="scenario to draw (default: the one "
                        "embedded in the recording)")
    parser.add_argument("--keep-raw", action="store_true", help="also copy the original msgpack channels")
    parser.add_argument("--no-trails", action="store_true", help="do not draw the rovers' recent paths")
    parser.add_argument("--terrain-cells", type=int, default=128, metavar="N",
                        help="terrain mesh nodes along the longer side (default 128)")


def run(args: argparse.Namespace) -> int:
    from sessions.export_input import recording_to_export
    from sessions.foxglove_export import MAX_TERRAIN_CELLS, export_foxglove

    process.check_range("--terrain-cells", args.terrain_cells, 2, MAX_TERRAIN_CELLS)
    check_paths(args.input, args.output)
    recording, scenario = recording_to_export(args.input, args.scenario, "exporting without terrain and obstacles")
    counts = export_foxglove(recording, args.output, scenario, keep_raw=args.keep_raw,
                             trail_points=0 if args.no_trails else 300, terrain_cells=args.terrain_cells,
                             progress=sys.stderr.isatty())
    print(f"wrote {args.output}: " + ", ".join(f"{n} {what}" for what, n in counts.items()), flush=True)
    return 0


def check_paths(source: Path, target: Path) -> None:
    """Refuse an output that cannot work before any exists (the input is checked by ``check_recording``)."""
    if target.suffix != ".mcap":
        raise process.UsageError(f"{target}: the output file must end in .mcap")
    if target.exists() and target.resolve() == source.resolve():
        raise process.UsageError(f"{target}: the output would overwrite the input")
