"""``lunarsim export-rosbag``: a recording as a rosbag2 folder (MCAP storage, CDR) with the ROS 2 bridge's topics.

    lunarsim export-rosbag runs/<folder>/session.mcap -o runs/<folder>/rosbag

The same topics, types and frames as ``lunarsim ros2`` (``docs/reference/ros2.md``), plus ``/clock``, made by the
bridge's own mapping; ``ros2 bag info`` and ``ros2 bag play`` read the result. The perception rays' layout comes
from the scenario the recording embeds (or ``--scenario``). Ground truth (``/tf``, ``/rover_<id>/truth/odom``) only
with ``--truth``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bus import paths, process


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("input", type=Path, metavar="IN.mcap", help="a LunarSim recording")
    parser.add_argument("-o", "--output", type=paths.output_folder, required=True, metavar="DIR",
                        help="the rosbag2 folder to write (must not exist)")
    parser.add_argument("--scenario", type=Path, metavar="FILE", help="scenario of the recording (default: the "
                        "one it embeds): the perception rays' layout for scan")
    parser.add_argument("--truth", action="store_true", help="also write ground truth (/tf, /rover_<id>/truth/odom)")


def run(args: argparse.Namespace) -> int:
    from ros2_bridge.rosbag import export_recording
    from sessions.export_input import recording_to_export

    if args.output.exists():
        raise process.UsageError(f"{args.output}: already exists (a rosbag2 export writes a new folder)")
    recording, scenario = recording_to_export(args.input, args.scenario, "scan assumes the stock perception layout")
    counts, skipped = export_recording(recording, scenario.rover_params if scenario is not None else None,
                                       args.truth, args.output)
    print(f"wrote {args.output}: {sum(counts.values())} messages on {len(counts)} topics"
          + (f"; skipped {skipped} sample(s) it could not convert" if skipped else ""), flush=True)
    return 0
