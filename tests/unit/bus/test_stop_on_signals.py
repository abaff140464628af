"""A process of a mission stops when asked, even when its clean-up hangs: real processes, real signals."""

from __future__ import annotations

import queue
import signal
import subprocess
import sys
from pathlib import Path

import pytest

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


BLOCKED_ON_ITS_INBOX = """
import queue
from bus import process
from bus.bus import Inbox
inbox = Inbox()
with process.stop_on_signals(30.0) as stop:
    stop.also_wake(inbox.wake)
    print("ready", flush=True)
    try:
        inbox.get(timeout=600)
    except queue.Empty:
        print("woken", flush=True)
"""


def test_a_loop_blocked_on_its_inbox_wakes_when_signalled_not_at_its_timeout() -> None:
    """The lander's loop waits on its inbox, not on the stop event: without the wake it noticed SIGTERM only at
    its timeout, and every mission's way out waited that long for it (here the timeout is ten minutes)."""
    done = _stopped("quick", 30.0, BLOCKED_ON_ITS_INBOX)
    assert (done.returncode, done.stdout, done.stderr) == (0, "woken\n", "")


def test_a_wake_counts_as_one_timeout_and_leaves_the_inbox_as_it_was() -> None:
    from bus.bus import Inbox, Received
    from bus.process import Stop

    inbox, stop = Inbox(per_key=2), Stop()
    inbox.put(Received("a", b"1"))
    stop.set()
    stop.also_wake(inbox.wake)  # registered after the stop: wakes at once
    assert inbox.get(timeout=60) == Received("a", b"1")
    with pytest.raises(queue.Empty):
        inbox.get(timeout=60)
    for payload in (b"2", b"3", b"4"):  # the third is over the key's bound: the wake took no place in it
        inbox.put(Received("a", payload))
    assert inbox.qsize() == 2 and inbox.dropped["a"] == 1
    assert [inbox.get_nowait().payload for _ in range(2)] == [b"2", b"3"]
