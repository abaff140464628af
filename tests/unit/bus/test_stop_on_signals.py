"""A process of a mission stops when asked, even when its clean-up hangs: real processes, real signals."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[3]
PROCESS = """
import sys, threading, time
from bus import process
hang = sys.argv[1] == "hang"
with process.stop_on_signals(float(sys.argv[2])) as stop:
    print("ready", flush=True)
    stop.wait(60)
def clean_up_that_never_returns():
    threading.Event().wait()
if hang:
    clean_up_that_never_returns()
"""


def _stopped(clean_up: str, deadline_s: float, script: str = PROCESS) -> subprocess.CompletedProcess:
    """Start the process, wait until it is ready, send SIGTERM and wait for its end."""
    child = subprocess.Popen([sys.executable, "-c", script, clean_up, str(deadline_s)], cwd=REPO,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert child.stdout.readline() == "ready\n"
    child.send_signal(signal.SIGTERM)
    out, err = child.communicate(timeout=60)
    return subprocess.CompletedProcess(child.args, child.returncode, out, err)


def test_a_clean_up_that_hangs_ends_at_the_deadline_with_the_stack_that_hung() -> None:
    done = _stopped("hang", 1.0)
    assert done.returncode == 1
    assert "clean_up_that_never_returns" in done.stderr  # where it hung, in the process's log


def test_a_clean_up_that_returns_ends_the_process_normally_and_quietly() -> None:
    done = _stopped("quick", 1.0)
    assert done.returncode == 0
    assert done.stderr == ""


def test_a_deadline_armed_by_a_signal_does_not_end_the_clean_up_before_it() -> None:
    """A clean-up that takes a while, but less than the deadline, finishes and the process ends as it would
    without a watchdog (here: 0.5 s of work against 30 s)."""
    done = _stopped("hang", 30.0, PROCESS.replace("threading.Event().wait()", "time.sleep(0.5)"))
    assert done.returncode == 0, done.stderr
