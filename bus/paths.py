"""Paths a command writes to, checked as its arguments are read (argparse types).

A command writes where its user says, and only where that is a plain file or a folder: an empty argument would
put a run's files in the working folder, a FIFO blocks the writer for ever, a device swallows the output (and a
state file's replace-then-remove took ``/dev/zero`` with it), and a folder named as a file fails only once the
mission is over. Each is refused before anything starts.
"""

from __future__ import annotations

import argparse
import stat
from pathlib import Path

from schemas.scenario_limits import clip, file_kind


def output_file(text: str) -> Path:
    """A file the command creates or replaces: absent, or a regular file."""
    path = _named(text)
    mode = _mode(path)
    if mode is not None and stat.S_ISDIR(mode):
        raise argparse.ArgumentTypeError(f"{clip(text)} is a folder; give a file's path")
    if mode is not None and not stat.S_ISREG(mode):
        raise argparse.ArgumentTypeError(f"{clip(text)} is not a regular file ({file_kind(mode)})")
    return path


def new_file(text: str) -> Path:
    """A file the command creates, where none is: a recording or a scenario replaced by the command's output is
    lost (``record -o`` over a recording left an empty one)."""
    path = output_file(text)
    if path.exists():
        raise argparse.ArgumentTypeError(f"{clip(text)} already exists; remove it or give another path")
    return path


def output_path(text: str) -> Path:
    """A file or a folder, as the command's other arguments decide: absent, a regular file or a folder."""
    path = _named(text)
    mode = _mode(path)
    if mode is not None and not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
        raise argparse.ArgumentTypeError(f"{clip(text)} is neither a regular file nor a folder ({file_kind(mode)})")
    return path


def output_folder(text: str) -> Path:
    """A folder the command creates or writes into: absent, or a folder."""
    path = _named(text)
    mode = _mode(path)
    if mode is not None and not stat.S_ISDIR(mode):
        raise argparse.ArgumentTypeError(f"{clip(text)} is not a folder ({file_kind(mode)})")
    return path


def _named(text: str) -> Path:
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path names no file or folder")
    return Path(text)


def _mode(path: Path) -> int | None:
    try:
        return path.stat().st_mode
    except FileNotFoundError:
        return None
    except OSError as exc:  # a path through a file, too long a name, no permission
        raise argparse.ArgumentTypeError(f"{clip(str(path))}: {exc.strerror}") from None
