"""The command blocks of the README and the guides, with their ``docs-test`` markers, as
``tests/e2e/test_docs_commands.py`` runs them. Pure: reads Markdown, runs nothing. The rules are in that module's
docstring."""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

SHELL_FENCES = frozenset({"bash", "sh", "shell", "console"})
"""Fenced blocks with one of these info strings hold commands; any other fence (text, yaml, python) does not."""

MARKER = re.compile(r"^\s*<!--\s*docs-test:\s*(.*?)\s*-->\s*$")
FENCE = re.compile(r"^(\s*)(```+|~~~+)\s*([\w-]*)")
FILE_COMMENT = re.compile(r"^#\s*(\S+\.py)\s*$")
FOLDER = "<folder>"
"""The placeholder for a run folder: the test puts the newest one the page's blocks made there."""

GENERATED = frozenset({"reference", "index.md"})
"""Under ``docs/``: made by ``python -m deploy.reference docs`` (``index.md`` is the README, links made relative)."""

BOX = re.compile(r"[\u2500-\u257f]")


class MarkerError(ValueError):
    """A marker that names nothing, or says nothing about why: reported against its page and line."""


@dataclass
class Block:
    """One code block of a page, with what its markers say about it."""

    page: str
    line: int
    text: str
    kind: str
    """``shell`` (run), ``output`` (checked against the previous shell block's output), ``example`` (neither),
    ``file`` (a Python block written to the file its first line names) or ``other`` (ignored)."""
    skip: str | None = None
    omit: list[tuple[str, str]] = field(default_factory=list)
    replace: list[tuple[str, str, str]] = field(default_factory=list)
    expect: list[str] = field(default_factory=list)

    @property
    def where(self) -> str:
        return f"{self.page}:{self.line}"


def commands(block: Block) -> list[str]:
    """The block's commands as a reader types them: continuation lines joined, a console block's ``$`` lines."""
    lines = block.text.splitlines()
    if block.kind == "shell" and block.text.lstrip().startswith("$ "):
        lines = [line[2:] for line in lines if line.startswith("$ ")]
    joined: list[str] = []
    for line in lines:
        if joined and joined[-1].endswith("\\"):
            joined[-1] += "\n" + line
        elif line.strip():
            joined.append(line)
    return joined


def script(block: Block) -> str:
    """The shell text the test runs: the block's commands less its omitted lines, with its replacements made."""
    lines = commands(block)
    for prefix, _ in block.omit:
        kept = [line for line in lines if not line.startswith(prefix)]
        if len(kept) == len(lines):
            raise MarkerError(f"{block.where}: omit `{prefix}` matches no line of the block")
        lines = kept
    text = "\n".join(lines)
    for old, new, _ in block.replace:
        if old not in text:
            raise MarkerError(f"{block.where}: replace `{old}` is not in the block")
        text = text.replace(old, new)
    return text + "\n"


def omitted(block: Block) -> list[tuple[str, str]]:
    """Each omitted line with the reason it is not run."""
    return [(line, reason) for prefix, reason in block.omit for line in commands(block) if line.startswith(prefix)]


def normalise(text: str) -> str:
    """Table borders dropped and runs of blanks made one, line by line, so a figure matches however wide the
    terminal's table was drawn."""
    lines = (" ".join(BOX.sub(" ", line).split()) for line in text.splitlines())
    return "\n".join(line for line in lines if line)


_RULES = (
    (re.compile(r"^skip:\s*(.+)$"), lambda b, m: setattr(b, "skip", m[1])),
    (re.compile(r"^omit `([^`]+)`:\s*(.+)$"), lambda b, m: b.omit.append((m[1], m[2]))),
    (re.compile(r"^replace `([^`]+)` with `([^`]*)`:\s*(.+)$"), lambda b, m: b.replace.append((m[1], m[2], m[3]))),
    (re.compile(r"^expect `([^`]+)`$"), lambda b, m: b.expect.append(m[1])),
    (re.compile(r"^output$"), lambda b, m: setattr(b, "kind", "output")),
    (re.compile(r"^example:\s*(.+)$"), lambda b, m: setattr(b, "kind", "example")),
)


def _apply(block: Block, markers: list[tuple[int, str]]) -> Block:
    for line, body in markers:
        for pattern, rule in _RULES:
            if match := pattern.match(body):
                rule(block, match)
                break
        else:
            raise MarkerError(f"{block.page}:{line}: unknown docs-test marker: {body!r}")
    if block.kind != "shell" and (block.skip or block.omit or block.replace or block.expect):
        raise MarkerError(f"{block.where}: skip, omit, replace and expect belong to command blocks")
    return block


def _fenced(lines: list[str], start: int) -> tuple[int, str, list[str]]:
    """From a fence's opening line: the index after its closing line, its info string and its body."""
    indent, fence, info = FENCE.match(lines[start]).groups()
    end = start + 1
    while end < len(lines) and not lines[end].strip().startswith(fence):
        end += 1
    body = [line[len(indent):] if line.startswith(indent) else line.lstrip() for line in lines[start + 1:end]]
    return end + 1, info, body


def _indented(lines: list[str], start: int) -> tuple[int, list[str]]:
    """From an indented block's first line: the index after it and its body, dedented by its first line's indent."""
    indent = len(lines[start]) - len(lines[start].lstrip())
    end = start
    while end < len(lines) and (not lines[end].strip() or len(lines[end]) - len(lines[end].lstrip()) >= indent):
        end += 1
    body = [line[indent:] for line in lines[start:end]]
    while body and not body[-1].strip():
        body.pop()
    return start + len(body), body


def _kind(info: str | None, body: list[str]) -> str:
    if info is None or info in SHELL_FENCES:
        return "shell"
    if info == "python" and body and FILE_COMMENT.match(body[0]):
        return "file"
    return "other"


def blocks(path: Path, page: str) -> list[Block]:
    """Every code block of a Markdown page, in order, with the markers on the lines before it."""
    lines = path.read_text().expandtabs().splitlines()
    found: list[Block] = []
    markers: list[tuple[int, str]] = []
    index, blank_before = 0, True
    while index < len(lines):
        line = lines[index]
        if marker := MARKER.match(line):
            markers.append((index + 1, marker[1]))
            index, blank_before = index + 1, False
            continue
        if FENCE.match(line):
            end, info, body = _fenced(lines, index)
        elif blank_before and line.strip() and len(line) - len(line.lstrip()) >= 4:
            end, body = _indented(lines, index)
            info = None
        else:
            if line.strip() and markers:
                raise MarkerError(f"{page}:{markers[0][0]}: a docs-test marker must stand just before a code block")
            index, blank_before = index + 1, not line.strip()
            continue
        found.append(_apply(Block(page, index + 1 + (info is not None), "\n".join(body), _kind(info, body)),
                            markers))
        markers, index, blank_before = [], end, False
    return found


def pages(repo: Path) -> list[tuple[str, Path]]:
    """The README and the hand-written docs; ``docs/reference/`` is generated from the code and not read here."""
    docs = repo / "docs"
    written = sorted(p for p in docs.rglob("*.md") if p.relative_to(docs).parts[0] not in GENERATED)
    return [(str(p.relative_to(repo)), p) for p in [repo / "README.md", *written]]
