"""CPU priority of the agents against the world (``bus.priority``); the processes' own classes are checked where
they start (test_warm_start, test_e2e_run, test_lockstep)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from bus import priority


def test_auto_yields_to_a_real_time_world_only_in_a_crowd() -> None:
    assert priority.for_mode("auto", lockstep=False, rovers=priority.CROWD) == "idle"
    assert priority.for_mode("auto", lockstep=False, rovers=5) == "equal"
    assert priority.for_mode("auto", lockstep=True, rovers=1000) == "equal"
    assert priority.for_camera(lockstep=False, rovers=priority.CROWD) == "low"
    assert priority.for_camera(lockstep=False, rovers=5) == priority.for_camera(lockstep=True, rovers=1000) == "equal"
    assert priority.for_mode("low", lockstep=True) == "low"
    with pytest.raises(ValueError, match="unknown priority 'high': expected one of auto, equal, low, idle"):
        priority.for_mode("high", lockstep=False)


LOWERED = """
import os, threading
from bus import priority
priority.lower({choice!r})
seen = []
thread = threading.Thread(target=lambda: seen.append((os.sched_getscheduler(0), os.getpriority(os.PRIO_PROCESS, 0))))
thread.start(); thread.join()
print(os.sched_getscheduler(0), os.getpriority(os.PRIO_PROCESS, 0), *seen[0])
"""


OWN = (os.sched_getscheduler(0), os.getpriority(os.PRIO_PROCESS, 0))  # what 'equal' leaves as it is


@pytest.mark.parametrize(("choice", "policy", "nice"), [("idle", os.SCHED_IDLE, OWN[1]), ("low", os.SCHED_BATCH, 19),
                                                         ("equal", *OWN)])
def test_lowering_holds_for_the_threads_started_after(choice: str, policy: int, nice: int) -> None:
    out = subprocess.run([sys.executable, "-c", LOWERED.format(choice=choice)], capture_output=True, text=True,
                         check=True).stdout.split()
    assert [int(v) for v in out] == [policy, nice, policy, nice]
