"""Where the test suite's time goes: the README's test command run under a /proc poll, its CPU by kind of process.

The suite starts thousands of processes (worlds, agents, routers, recorders, browsers, commands) from its pytest
workers, so ``pytest --durations`` says which tests are long but not what they spend their cores on. This runs
``pytest`` (or the arguments after ``--``) and, every ``--interval`` seconds, reads each new process's CPU time and
command line from /proc, then groups the processes by kind. Three totals frame the table: the CPU the process tree's
parents collected (ours once pytest is waited for; a process its parent never waited for is missing from it), what
the poll saw of the tree (a process shorter than the interval, and the last interval of each, are missed), and how
much of the machine's CPU time went idle meanwhile (/proc/stat: a suite that leaves cores idle waits on wall
clocks, not on work).

    python benchmarks/suite_cpu.py [--json FILE] [--interval S] [-- PYTEST ARGS]
    python benchmarks/suite_cpu.py -- -n 2    # the suite on two workers instead of the configured three
    python benchmarks/suite_cpu.py --quick     # one small test module, in one process: the same path in seconds
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import quick
from proc_meter import machine_cpu_seconds, proc_stat, stat_cpu_seconds

REPO = Path(__file__).resolve().parents[1]
QUICK = {"interval": 0.1,
         "pytest_args": ["-q", "-p", "no:cacheprovider", "-n", "0", "tests/unit/schemas/test_keyspace.py"]}
KINDS = (
    ("pytest worker", r"exec\(eval\(sys\.stdin\.readline|^\[pytest-xdist"),
    ("pytest", r"^\S*python\S*( -\S+)* (-m |\S*/)pytest\b|^\S*/pytest\b"),  # anchored: tests' paths hold "pytest-of-"
    ("world", r"-m world_service|world_service\b"),
    ("camera", r"^lunarsim camera"),
    ("lander", r"-m lander_agent|lunarsim-lander"),
    ("rover agent", r"-m rover_agent|lunarsim-rover|multiprocessing\.forkserver"),
    ("recorder", r"deploy\.cli record|lunarsim record"),
    ("router", r"deploy\.router|zenohd"),
    ("ROS 2 bridge", r"ros2_bridge"),
    ("lunarsim command", r"deploy\.cli|/lunarsim\b"),
    ("benchmark script", r"benchmarks/"),
    ("browser", r"chrom|headless_shell|playwright|^/proc/self/exe"),
    ("other Python", r"python"),
)
"""Kinds of process, first match of the command line wins; anything else is grouped by its program's name."""


@dataclass
class Seen:
    cmd: str
    cpu_s: float = 0.0


@dataclass
class Poll:
    """The CPU time and command line of every process under ``root``, from repeated reads of /proc. A process joins
    when its parent is in the tree; one whose parent ended before a read saw both is missed."""

    root: int
    tree: set[int] = field(default_factory=set)
    seen: dict[tuple[int, int], Seen] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.tree.add(self.root)

    def read(self) -> None:
        found: dict[int, tuple[int, int, float, str]] = {}
        for entry in os.scandir("/proc"):
            if not entry.name.isdigit():
                continue
            try:
                _, fields = proc_stat(int(entry.name))
                cmd = Path(entry.path, "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace").strip()
            except OSError:
                continue  # gone meanwhile
            found[int(entry.name)] = (int(fields[1]), int(fields[19]), stat_cpu_seconds(fields), cmd)
        joined = True
        while joined:  # a child may come before its parent in the listing
            joined = False
            for pid, (parent, _, _, _) in found.items():
                if pid not in self.tree and parent in self.tree:
                    self.tree.add(pid)
                    joined = True
        self.tree &= found.keys() | {self.root}  # an ended process's pid may be given to one outside the tree
        for pid in self.tree & found.keys():
            _, started, cpu_s, cmd = found[pid]
            process = self.seen.setdefault((pid, started), Seen(cmd))
            process.cmd = process.cmd or cmd  # a process that has exited shows no command line
            process.cpu_s = cpu_s


def kind(cmd: str) -> str:
    for name, pattern in KINDS:
        if re.search(pattern, cmd):
            return name
    return Path(cmd.split(" ", 1)[0]).name or "(no command line seen)"


def run(pytest_args: list[str], interval: float) -> dict:
    busy0, stolen0 = machine_cpu_seconds()
    children0 = os.times()
    started = time.monotonic()
    suite = subprocess.Popen([sys.executable, "-m", "pytest", *pytest_args], cwd=REPO, stdout=subprocess.PIPE,
                             stderr=subprocess.STDOUT, text=True)
    poll = Poll(root=suite.pid)
    output: list[str] = []
    reader = _reader(suite, output)
    while suite.poll() is None:
        poll.read()
        time.sleep(interval)
    reader.join()
    wall = time.monotonic() - started
    busy1, stolen1 = machine_cpu_seconds()
    children1 = os.times()
    tree = (children1.children_user - children0.children_user) + (children1.children_system - children0.children_system)
    by_kind: dict[str, dict[str, float]] = {}
    for process in poll.seen.values():
        row = by_kind.setdefault(kind(process.cmd), {"cpu_s": 0.0, "processes": 0})
        row["cpu_s"] += process.cpu_s
        row["processes"] += 1
    summary = next((line for line in reversed(output) if re.search(r"\d+ (passed|failed)", line)), "")
    return {"pytest_args": pytest_args, "exit": suite.returncode, "summary": summary.strip(" ="),
            "wall_s": round(wall, 1), "tree_cpu_s": round(tree, 1),
            "seen_cpu_s": round(sum(r["cpu_s"] for r in by_kind.values()), 1),
            "machine_cpu_s": round(wall * os.cpu_count(), 1),
            "idle_share": round(max(0.0, 1 - (busy1 - busy0 + stolen1 - stolen0) / (wall * os.cpu_count())), 3),
            "cores": os.cpu_count(), "by_kind": dict(sorted(by_kind.items(), key=lambda kv: -kv[1]["cpu_s"])),
            "processes": [[round(p.cpu_s, 2), p.cmd[:300]] for p in poll.seen.values()]}


def _reader(suite: subprocess.Popen, output: list[str]) -> threading.Thread:
    """Keeps pytest's output (its pipe must not fill while the poll runs)."""

    def read() -> None:
        for line in suite.stdout:
            output.append(line.rstrip("\n"))

    thread = threading.Thread(target=read, daemon=True)
    thread.start()
    return thread


def report(figures: dict) -> None:
    f = figures
    print(f"pytest {' '.join(f['pytest_args']) or '(the README command)'}: {f['summary'] or 'no summary'} "
          f"(exit {f['exit']})")
    print(f"wall {f['wall_s']:.1f} s on {f['cores']} cores; the process tree used {f['tree_cpu_s']:.1f} CPU s, the "
          f"poll saw {f['seen_cpu_s']:.1f}; the machine was idle {f['idle_share']:.0%} of its {f['machine_cpu_s']:.1f} "
          f"CPU s")
    print(f"{'kind':<24}{'CPU s':>9}{'share':>8}{'processes':>11}")
    total = f["seen_cpu_s"] or 1.0
    for name, row in f["by_kind"].items():
        print(f"{name:<24}{row['cpu_s']:>9.1f}{row['cpu_s'] / total:>8.1%}{row['processes']:>11}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--interval", type=float, default=0.2, help="seconds between reads of /proc")
    parser.add_argument("--json", type=Path, metavar="FILE", help="also write the figures here")
    parser.add_argument("pytest_args", nargs="*", default=[], metavar="-- PYTEST ARGS",
                        help="arguments for pytest (default: none, as the README runs it)")
    args = quick.parse_args(parser, QUICK)
    if args.interval <= 0:
        parser.error("--interval must be more than 0")
    figures = run(args.pytest_args, args.interval)
    report(figures)
    if args.json:
        args.json.write_text(json.dumps(figures, indent=2) + "\n")
    return 0 if figures["exit"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
