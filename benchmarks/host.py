"""Which machine a benchmark ran on, and how fast its cores are, so figures from two machines are not compared as
if they came from one.

LunarSim's five-rover lockstep ran at 11.5-14x real time on one of this project's 2-core machines and, with the
code barely changed, at 24-26x on the next; nothing in the figures said why. ``reference_ns`` times a fixed
piece of pure Python (no LunarSim code, so it does not move when LunarSim gets faster): the ratio of two hosts'
figures says roughly how much of a change in the benchmark is the machine's.
"""

from __future__ import annotations

import statistics
import subprocess
import time
from pathlib import Path

REFERENCE_LOOPS = 2_000_000


def cpu_model() -> str:
    """The model name, with family and model numbers: a virtual machine's name is often only "AMD EPYC"."""
    try:
        text = Path("/proc/cpuinfo").read_text(encoding="utf-8")
    except OSError:
        return "unknown"
    first = dict(line.split(":", 1) for line in text.split("\n\n")[0].splitlines() if ":" in line)
    info = {k.strip(): v.strip() for k, v in first.items()}
    name = info.get("model name", "unknown")
    numbers = [f"{k} {info[k]}" for k in ("cpu family", "model", "stepping") if k in info]
    return f"{name} ({', '.join(numbers)})" if numbers else name


def reference_ns() -> float:
    """Nanoseconds per iteration of a fixed pure-Python loop."""
    t0 = time.perf_counter_ns()
    total = 0
    for i in range(REFERENCE_LOOPS):
        total += i * i % 7
    return (time.perf_counter_ns() - t0) / REFERENCE_LOOPS


def describe() -> dict:
    """For a benchmark's JSON: the CPU model and the reference loop's speed, the fastest of 5 runs (the least
    disturbed) and their median."""
    samples = [reference_ns() for _ in range(5)]
    return {"cpu_model": cpu_model(), "reference_loop_ns": round(min(samples), 2),
            "reference_loop_ns_median": round(statistics.median(samples), 2)}


def line(host: dict) -> str:
    return (f"host: {host['cpu_model']}; reference pure-Python loop {host['reference_loop_ns']:.1f} ns an iteration "
            "(benchmarks/host.py: compare it before comparing figures from two machines)")


def code_version() -> dict:
    """The commit measured, and files changed since it (a benchmark of a working tree says which one)."""
    repo = Path(__file__).resolve().parents[1]

    def git(*cmd: str) -> str:
        out = subprocess.run(["git", "-C", str(repo), *cmd], capture_output=True, text=True)
        return out.stdout.rstrip("\n") if out.returncode == 0 else ""  # porcelain lines start with a space

    changed = [line[3:] for line in git("status", "--porcelain", "--untracked-files=no").splitlines()]
    return {"commit": git("rev-parse", "--short", "HEAD"), "uncommitted_changes": changed}


if __name__ == "__main__":  # the machine's line alone, beside a figure measured without a benchmark (the suite's)
    print(line(describe()))
