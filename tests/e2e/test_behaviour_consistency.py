"""The behaviour suite's estimate-consistency figure: each rover's normalised estimation error squared (NEES) from a
real noisy mission, and its aggregate in the tables. No figure is judged here, only what must hold of any
covariance: the truth's Mahalanobis distance is at least its distance over the root of the covariance's trace."""

from __future__ import annotations

import logging
import sys
from pathlib import Path

from procs import REPO

# benchmarks/ is not a package (its scripts import each other by name), and behaviour_suite puts it first on the path
# as it is imported. Off the path again after the imports: its ros2_bridge.py would hide the ros2_bridge package from
# the tests that run after this one in the same worker (even last on the path, under an editable install)
sys.path.append(str(REPO / "benchmarks"))

from behaviour_suite import run_one
from behaviour_tables import NEES_GATES, consistency, summarise

sys.path[:] = [p for p in sys.path if Path(p).resolve() != (REPO / "benchmarks").resolve()]

NOISY_SEED = 4
"""A small high-noise traverse of the generator: every rover walks with an uncertain estimate."""


def test_each_rovers_nees_bounds_its_error_over_its_one_sigma_and_the_tables_count_it() -> None:
    try:
        row = run_one(NOISY_SEED, None, cap_s=120.0)
    finally:
        logging.disable(logging.NOTSET)  # run_one silences warnings for its worker process: not for later tests here
    assert "error" not in row and row["classes"]["noise"] == "high"
    rovers = row["rovers"]
    assert rovers and all(r["estimate_nees"] is not None for r in rovers)
    for r in rovers:
        bound = (r["estimate_error_m"] / r["estimate_std_m"]) ** 2
        assert r["estimate_nees"] >= bound * (1 - 1e-3) - 1e-3, r
    figures = summarise([row])
    assert figures["nees_rovers"] == len(rovers)
    low, _ = NEES_GATES
    assert figures["nees_beyond_99"] == round(sum(r["estimate_nees"] > low for r in rovers) / len(rovers), 4)
    assert figures["nees_beyond_999"] <= figures["nees_beyond_99"]


def test_runs_saved_before_the_figure_have_none() -> None:
    assert consistency([{"estimate_error_m": 1.0}]) == {"nees_rovers": 0, "nees_mean": None,
                                                        "nees_beyond_99": None, "nees_beyond_999": None}
