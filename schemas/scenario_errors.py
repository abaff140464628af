"""What is wrong with a scenario or parameter file, said so the user can fix it all in one edit: the file named
once, then every problem on a line of its own starting with its field path.

Reading is here too, since a file that is missing, a directory, not UTF-8 or not YAML must fail the same way.
"""

from __future__ import annotations

import difflib
from pathlib import Path

import yaml
from pydantic import ValidationError


class ScenarioError(ValueError):
    """A scenario that cannot be used; the message names the file and is meant for the user as it is."""


def format_error(source: str, exc: ValidationError) -> str:
    """``source: path: problem``; with several problems, the file on a line and each problem on its own."""
    lines = error_lines(exc)
    if len(lines) == 1:
        return f"{source}: {lines[0]}"
    return f"{source}: {len(lines)} problems:\n" + "\n".join(f"  {line}" for line in lines)


def error_lines(exc: ValidationError) -> list[str]:
    """Every error as ``path: problem``, unknown fields first (a typo is the likeliest mistake) with the field
    each probably meant; a required field that a typo explains is not listed again."""
    errors = exc.errors()
    extras = [e for e in errors if e["type"] == "extra_forbidden"]
    lines: list[str] = []
    explained: set[str] = set()
    for e in extras:
        parent, name = _path(e["loc"][:-1]), str(e["loc"][-1])
        missing = [str(m["loc"][-1]) for m in errors if m["type"] == "missing" and _path(m["loc"][:-1]) == parent]
        guess = difflib.get_close_matches(name, [m for m in missing if f"{parent}.{m}" not in explained], n=1)
        explained.update(f"{parent}.{g}" for g in guess)
        lines.append(f"{_path(e['loc'])}: unknown field{f' (did you mean {guess[0]!r}?)' if guess else ''}")
    for e in errors:
        if e["type"] == "extra_forbidden" or (e["type"] == "missing" and f"{_path(e['loc'][:-1])}.{e['loc'][-1]}"
                                                                          in explained):
            continue
        message = e["msg"].removeprefix("Value error, ")
        if not e["loc"] and e["type"] == "value_error":  # a model check: its lines name their own paths
            lines += message.splitlines()
        else:
            lines += [f"{_path(e['loc'])}: {line}" for line in message.splitlines()]
    return lines


def _path(loc: tuple) -> str:
    return ".".join(str(p) for p in loc) or "<root>"


MAX_FILE_BYTES = 64 * 1024**2
"""Largest scenario or parameter file read: ample for 100,000 rocks, and a device or a wrong file named by
mistake is refused instead of read into memory."""


def read_yaml(path: Path, what: str) -> object:
    """The YAML document in ``path``; anything that keeps it from being one is a ``ScenarioError`` naming the
    file (missing, a directory, too large, not UTF-8, not YAML)."""
    try:
        with path.open("rb") as f:
            raw = f.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot read {what}: {exc.strerror or exc}") from None
    if len(raw) > MAX_FILE_BYTES:
        raise ScenarioError(f"{path}: cannot read {what}: larger than {MAX_FILE_BYTES // 1024**2} MiB")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: cannot read {what}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset "
                            f"{exc.start}); save it as UTF-8") from None
    try:
        return yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise ScenarioError(f"{path}: cannot read {what}: not valid YAML{at}: {getattr(exc, 'problem', exc)}"
                            ) from None
    except (ValueError, RecursionError) as exc:  # a scalar YAML cannot build (a date 2024-13-01), deep nesting
        raise ScenarioError(f"{path}: cannot read {what}: a YAML value cannot be read: {exc}") from None
