"""Reading the files a user names: scenario and rover parameter YAML, terrain meshes, editor profiles.

A name may point at anything: a FIFO that never ends, ``/dev/zero``, a directory, a 24 MB file. Each is refused
before a byte is read, with one line naming the file: only a regular file within its size bound is opened, and
what was opened is checked again, so nothing put in its place between the two is read either. A YAML document is
refused for a key given twice in one mapping (the last would silently win) and for aliases that expand beyond
what its size allows.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import yaml

from schemas.scenario_errors import ScenarioError
from schemas.scenario_limits import MAX_MESH_BYTES, MAX_SCENARIO_BYTES, MAX_YAML_NODES, clip, file_kind, mesh_suffix


def file_problem(st: os.stat_result, limit: int) -> str | None:
    """Why a file with this status is not read (not a regular file, larger than ``limit``), or None."""
    if stat.S_ISDIR(st.st_mode):
        return "Is a directory"
    if not stat.S_ISREG(st.st_mode):
        return f"not a regular file ({file_kind(st.st_mode)})"
    if st.st_size > limit:
        return f"{st.st_size:,} bytes, more than the {_size(limit)} allowed"
    return None


def read_regular_file(path: Path, what: str, limit: int) -> bytes:
    """The bytes of ``path``, a regular file of at most ``limit`` bytes; else a ``ScenarioError`` naming it."""
    try:
        problem = file_problem(os.stat(path), limit)  # before opening: opening a FIFO waits for a writer
        if problem is None:
            fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC)
    except (OSError, ValueError) as exc:  # ValueError: a NUL in the name
        raise ScenarioError(f"{path}: cannot read {what}: {exc.strerror or exc}") from None
    if problem is not None:
        raise ScenarioError(f"{path}: cannot read {what}: {problem}")
    with os.fdopen(fd, "rb") as f:
        problem = file_problem(os.fstat(fd), limit)  # what was opened, were the name changed meanwhile
        raw = f.read(limit + 1) if problem is None else b""
    if problem is None and len(raw) > limit:
        problem = f"more than the {_size(limit)} allowed"
    if problem is not None:
        raise ScenarioError(f"{path}: cannot read {what}: {problem}")
    return raw


def check_mesh(mesh: str, base_dir: Path) -> str:
    """The mesh file a scenario names, as an absolute path (a relative one is taken from ``base_dir``, the
    scenario's folder, so a copy of the scenario still finds it); ``ValueError`` saying why it cannot be one."""
    mesh_suffix(mesh)
    path = (base_dir / mesh).resolve()
    try:
        problem = file_problem(os.stat(path), MAX_MESH_BYTES)
    except (OSError, ValueError) as exc:
        problem = exc.strerror or str(exc)
    if problem is not None:
        raise ValueError(f"{clip(str(path))}: {problem}")
    return str(path)


def read_mesh(path: Path) -> tuple[bytes, str]:
    """A terrain mesh file's bytes and format (its suffix, as trimesh names formats)."""
    try:
        suffix = mesh_suffix(str(path))
    except ValueError as exc:
        raise ScenarioError(f"cannot read terrain mesh: {exc}") from None
    return read_regular_file(path, "terrain mesh", MAX_MESH_BYTES), suffix.removeprefix(".")


def read_yaml(path: Path, what: str) -> object:
    """The YAML document in ``path``; anything that keeps it from being one is a ``ScenarioError`` naming the
    file (missing, not a regular file, too large, not UTF-8, not YAML, a key given twice, aliases too many)."""
    raw = read_regular_file(path, what, MAX_SCENARIO_BYTES)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{path}: cannot read {what}: not UTF-8 text (byte 0x{raw[exc.start]:02x} at offset "
                            f"{exc.start}); save it as UTF-8") from None
    try:
        return load_yaml_text(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        at = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = clip(str(getattr(exc, "problem", None) or exc))
        raise ScenarioError(f"{path}: cannot read {what}: not valid YAML{at}: {problem}") from None
    except (ValueError, RecursionError) as exc:  # a scalar YAML cannot build (a date 2024-13-01), deep nesting
        raise ScenarioError(f"{path}: cannot read {what}: a YAML value cannot be read: {clip(str(exc))}") from None


class UniqueKeyLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """The safe loader (libyaml's where installed), refusing a mapping that gives one key twice."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict:
        first: dict[object, int] = {}
        for key_node, _ in node.value:
            if not isinstance(key_node, yaml.ScalarNode) or key_node.tag == "tag:yaml.org,2002:merge":
                continue  # a merge (<<) may be overridden; an unhashable key is refused by the base loader
            key = self.construct_object(key_node)
            if key in first:
                raise yaml.constructor.ConstructorError(
                    "while constructing a mapping", node.start_mark,
                    f"duplicate key {clip(repr(key))} (first given at line {first[key] + 1})", key_node.start_mark)
            first[key] = key_node.start_mark.line
        return super().construct_mapping(node, deep=deep)


def load_yaml_text(text: str) -> object:
    """One YAML document, loaded by ``UniqueKeyLoader`` after its aliases are counted (``MAX_YAML_NODES``)."""
    loader = UniqueKeyLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        if "*" in text:  # no alias without one: the count would only cost time
            _count_values(node)
        return loader.construct_document(node)
    finally:
        loader.dispose()


def _count_values(root: yaml.Node) -> None:
    """Refuse a document whose values, aliases expanded, exceed ``MAX_YAML_NODES``, or that holds itself."""
    counts: dict[int, int] = {}
    open_nodes: set[int] = set()
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, children_done = stack.pop()
        children = _children(node)
        if children_done:
            counts[id(node)] = 1 + sum(counts[id(c)] for c in children)
            open_nodes.discard(id(node))
            if counts[id(node)] > MAX_YAML_NODES:
                raise yaml.YAMLError(f"aliases expand it to more than {MAX_YAML_NODES:,} values")
        elif id(node) in open_nodes:
            raise yaml.composer.ComposerError(None, None, "an alias refers to a value that holds it",
                                              node.start_mark)
        elif id(node) not in counts:
            open_nodes.add(id(node))
            stack.append((node, True))
            stack.extend((c, False) for c in children if id(c) not in counts)


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return node.value
    if isinstance(node, yaml.MappingNode):
        return [n for pair in node.value for n in pair]
    return []


def _size(limit: int) -> str:
    return f"{limit / 1024**2:g} MiB" if limit >= 1024**2 else f"{limit:,} bytes"
