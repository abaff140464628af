"""The C heap of a process that makes and drops the same large NumPy arrays every tick or photo.

glibc hands a block over 128 KiB to its own ``mmap`` and gives it back at once, and gives back the top of the heap
once more than twice that is free; each new array is then fresh pages, and every page's first touch is a fault.
A photo's rays are a few such arrays, a tick's perception and state several more: in a virtual machine the faults
were about a fifth of the in-process lockstep mission's CPU time (a quarter of a photo's). Raising both
thresholds keeps freed blocks in the heap for the next array of the same size; the heap still never holds more
than the process's peak.
"""

from __future__ import annotations

import ctypes
import sys

M_TRIM_THRESHOLD = -1  # glibc's malloc.h
M_MMAP_THRESHOLD = -3
MMAP_THRESHOLD_BYTES = 32 * 1024 * 1024  # glibc's own ceiling for the threshold it adjusts by itself
TRIM_THRESHOLD_BYTES = 2 * MMAP_THRESHOLD_BYTES  # the ratio glibc keeps when it adjusts them


def keep_freed_memory() -> bool:
    """Have the allocator reuse freed large blocks instead of mapping fresh pages; False where the C library is
    not glibc (nothing changes there)."""
    if not sys.platform.startswith("linux"):
        return False
    libc = ctypes.CDLL(None)
    mallopt = getattr(libc, "mallopt", None)
    if mallopt is None or not hasattr(libc, "gnu_get_libc_version"):
        return False
    mallopt.argtypes, mallopt.restype = [ctypes.c_int, ctypes.c_int], ctypes.c_int
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES)) and bool(mallopt(M_TRIM_THRESHOLD,
                                                                                  TRIM_THRESHOLD_BYTES))
