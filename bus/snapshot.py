"""A process's own state on disk, whole, for a restart to resume from: the world's and the lander's.

Written whole or not at all (a temporary file renamed over the last one, mode 0600), read back only from where the
process itself wrote it: a snapshot is as trusted as the scenario, so ``pickle`` keeps every part of the state
without a schema of its own. A file that is not a regular one, too large, or cut short is said and ignored.
"""

from __future__ import annotations

import logging
import os
import pickle
import stat
from pathlib import Path

MAX_BYTES = 512 * 2**20
"""A snapshot is about a megabyte for a five-rover mission; far larger is not ours."""


def save(state: object, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "wb") as out:
        pickle.dump(state, out, protocol=pickle.HIGHEST_PROTOCOL)
    os.replace(tmp, path)


def load(path: Path, log: logging.Logger) -> object | None:
    """What ``save`` wrote to ``path``; None, and a warning saying why, if there is nothing usable."""
    try:
        info = path.stat()
    except FileNotFoundError:
        return None
    if not stat.S_ISREG(info.st_mode) or info.st_size > MAX_BYTES:
        log.warning("not resuming from %s: not a regular file of at most %d MiB", path, MAX_BYTES >> 20)
        return None
    try:
        with open(path, "rb") as f:
            return pickle.load(f)
    except Exception as exc:  # cut short by a kill mid-write, or written by another version
        log.warning("not resuming from %s: it cannot be read (%s: %s)", path, type(exc).__name__, exc)
        return None


def discard(path: Path) -> None:
    """The snapshot and its temporary file gone; only regular files are removed (``save`` writes no other)."""
    for p in (path, path.with_name(path.name + ".tmp")):
        if p.is_file():
            p.unlink(missing_ok=True)
