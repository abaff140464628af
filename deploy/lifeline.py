"""Every process ``lunarsim run`` starts ends with it, even when the launcher itself is killed with SIGKILL: Linux
sends the child SIGTERM when its parent dies (``PR_SET_PDEATHSIG``)."""

from __future__ import annotations

import contextlib
import ctypes
import signal

PR_SET_PDEATHSIG = 1


def die_with_parent() -> None:
    with contextlib.suppress(OSError):  # not Linux: the launcher's own shutdown still stops children
        ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)
