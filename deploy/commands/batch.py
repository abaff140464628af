"""``lunarsim batch``: N seeded runs of a scenario, in parallel, summarised as the report's Table 2.

Each run is a whole ``lunarsim run`` (its own router port and world name) with seed BASE + i. Every
run's report and the aggregate go to ``DIR/batch.json``; a run that fails is recorded with the end of
its output, and the others go on. Beside Table 2's columns the table shows the radio: the worst rover's
share of the mission connected to the lander, the most rovers relaying at once, and the photos the lander
archived (``photos_at_lander``, counted from the run's ``lander_archive/index.jsonl``): the daisy chain's
figures.

--in-process runs each mission whole in one worker process (the world, the lander and the agents wired
without Zenoh), --jobs at a time: the same reports and table as --lockstep, several times faster, with
each run folder holding its report.json, the lander's archive and map, and no recording or logs.

Runs made elsewhere (the Kubernetes Indexed Job, one run per pod) get the same batch.json and table from
``lunarsim collect-batch``, which shares this command's folder names, report reading and summary.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from bus import paths


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", type=Path, help="scenario YAML (see scenarios/)")
    parser.add_argument("--runs", type=int, default=5, metavar="N", help="number of seeded runs (default 5)")
    parser.add_argument("--seed", type=int, default=1, metavar="BASE", help="seed of the first run (default 1)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, metavar="J", help="runs at a time")
    parser.add_argument("--lockstep", action="store_true", help="deterministic runs (recommended)")
    parser.add_argument("--in-process", action="store_true",
                        help="each run's world and agents in one worker process instead of a process each: the "
                             "same reports as --lockstep, several times faster; no recording or logs")
    parser.add_argument("--rovers", type=int, metavar="N", help="spawn N rovers in the scenario's formation")
    parser.add_argument("--params", type=Path, metavar="FILE", help="rover parameters (YAML) replacing the "
                        "scenario's rover_params, e.g. scenarios/params/report_defaults.yaml")
    parser.add_argument("--max-sim-time", type=float, default=900.0, metavar="S",
                        help="stop each run after S simulated seconds (default 900)")
    parser.add_argument("--time-scale", type=float, default=4.0, metavar="K", help="without --lockstep (default 4)")
    parser.add_argument("--out", type=paths.output_folder, required=True, metavar="DIR",
                        help="folder for the runs (one subfolder each) and batch.json")


def run(args: argparse.Namespace) -> int:
    from deploy.batch import BatchSpec, run_batch

    return run_batch(BatchSpec(args.scenario, args.out, runs=args.runs, seed=args.seed, jobs=args.jobs,
                               lockstep=args.lockstep, in_process=args.in_process, rovers=args.rovers,
                               params=args.params, max_sim_time=args.max_sim_time, time_scale=args.time_scale))
