"""``lunarsim scenario list|import|export|check|generate``: the shipped scenarios, the report's editor profiles,
scenario validation and seeded scenarios drawn by ``scenarios.generator``.

Wherever a command takes a scenario file, a shipped scenario's bare name does too (``lunarsim run maze``)."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from bus import paths, process


def add_arguments(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    """The command's arguments; returns the parsers of its own subcommands, by name."""
    sub = parser.add_subparsers(dest="scenario_command", required=True,
                                metavar="{list,import,export,check,generate}")
    listing = sub.add_parser("list", help="the scenarios that come with LunarSim, by the name any command takes")
    imp = sub.add_parser("import", help="scenario YAML from a LunarSim scenario-editor profile (JSON)")
    imp.add_argument("profile", type=Path, help="the editor profile (JSON)")
    imp.add_argument("-o", "--output", type=paths.new_file, required=True,
                     metavar="FILE.yaml", help="the scenario to write")
    imp.add_argument("--name", help="scenario name (default: the profile's file name)")
    imp.add_argument("--seed", type=int, default=0, help="the scenario's seed (default 0)")
    exp = sub.add_parser("export", help="scenario-editor profile (JSON) from a scenario YAML")
    exp.add_argument("scenario", type=Path, help="scenario YAML")
    exp.add_argument("-o", "--output", type=paths.new_file, required=True,
                     metavar="FILE.json", help="the profile to write")
    chk = sub.add_parser("check", help="validate a scenario file, and the terrain mesh and behaviour it names; "
                         "summarise it")
    chk.add_argument("scenario", type=Path, help="scenario YAML")
    gen = sub.add_parser("generate", help="a varied, valid mission drawn from a seed (scenarios/generator.py)")
    gen.add_argument("--seed", type=int, required=True, metavar="N", help="the same seed gives the same scenario")
    gen.add_argument("--kind", help="the family: crater, traverse, maze or daisy (default: drawn from the seed "
                     "too); checked by the generator, which lists them")
    gen.add_argument("-o", "--output", type=paths.new_file, required=True,
                     metavar="FILE.yaml", help="the scenario to write")
    return {"list": listing, "import": imp, "export": exp, "check": chk, "generate": gen}


def run(args: argparse.Namespace) -> int:
    from deploy.scenario_check import check_files
    from scenarios.profiles import load_profile, scenario_to_profile
    from schemas.scenario import dump_scenario, load_scenario

    if args.scenario_command == "list":
        _list()
    elif args.scenario_command == "import":
        scenario = load_profile(args.profile, args.name).with_overrides(seed=args.seed)
        args.output.write_text(dump_scenario(scenario))
        print(f"wrote {args.output}: {len(scenario.rovers)} rovers, {len(scenario.craters)} craters, "
              f"{len(scenario.mission)} goals")
    elif args.scenario_command == "export":
        args.output.write_text(json.dumps(scenario_to_profile(load_scenario(args.scenario))) + "\n")
        print(f"wrote {args.output} (profiles carry no obstacles, terrain or parameters)", file=sys.stderr)
    elif args.scenario_command == "generate":
        _generate(args)
    else:
        s = load_scenario(args.scenario)
        check_files(args.scenario, s)
        print(f"{args.scenario}: ok: {s.name!r}, seed {s.seed}, {len(s.rovers)} rovers, {len(s.craters)} craters, "
              f"{len(s.obstacles.rocks) + sum(f.count for f in s.obstacles.rock_fields)} rocks, "
              f"{len(s.obstacles.walls)} walls, {len(s.mission)} goals")
    return 0


def _list() -> None:
    from schemas.scenario import load_scenario, shipped_scenarios

    for name, path in shipped_scenarios().items():
        s = load_scenario(path)
        kinds = ", ".join(dict.fromkeys(g.kind for g in s.mission))
        print(f"{name:<20} {len(s.rovers):>3} rover(s), {len(s.mission)} goal(s) ({kinds})   {path}")


def _generate(args: argparse.Namespace) -> None:
    from scenarios.generator import generate
    from schemas.scenario import dump_scenario

    try:
        made = generate(args.seed, args.kind)
    except ValueError as exc:
        raise process.UsageError(str(exc)) from None
    s = made.scenario
    head = [f"lunarsim scenario generate --seed {args.seed}" + (f" --kind {args.kind}" if args.kind else ""),
            "classes: " + ", ".join(f"{k}={v}" for k, v in made.classes.items())]
    head += [f"rovers {what}: {', '.join(map(str, ids))}" for what, ids in
             (("starting in a crater", made.in_crater), ("out of radio range", made.out_of_range)) if ids]
    args.output.write_text("".join(f"# {line}\n" for line in head) + dump_scenario(s))
    print(f"wrote {args.output}: {s.name!r}, {len(s.rovers)} rovers, {len(s.mission)} goals; "
          + " ".join(f"{k}={v}" for k, v in made.classes.items()))
