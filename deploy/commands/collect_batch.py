"""``lunarsim collect-batch``: one batch.json and Table 2 from runs that other machines wrote, such as the pods of
the Kubernetes Indexed Job (deploy/k8s/batch/job.yaml), each writing one run to a shared volume.

DIR holds a folder per run, run-<NNN>-seed<S>: NNN is the Job's index + 1, as lunarsim batch numbers its runs,
so the collector reads either's folders. It writes DIR/batch.json and prints the table as lunarsim batch does
for the same runs (the same code writes both), and names what is wrong instead of failing on it:

- runs missing: no folder (the pod never started the run), or a folder without report.json (its pod failed,
  or is still running); give --runs to see a missing last run too;
- reports unreadable (cut short, edited, not a mission report): counted, named, left out;
- seeds that came twice: the lowest run number is kept, the others are left out of the aggregate.

    lunarsim collect-batch /results/lunarsim-batch-x7k2p --runs 20

Exit status: 0 batch.json written (problems named above the table), 1 no run had a readable report, 2 bad input
(DIR is not a folder or holds no run folder, --runs below 1, runs of different missions in one DIR).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bus import paths, process


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("folder", type=Path, metavar="DIR",
                        help="the folder of the runs: a Job's /results/<job name>, or a lunarsim batch --out")
    parser.add_argument("--runs", type=int, metavar="N", help="runs expected (the Job's completions), so that a "
                        "missing last run is named too (default: up to the highest run number found)")
    parser.add_argument("--out", type=paths.output_file,
                        metavar="FILE", help="where to write batch.json (default DIR/batch.json)")


def run(args: argparse.Namespace) -> int:
    from deploy.batch import MAX_RUNS
    from deploy.batch_collect import collect_batch

    if args.runs is not None:
        process.check_range("--runs", args.runs, 1, MAX_RUNS)
    if not args.folder.is_dir():
        raise process.UsageError(f"{args.folder}: no such folder")
    return collect_batch(args.folder, args.runs, args.out)
