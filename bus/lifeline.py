"""Child processes end with their parent, even when the parent is killed with SIGKILL and cannot stop them.

Two mechanisms, for two kinds of child:
- ``die_with_parent``: Linux sends the child SIGTERM when the thread that started it ends (``PR_SET_PDEATHSIG``).
  For children started from a process's main thread, which lives as long as the process: ``lunarsim run``'s.
- ``exit_when_orphaned``: a thread in the child that ends it once its parent is gone. For children started from
  whichever thread a pool spawns them on (the world's camera process), where the first would end them early.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import threading

PR_SET_PDEATHSIG = 1
ORPHAN_CHECK_S = 1.0


def die_with_parent() -> None:
    with contextlib.suppress(OSError):  # not Linux: the launcher's own shutdown still stops children
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def exit_when_orphaned(parent_pid: int) -> None:
    """End this process within ``ORPHAN_CHECK_S`` of ``parent_pid`` ending (it is then re-parented)."""

    def watch() -> None:
        stop = threading.Event()
        while not stop.wait(ORPHAN_CHECK_S):
            if os.getppid() != parent_pid:
                os._exit(1)

    threading.Thread(target=watch, name="orphan-watch", daemon=True).start()
