"""The control-loop benchmark's figures: nearest-rank percentiles of round trips, the table it prints, its JSON and
the targets it judges them by (``benchmarks/control_loop_latency.py``; the scale benchmark uses the summary too)."""

from __future__ import annotations

import argparse
import json
import math
import platform
from dataclasses import dataclass
from pathlib import Path

TARGET_P50_MS = 1.0
TARGET_P99_MS = 5.0
TARGET_RATIO = 1.2
"""The control loop's p50 and p99 within this many times the bare Zenoh floor's, measured in the same run."""


@dataclass(frozen=True)
class Summary:
    loops: int
    p50_ms: float
    p90_ms: float
    p99_ms: float
    max_ms: float
    mean_ms: float

    @classmethod
    def of(cls, samples_ns: list[int]) -> Summary:
        s = sorted(samples_ns)
        return cls(len(s), _ms(_percentile(s, 50)), _ms(_percentile(s, 90)), _ms(_percentile(s, 99)),
                   _ms(s[-1]), _ms(sum(s) / len(s)))


def _percentile(sorted_ns: list[int], p: float) -> int:
    """Nearest-rank percentile: the smallest sample with at least p % of the samples at or below it."""
    rank = max(1, math.ceil(p / 100 * len(sorted_ns)))
    return sorted_ns[rank - 1]


def _ms(ns: float) -> float:
    return ns / 1e6


def verdict(value: float, target: float) -> str:
    return "PASS" if value < target else "FAIL"


def ratios(loop: Summary, floor: Summary) -> dict[str, float]:
    """The control loop's p50 and p99 over the floor's (infinite for a floor too fast for the clock to see)."""
    return {"p50": loop.p50_ms / floor.p50_ms if floor.p50_ms > 0 else math.inf,
            "p99": loop.p99_ms / floor.p99_ms if floor.p99_ms > 0 else math.inf}


def print_table(zenoh_summary: Summary, floor: Summary, local: Summary, endpoint: str, missed: int,
                args: argparse.Namespace, rover_id: int) -> None:
    rows = [("over Zenoh (world -> router -> rover -> router -> world)", zenoh_summary),
            ("bare Zenoh floor (ping -> router -> echo -> router -> pong)", floor),
            ("agent only, in process (decode + decide + encode)", local)]
    print(f"\nControl-loop latency: Perception -> MoveAction, rover {rover_id}, router {endpoint}, "
          f"{args.warmup} warm-up loops not counted, {args.gap_ms:g} ms idle gap between loops, "
          f"{'no state file' if args.no_state else 'its state kept in a file'}")
    print(f"{'':60}{'loops':>7}{'p50':>9}{'p90':>9}{'p99':>9}{'max':>9}{'mean':>9}   (ms)")
    for label, s in rows:
        print(f"{label:60}{s.loops:>7}{s.p50_ms:>9.3f}{s.p90_ms:>9.3f}{s.p99_ms:>9.3f}{s.max_ms:>9.3f}"
              f"{s.mean_ms:>9.3f}")
    z = zenoh_summary
    print(f"\nTarget p50 < {TARGET_P50_MS:g} ms: {z.p50_ms:.3f} ms  {verdict(z.p50_ms, TARGET_P50_MS)}")
    print(f"Target p99 < {TARGET_P99_MS:g} ms: {z.p99_ms:.3f} ms  {verdict(z.p99_ms, TARGET_P99_MS)}")
    for key, ratio in ratios(z, floor).items():
        print(f"Target {key} within {TARGET_RATIO:g}x the floor: {ratio:.2f}x  {verdict(ratio, TARGET_RATIO)}")
    print(f"Perceptions the rover ignored (it took them before the previous NavigationStatus/Gyroscope; "
          f"a fresh one was sent after {args.stall_ms:g} ms): {missed}")
    if z.p50_ms > 0:
        print(f"Agent share of the median round trip: {100 * local.p50_ms / z.p50_ms:.0f} %")


def write_json(path: Path, zenoh_summary: Summary, floor: Summary, local: Summary, args: argparse.Namespace,
               endpoint: str, missed: int) -> None:
    ratio = ratios(zenoh_summary, floor)
    doc = {
        "benchmark": "control_loop_latency",
        "endpoint": endpoint,
        "loops": args.loops,
        "warmup": args.warmup,
        "gap_ms": args.gap_ms,
        "stall_ms": args.stall_ms,
        "state_file": not args.no_state,
        "missed_perceptions": missed,
        "python": platform.python_version(),
        "platform": platform.platform(),
        "zenoh": vars(zenoh_summary),
        "floor": vars(floor),
        "ratio_to_floor": ratio,
        "in_process": vars(local),
        "targets": {
            "p50_ms": TARGET_P50_MS, "p99_ms": TARGET_P99_MS, "ratio": TARGET_RATIO,
            "p50_pass": zenoh_summary.p50_ms < TARGET_P50_MS, "p99_pass": zenoh_summary.p99_ms < TARGET_P99_MS,
            "p50_ratio_pass": ratio["p50"] < TARGET_RATIO, "p99_ratio_pass": ratio["p99"] < TARGET_RATIO,
        },
    }
    path.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
