"""Hostile scenario files: how long ``load_scenario`` takes, and how much memory, until it refuses them.

Writes each file into a temporary folder, then loads it in a fresh Python (``schemas.scenario.load_scenario``,
as ``lunarsim scenario check`` and ``lunarsim run`` do), which reports the seconds from the call to the refusal
(and from the process's start), and its peak resident memory (``ru_maxrss``, the interpreter and its imports,
about 30 MB, included):

- 1,000,000 rovers in 24 MB: refused for its size before a byte is parsed;
- a FIFO: refused without waiting for a writer (a load still running after 30 s counts as hung);
- aliases ten deep, ten to a list (10**10 values from a few hundred bytes): refused once counted;
- the full run adds a valid file at the size bound (``MAX_SCENARIO_BYTES`` of listed rocks, accepted): what the
  largest file that is parsed costs.

    python benchmarks/scenario_load.py [--quick] [--json FILE]

Target: the 24 MB file refused in under 2 s and under 200 MB. The exit status is 1 if it is not, if a hostile file
is accepted, or if any load hangs; ``--quick`` leaves out the file at the size bound (about 3 s here).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from schemas.scenario_limits import MAX_SCENARIO_BYTES  # noqa: E402

TARGET_S = 2.0
TARGET_MB = 200.0
HUNG_S = 30.0
HEAD = "name: hostile\nlander: {x: 0.0, z: 0.0}\nmission:\n- {x: 1.0, z: 1.0}\n"
LOAD = """
import json, resource, sys, time
from schemas.scenario import ScenarioError, load_scenario
start = time.perf_counter()
try:
    load_scenario(sys.argv[1])
    said = "accepted"
except ScenarioError as exc:
    said = str(exc).splitlines()[0]
print(json.dumps({"seconds": time.perf_counter() - start, "said": said,
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""


def million_rovers(path: Path) -> None:
    with path.open("w") as f:
        f.write(HEAD + "rovers:\n")
        f.writelines("- {x: -510.0, z: 100.5}\n" for _ in range(1_000_000))


def fifo(path: Path) -> None:
    os.mkfifo(path)


def alias_bomb(path: Path) -> None:
    levels = [f"l0: &l0 [{', '.join(['1.0'] * 10)}]"]
    levels += [f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 10)}]" for i in range(1, 10)]
    path.write_text(HEAD + "bombs:\n" + "".join(f"  {level}\n" for level in levels)
                    + "rovers: [{x: 1.0, z: 1.0}]\nobstacles:\n  walls:\n  - points: *l9\n")


def rocks_at_the_bound(path: Path) -> None:
    line = "  - {x: -520.0, z: 75.0, radius_m: 1.2}\n"
    head = HEAD + "rovers: [{x: 1.0, z: 1.0}]\nobstacles:\n  rocks:\n"
    path.write_text(head + line * ((MAX_SCENARIO_BYTES - len(head)) // len(line)))


CASES: dict[str, Callable[[Path], None]] = {
    "1,000,000 rovers": million_rovers,
    "a FIFO": fifo,
    "aliases 10 deep": alias_bomb,
    "rocks at the size bound": rocks_at_the_bound,
}


def load(path: Path) -> dict:
    """``load_scenario(path)`` in a fresh Python: seconds, peak MB and the first line it said."""
    start = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-c", LOAD, str(path)], cwd=REPO, stdout=subprocess.PIPE, text=True)
    try:
        out, _ = proc.communicate(timeout=HUNG_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        return {"seconds": None, "said": f"hung: still loading after {HUNG_S:g} s", "peak_mb": None}
    return {**json.loads(out), "process_seconds": time.perf_counter() - start}

AT_BOUND = "rocks at the size bound"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="leave out the file at the size bound")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    args = parser.parse_args()
    names = [n for n in CASES if not (args.quick and n == AT_BOUND)]
    results = {}
    with tempfile.TemporaryDirectory() as folder:
        for name in names:
            path = Path(folder) / f"{name.replace(' ', '_').replace(',', '')}.yaml"
            CASES[name](path)
            size = path.stat().st_size if path.is_file() else 0
            results[name] = {"bytes": size, **load(path)}
            r = results[name]
            figures = "" if r["seconds"] is None else (f"{r['seconds']:.3f} s ({r['process_seconds']:.2f} s with "
                                                        f"Python's start), peak {r['peak_mb']:.0f} MB: ")
            print(f"{name} ({size / 1e6:.1f} MB): {figures}{r['said'][:160]}")
    main_case = results["1,000,000 rovers"]
    met = main_case["seconds"] is not None and main_case["seconds"] < TARGET_S and main_case["peak_mb"] < TARGET_MB
    refused = all(r["seconds"] is not None and (r["said"] != "accepted" or name == AT_BOUND)
                  for name, r in results.items())
    print(f"target (24 MB refused in < {TARGET_S:g} s, < {TARGET_MB:g} MB): {'met' if met else 'MISSED'}; "
          f"{'every hostile file refused' if refused else 'a hostile file was ACCEPTED, or a load HUNG'}")
    if args.json:
        args.json.write_text(json.dumps(results, indent=2) + "\n")
    return 0 if met and refused else 1


if __name__ == "__main__":
    sys.exit(main())
