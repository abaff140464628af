"""The allocator keeps freed array blocks: a process that makes and drops the same arrays stops faulting pages."""

from __future__ import annotations

import subprocess
import sys

import pytest

CHURN = """
import resource, sys
import numpy as np
from bus import heap
kept = heap.keep_freed_memory() if sys.argv[1] == "keep" else None
def churn():
    for _ in range(40):
        a = np.ones((600, 600)) * 2.0  # ~2.9 MB each, freed at once
        b = a + 1.0
        del a, b
churn()
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
churn()
print(kept, resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _faults(mode: str) -> tuple[str, int]:
    out = subprocess.run([sys.executable, "-c", CHURN, mode], capture_output=True, text=True, check=True).stdout
    kept, faults = out.split()
    return kept, int(faults)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's mallopt")
def test_kept_blocks_are_reused_without_faulting_fresh_pages():
    kept, faults_kept = _faults("keep")
    _, faults_default = _faults("default")
    assert kept == "True"
    assert faults_default > 40 * 600  # every array is fresh pages: ~700 faults each
    assert faults_kept < faults_default / 10
