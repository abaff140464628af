"""How many times faster than real time a lockstep mission runs, in one process and through processes, and where
its wall time goes.

- In process: ``harness.loopback.run_mission_agents`` (the world, the lander and the rover agents wired through
  their handlers, every sample through the codec; with no archive on disk its photos carry no pixels), timed
  alone for the ratio, then again with its parts timed (``tick_costs``): the world's step, perception,
  gyroscopes, the codec, the agents' estimator, planner and map, the lander, and the harness's routing; and the
  agents' handling of one perception, part by part.
- Through processes: ``lunarsim run SCENARIO --lockstep --no-record --quiet --seed N`` as a user runs it (a
  process per rover), timed as a whole, start-up included; the phases from its processes' logs (until the world
  listens, until every agent is there, until the clock starts, the mission, the way out), and the world's own
  account of the mission's ticks (``LockstepTally``: stepping, publishing, waiting for the agents' acks, taking
  their answers).

Ratios are simulated seconds over wall seconds. On a machine shared with other work they move with its load, so
compare the figures of one run (``--repeats`` interleaves the two paths), never across runs.

    python benchmarks/lockstep_speed.py [--seeds 1 2 3] [--repeats 1] [--json FILE]
    python benchmarks/lockstep_speed.py --quick    # one seed, 10 simulated seconds
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import host
import quick
import tick_costs

from harness.loopback import run_mission_agents
from schemas.scenario import Scenario, load_scenario
from world_service.commands.world import LISTENING

REPO = Path(__file__).resolve().parents[1]
SCENARIO = REPO / "scenarios" / "crater_observation.yaml"
QUICK = {"seeds": [1], "max_sim_time": 10.0}
PHASES = (("world listening", re.escape(LISTENING)), ("every agent there", r"every agent is there"),
          ("clock started", r"clock started"), ("mission over", r"^lockstep: "))
"""Milestones of the world's log, each timed from the command's start."""
TALLY = re.compile(r"lockstep: ([\d.]+) s simulated in ([\d.]+) s .*?; (\d+) ticks, (\d+) waited for acks "
                   r"\(([\d.]+) s\), stepping ([\d.]+) s(?:, publishing ([\d.]+) s)?(?:, taking answers ([\d.]+) s)?")


def in_process(scenario: Scenario, max_sim_time: float, parts: bool) -> dict:
    """One mission in process: its ratio, and with ``parts`` its wall time split by part."""
    if not parts:
        t0 = time.perf_counter()
        world, _ = run_mission_agents(scenario, max_sim_time)
        wall = time.perf_counter() - t0
        return {"sim_s": world.clock.sim_time, "wall_s": wall, "ratio": world.clock.sim_time / wall}
    with tick_costs.attributed() as tally:
        t0 = time.perf_counter()
        world, _ = run_mission_agents(scenario, max_sim_time)
        wall = time.perf_counter() - t0
    ticks = world.clock.tick
    return {"sim_s": world.clock.sim_time, "wall_s": wall, "ticks": ticks,
            "parts": {part: s for part, s, _ in tally.shares(wall)},
            "perceptions": tally.perceptions, "perception_parts": dict(tally.perception)}


def through_processes(scenario_file: Path, seed: int, max_sim_time: float | None, folder: Path) -> dict:
    """``lunarsim run`` as a user runs it, in ``folder``: the whole command's wall time, its phases, the world's
    account of its ticks."""
    out = folder / f"run-{seed}-{time.monotonic_ns()}"
    limit = ["--max-sim-time", str(max_sim_time)] if max_sim_time is not None else []
    port = _free_port()
    command = [sys.executable, "-m", "deploy.cli", "run", str(scenario_file), "--lockstep", "--no-record", "--quiet",
               "--seed", str(seed), "--out", str(out), "--port", str(port), *limit]
    started = time.time()
    t0 = time.perf_counter()
    proc = subprocess.run(command, cwd=folder, capture_output=True, text=True, timeout=900)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"lunarsim run exited {proc.returncode}:\n{(proc.stdout + proc.stderr)[-3000:]}")
    report = json.loads((out / "report.json").read_text())
    sim = report["mission_duration_s"]
    return {"sim_s": sim, "wall_s": wall, "ratio": sim / wall, "phases": _phases(out / "logs" / "world.log", started),
            "tally": _tally(out / "logs" / "world.log")}


def _phases(world_log: Path, started: float) -> dict[str, float]:
    found: dict[str, float] = {}
    for line in world_log.read_text(errors="replace").splitlines():
        stamp, _, message = _log_line(line)
        for name, pattern in PHASES:
            if stamp is not None and name not in found and re.search(pattern, message):
                found[name] = stamp - started
    return found


def _log_line(line: str) -> tuple[float | None, str, str]:
    match = re.match(r"(\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d{3}) (\S+) \w+: (.*)", line)
    if match is None:
        return None, "", line
    return dt.datetime.strptime(match[1], "%Y-%m-%d %H:%M:%S,%f").timestamp(), match[2], match[3]


def _tally(world_log: Path) -> dict[str, float]:
    match = TALLY.search(world_log.read_text(errors="replace"))
    if match is None:
        return {}
    names = ("sim_s", "mission_wall_s", "ticks", "ticks_waited", "waiting_s", "stepping_s", "publishing_s",
             "taking_s")
    return {name: float(value) for name, value in zip(names, match.groups(), strict=True) if value is not None}


def _free_port() -> int:
    import socket

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenario", type=Path, default=SCENARIO)
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--max-sim-time", type=float, default=None, help="cut each mission here (default: its end)")
    parser.add_argument("--repeats", type=int, default=1, help="runs of each seed on each path, interleaved")
    parser.add_argument("--json", type=Path)
    args = quick.parse_args(parser, QUICK, argv)
    scenario = load_scenario(args.scenario)
    cap = args.max_sim_time if args.max_sim_time is not None else 1800.0
    machine = host.describe()
    loop, command, parts = [], [], []
    with tempfile.TemporaryDirectory(prefix="lunarsim-lockstep-") as tmp:
        for _ in range(args.repeats):
            for seed in args.seeds:
                seeded = scenario.with_overrides(seed=seed)
                loop.append(in_process(seeded, cap, parts=False) | {"seed": seed})
                command.append(through_processes(args.scenario, seed, args.max_sim_time, Path(tmp)) | {"seed": seed})
                print(f"seed {seed}: in process {loop[-1]['ratio']:.1f}x, lunarsim run {command[-1]['ratio']:.1f}x "
                      f"({command[-1]['sim_s']:.1f} s simulated)", flush=True)
        for seed in args.seeds:
            parts.append(in_process(scenario.with_overrides(seed=seed), cap, parts=True))
    figures = {"host": machine, "code": host.code_version(), "scenario": str(args.scenario), "seeds": args.seeds,
               "in_process": loop, "command": command, "parts": parts}
    _print(figures)
    if args.json:
        args.json.write_text(json.dumps(figures, indent=1) + "\n")
    return 0


def _print(figures: dict) -> None:
    import lockstep_speed_report

    lockstep_speed_report.show(figures)


if __name__ == "__main__":
    sys.exit(main())
