"""One batch.json and Table 2 from runs that other machines wrote (``lunarsim collect-batch``), such as the pods of
the Kubernetes Indexed Job (deploy/k8s/batch/job.yaml), each writing one run to a shared volume.

The run folders are named as ``deploy.batch`` names them, and the summary is written by the same code, so the table
is the one ``lunarsim batch`` prints for the same runs. What is wrong is named instead of failing the collection:
runs missing, reports unreadable, seeds that came twice.
"""

from __future__ import annotations

import contextlib
import re
from dataclasses import dataclass, field
from pathlib import Path

from bus import process
from deploy.batch import BATCH_FILE, read_run, summarise, table_console, write_summary

RUN_FOLDER = re.compile(r"run-(?P<run>\d+)-seed(?P<seed>-?\d+)")
"""What ``deploy.batch.run_folder`` names a run's folder."""


@dataclass
class Collected:
    """The runs of DIR sorted into what goes into the aggregate and what is named as wrong."""

    read: list[tuple[dict, Path]] = field(default_factory=list)
    failed: list[dict] = field(default_factory=list)
    missing: list[int] = field(default_factory=list)
    unreadable: list[str] = field(default_factory=list)
    duplicates: list[dict] = field(default_factory=list)

    @property
    def reports(self) -> list[dict]:
        return [report for report, _ in self.read]


def collect_batch(folder: Path, runs: int | None = None, out: Path | None = None) -> int:
    """Read the run folders in ``folder`` (``runs`` expected), write batch.json (to ``out``, default beside them) and
    print Table 2 with what is wrong named above it; 1 if no run had a readable report."""
    found = run_folders(folder)
    if not found:
        raise process.UsageError(f"{folder} holds no run folders (run-<NNN>-seed<S>): give the folder the Job "
                                 "wrote, /results/<job name>")
    expected = max(runs or 0, max(run for run, _, _ in found))  # a run past --runs is still a run
    collected = collect(found, expected)
    scenario, rovers = _mission(collected.reports, folder)
    summary = summarise(scenario, rovers, _lockstep(collected), collected.reports, collected.failed,
                        missing=collected.missing, unreadable=collected.unreadable,
                        duplicate_seeds=collected.duplicates)
    out = out or folder / BATCH_FILE
    console = table_console()
    console.print(f"{folder}: {len(collected.reports)} of {expected} runs in the aggregate", highlight=False)
    for item in collected.failed:
        console.print(f"  run {item['run']} (Job index {item['run'] - 1}, seed {_seed(item['seed'])}): "
                      f"{item['error']}", highlight=False, markup=False, soft_wrap=True)
    for item in collected.duplicates:
        console.print(f"  seed {item['seed']} came twice: kept {item['kept']}, left out "
                      f"{', '.join(item['left_out'])}", highlight=False, markup=False, soft_wrap=True)
    write_summary(out, summary, console)
    console.print(f"written {out}" + "".join(f"; {text}" for text in _problems(collected)), highlight=False,
                  markup=False, soft_wrap=True)
    return process.EXIT_FAILED if not collected.reports else 0


def run_folders(folder: Path) -> list[tuple[int, int, Path]]:
    """(run, seed, folder) of every run folder in ``folder``, by run number; other entries are not runs."""
    found = []
    for path in folder.iterdir():
        match = RUN_FOLDER.fullmatch(path.name)
        if match and path.is_dir():
            found.append((int(match["run"]), int(match["seed"]), path))
    return sorted(found, key=lambda item: (item[0], item[1]))


def collect(found: list[tuple[int, int, Path]], expected: int) -> Collected:
    """Read every run's report; a run that gives none is named with why, never raised, so that one bad pod does
    not cost the whole sweep its table."""
    result = Collected()
    for run, seed, path in found:
        try:
            result.read.append((read_run(path, run), path))
        except FileNotFoundError:
            result.missing.append(run)
            result.failed.append({"run": run, "seed": seed, "error": "no report.json: the run did not finish (its "
                                  "pod failed, or still runs); see its logs/"})
        except (OSError, ValueError) as exc:
            result.unreadable.append(path.name)
            result.failed.append({"run": run, "seed": seed, "error": f"report.json unreadable: {_why(exc)}"})
    bases = {seed - run for run, seed, _ in found}  # the Job's BASE_SEED - 1, when every folder agrees on it
    base = bases.pop() if len(bases) == 1 else None
    for run in sorted(set(range(1, expected + 1)) - {run for run, _, _ in found}):
        result.missing.append(run)
        result.failed.append({"run": run, "seed": None if base is None else base + run,
                              "error": f"no run folder (run-{run:03d}-seed*): the pod never started the run"})
    result.missing.sort()
    result.failed.sort(key=lambda item: item["run"])
    _drop_duplicate_seeds(result)
    return result


def _drop_duplicate_seeds(result: Collected) -> None:
    """A seed twice (an index re-run by hand into another folder, two Jobs' runs in one folder) would weigh twice
    in the means: the lowest run number stays, the others are named and left out."""
    by_seed: dict[int, list[tuple[dict, Path]]] = {}
    for report, path in result.read:
        by_seed.setdefault(report["seed"], []).append((report, path))
    left_out: set[Path] = set()
    for seed, runs in sorted(by_seed.items()):
        if len(runs) > 1:
            (_, kept), *others = sorted(runs, key=lambda item: item[0]["run"])
            result.duplicates.append({"seed": seed, "kept": kept.name, "left_out": [p.name for _, p in others]})
            left_out.update(p for _, p in others)
    result.read = [(report, path) for report, path in result.read if path not in left_out]


def _mission(reports: list[dict], folder: Path) -> tuple[str | None, int | None]:
    """The scenario and rover count every run shares; one table over different missions would mean nothing."""
    missions = sorted({(r["scenario"], r["rovers_total"]) for r in reports})
    if len(missions) > 1:
        listed = ", ".join(f"{name} ({rovers} rovers)" for name, rovers in missions)
        raise process.UsageError(f"{folder} holds runs of different missions: {listed}; collect each Job's folder "
                                 "on its own")
    return missions[0] if missions else (None, None)


def _lockstep(collected: Collected) -> bool | None:
    """Whether the runs had a lockstep clock, as batch.json says: report.json does not hold it, so it is read from
    each run's recording (its world's first clock tick). None when a run was not recorded or the runs differ."""
    values = {_recorded_lockstep(path) for _, path in collected.read}
    return values.pop() if len(values) == 1 else None


def _recorded_lockstep(folder: Path) -> bool | None:
    from deploy.launcher import SESSION_FILE
    from sessions.format import TopicFilter, decode, read_samples

    path = folder / SESSION_FILE
    if not path.is_file():
        return None
    try:
        with contextlib.closing(read_samples(path, TopicFilter(["*/world/clock"]))) as samples:
            first = next(samples, None)
        return None if first is None else bool(decode(first).lockstep)
    except Exception:  # the mcap reader raises many kinds; all mean a recording that cannot say
        return None


def _why(exc: Exception) -> str:
    """One line for a report that does not read: the report model's first complaint, the JSON parser's, or the
    system's."""
    import msgspec

    from schemas.codec import field_problem

    if isinstance(exc, OSError):
        return exc.strerror or str(exc)
    if isinstance(exc, msgspec.ValidationError):
        return field_problem(exc).replace("<root>", "the report", 1)
    return str(exc).splitlines()[0] if str(exc) else type(exc).__name__


def _seed(seed: int | None) -> str:
    return "unknown" if seed is None else str(seed)


def _problems(collected: Collected) -> list[str]:
    problems = []
    if collected.missing:
        problems.append(f"{len(collected.missing)} run(s) missing ({', '.join(map(str, collected.missing))})")
    if collected.unreadable:
        problems.append(f"{len(collected.unreadable)} report(s) unreadable ({', '.join(collected.unreadable)})")
    if collected.duplicates:
        seeds = ", ".join(str(item["seed"]) for item in collected.duplicates)
        problems.append(f"{len(collected.duplicates)} seed(s) twice ({seeds}): the later runs left out")
    return problems
