"""``lunarsim scenario import|export|check``: the report's editor profiles and scenario validation."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="scenario_command", required=True, metavar="{import,export,check}")
    imp = sub.add_parser("import", help="scenario YAML from a LunarSim scenario-editor profile (JSON)")
    imp.add_argument("profile", type=Path)
    imp.add_argument("-o", "--output", type=Path, required=True, metavar="FILE.yaml")
    imp.add_argument("--name", help="scenario name (default: the profile's file name)")
    imp.add_argument("--seed", type=int, default=0)
    exp = sub.add_parser("export", help="scenario-editor profile (JSON) from a scenario YAML")
    exp.add_argument("scenario", type=Path)
    exp.add_argument("-o", "--output", type=Path, required=True, metavar="FILE.json")
    chk = sub.add_parser("check", help="validate a scenario file and summarise it")
    chk.add_argument("scenario", type=Path)


def run_from_args(args: argparse.Namespace) -> int:
    from schemas.profiles import load_profile, scenario_to_profile
    from schemas.scenario import dump_scenario, load_scenario

    if args.scenario_command == "import":
        scenario = load_profile(args.profile, args.name).with_overrides(seed=args.seed)
        args.output.write_text(dump_scenario(scenario))
        print(f"wrote {args.output}: {len(scenario.rovers)} rovers, {len(scenario.craters)} craters, "
              f"{len(scenario.mission)} goals")
    elif args.scenario_command == "export":
        args.output.write_text(json.dumps(scenario_to_profile(load_scenario(args.scenario))) + "\n")
        print(f"wrote {args.output} (profiles carry no obstacles, terrain or parameters)", file=sys.stderr)
    else:
        s = load_scenario(args.scenario)
        print(f"{args.scenario}: ok: {s.name!r}, seed {s.seed}, {len(s.rovers)} rovers, {len(s.craters)} craters, "
              f"{len(s.obstacles.rocks)} rocks, {len(s.obstacles.walls)} walls, {len(s.mission)} goals")
    return 0
