"""What is wrong with a scenario or parameter file, said so the user can fix it all in one edit: the file named
once, then every problem on a line of its own starting with its field path.

Every value of the user's repeated in a message goes through ``clip``: a name of 10 MB is named by its start.
"""

from __future__ import annotations

import difflib
import types
import typing

import msgspec
from pydantic import BaseModel, ValidationError

from schemas.errors import EXIT_USAGE, LunarSimError
from schemas.scenario_limits import clip
from schemas.scenario_types import mirror

LINE_CHARS = 1000
"""Longest problem line: a message that repeats values it did not clip is cut here all the same."""
LISTED_PROBLEMS = 50
"""Problems listed one a line; past them, how many more there are. A list of 100,000 bad rocks is fixed by
reading the first few."""
GUESS_CHARS = 100
"""Unknown field names longer than this get no 'did you mean': no field is that long, and matching costs their
length squared."""


class ScenarioError(LunarSimError, ValueError):
    """A scenario that cannot be used; the message names the file and is meant for the user as it is."""

    exit_code = EXIT_USAGE


def format_error(source: str, exc: ValidationError, model: type[BaseModel] | None = None) -> str:
    """``source: path: problem``; with several problems, the file on a line and each problem on its own.

    ``model``, the class validated, lets an unknown field be matched against every field at its level."""
    lines = [clip(line, LINE_CHARS) for line in error_lines(exc, model)]
    if len(lines) == 1:
        return f"{source}: {lines[0]}"
    shown = lines[:LISTED_PROBLEMS]
    if len(lines) > len(shown):
        shown.append(f"... and {len(lines) - len(shown):,} more")
    return f"{source}: {len(lines):,} problems:\n" + "\n".join(f"  {line}" for line in shown)


def error_lines(exc: ValidationError, model: type[BaseModel] | None = None) -> list[str]:
    """Every error as ``path: problem``, unknown fields first (a typo is the likeliest mistake) with the field
    each probably meant; a required field that a typo explains is not listed again."""
    errors = exc.errors()
    missing: dict[tuple, list[str]] = {}
    for e in errors:
        if e["type"] == "missing":
            missing.setdefault(e["loc"][:-1], []).append(str(e["loc"][-1]))
    lines: list[str] = []
    explained: set[str] = set()
    for e in errors:
        if e["type"] == "extra_forbidden":
            wider = model if len(lines) < LISTED_PROBLEMS else None  # past those, the lines are not shown
            guess = _guess(e["loc"], missing, explained, wider)
            lines.append(f"{_path(e['loc'])}: unknown field{f' (did you mean {guess!r}?)' if guess else ''}")
    for e in errors:
        if e["type"] == "extra_forbidden" or (e["type"] == "missing" and _key(e["loc"]) in explained):
            continue
        message = e["msg"].removeprefix("Value error, ")
        if not e["loc"] and e["type"] == "value_error":  # a model check: its lines name their own paths
            lines += message.splitlines()
        else:
            lines += [f"{_path(e['loc'])}: {line}" for line in message.splitlines()]
    return lines


def _guess(loc: tuple, missing: dict[tuple, list[str]], explained: set[str],
           model: type[BaseModel] | None) -> str | None:
    """The field an unknown one probably meant: a missing one at its level first (then it is not listed again as
    missing), else any field of ``model`` there."""
    name, parent = str(loc[-1]), loc[:-1]
    if len(name) > GUESS_CHARS:
        return None
    unexplained = [m for m in missing.get(parent, []) if _key((*parent, m)) not in explained]
    guess = difflib.get_close_matches(name, unexplained, n=1)
    if guess:
        explained.add(_key((*parent, guess[0])))
        return guess[0]
    known = sorted(fields_at(model, parent)) if model is not None else []
    guess = difflib.get_close_matches(name, known, n=1)
    return guess[0] if guess else None


def fields_at(model: type[BaseModel], loc: tuple) -> set[str]:
    """The field names of the models found at ``loc`` (a pydantic error location) under ``model``."""
    kinds = _models(model)
    for part in loc:
        if isinstance(part, int):  # an item of a list or tuple: _models already looked inside those
            continue
        nxt = {m for kind in kinds if part in kind.model_fields for m in _models(kind.model_fields[part].annotation)}
        kinds = nxt or {kind for kind in kinds if kind.__name__ == part} or kinds  # a union member's tag
    return {name for kind in kinds for name in kind.model_fields}


def _models(annotation: object) -> set[type[BaseModel]]:
    """The pydantic models an annotation holds, through Optional, unions, lists, tuples and Annotated; a msgspec
    Struct (a scenario's ``rover_params``) as its mirror, which has its fields."""
    if isinstance(annotation, type) and issubclass(annotation, msgspec.Struct):
        return {mirror(annotation)}
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return {annotation}
    if typing.get_origin(annotation) is None and not isinstance(annotation, types.UnionType):
        return set()
    return {m for arg in typing.get_args(annotation) for m in _models(arg)}


def _key(loc: tuple) -> str:
    return ".".join(str(p) for p in loc)


def _path(loc: tuple) -> str:
    return ".".join(clip(str(p)) for p in loc) or "<root>"
