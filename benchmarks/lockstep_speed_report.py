"""Prints the figures of ``lockstep_speed.py`` (also from its ``--json`` file: ``python
benchmarks/lockstep_speed_report.py FILE``)."""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path

import host

TARGETS = {"in_process": 60.0, "command": 25.0}
"""Real-time factors the 5-rover crater mission is held to: in process, and the whole command through processes."""
FOLD = "agents: traverse map"
"""The part an agent does once its answer is out (``RoverAgent.catch_up``)."""


def show(figures: dict, targets: dict[str, float] = TARGETS) -> None:
    print()
    print(host.line(figures["host"]))
    for path, title in (("in_process", "in process (harness.loopback.run_mission_agents)"),
                        ("command", "lunarsim run --lockstep, whole command (a process per rover)")):
        runs = figures[path]
        ratio = statistics.median(r["ratio"] for r in runs)
        each = ", ".join(f"{r['ratio']:.1f}" for r in runs)
        verdict = "PASS" if ratio >= targets[path] else "FAIL"
        print(f"{title}: median {ratio:.1f} x real time (runs: {each}); target {targets[path]:g} x: {verdict}")
    _phases(figures["command"])
    _ticks(figures["command"])
    _parts(figures["parts"])
    _perception(figures["parts"])


def _median(values: list[float]) -> float:
    return statistics.median(values) if values else float("nan")


def _phases(runs: list[dict]) -> None:
    names = sorted({name for r in runs for name in r["phases"]}, key=lambda n: _median(
        [r["phases"][n] for r in runs if n in r["phases"]]))
    shown = ", ".join(f"{name} {_median([r['phases'][name] for r in runs if name in r['phases']]):.2f}"
                      for name in names)
    print(f"lunarsim run phases (median s from the command's start): {shown}, command over "
          f"{_median([r['wall_s'] for r in runs]):.2f}")


def _ticks(runs: list[dict]) -> None:
    tallies = [r["tally"] for r in runs if r["tally"]]
    if not tallies:
        print("the world's ticks through processes: no lockstep summary in its log")
        return

    def per_tick(name: str) -> float:
        return _median([1000 * t[name] / t["ticks"] for t in tallies if name in t])

    waited = _median([t["ticks_waited"] / t["ticks"] for t in tallies])
    print(f"the world's ticks through processes (median ms a tick): mission {per_tick('mission_wall_s'):.3f}, "
          f"stepping {per_tick('stepping_s'):.3f}, publishing {per_tick('publishing_s'):.3f}, waiting for acks "
          f"{per_tick('waiting_s'):.3f} ({100 * waited:.0f}% of ticks wait), taking answers "
          f"{per_tick('taking_s'):.3f}")


def _parts(runs: list[dict]) -> None:
    wall = sum(r["wall_s"] for r in runs)
    ticks = sum(r["ticks"] for r in runs)
    totals: dict[str, float] = {}
    for r in runs:
        for part, s in r["parts"].items():
            totals[part] = totals.get(part, 0.0) + s
    print(f"in process, where the wall time goes ({ticks} ticks, {wall:.2f} s with the parts timed):")
    for part, s in sorted(totals.items(), key=lambda item: -item[1]):
        print(f"  {part:<52} {1000 * s / ticks:7.3f} ms a tick  {100 * s / wall:5.1f}%")


def _perception(runs: list[dict]) -> None:
    count = sum(r["perceptions"] for r in runs)
    if not count:
        return
    totals: dict[str, float] = {}
    for r in runs:
        for part, s in r["perception_parts"].items():
            totals[part] = totals.get(part, 0.0) + s
    total = sum(totals.values())
    shown = ", ".join(f"{part.removeprefix('agents: ')} {1000 * s / count:.3f}"
                      for part, s in sorted(totals.items(), key=lambda item: -item[1]))
    folded = sum(r["parts"].get(FOLD, 0.0) for r in runs)
    print(f"an agent's handling of one perception (in process, mean of {count}): {1000 * total / count:.3f} ms until "
          f"its answer is out: {shown}; then the traverse map {1000 * folded / count:.3f} ms")


if __name__ == "__main__":
    show(json.loads(Path(sys.argv[1]).read_text()))
