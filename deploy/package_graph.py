"""Which LunarSim package imports which, read from the source (every import, also those inside functions), and the
floors they stack into: the diagram of ``docs/concepts/architecture.md`` is drawn from this, so it cannot drift from
the code. ``tests/project/test_layout.py`` holds the same imports to the rules (downwards only, no circles).
"""

from __future__ import annotations

import ast
import tomllib
from pathlib import Path


def packages(repo: Path) -> list[str]:
    """The top-level packages the wheel ships (``pyproject.toml``), in its order."""
    listed = tomllib.loads((repo / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
    return [name for name in listed if "." not in name]


def imported_names(source: str) -> set[str]:
    """The absolute module names a file imports (relative imports stay inside their package)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
            found.add(node.module)
    return found


def package_imports(repo: Path) -> dict[str, set[str]]:
    """Each package -> the other LunarSim packages its modules import."""
    names = packages(repo)
    graph: dict[str, set[str]] = {}
    for package in names:
        used: set[str] = set()
        for path in sorted((repo / package).rglob("*.py")):
            if "node_modules" not in path.parts:
                used |= {name.split(".")[0] for name in imported_names(path.read_text())}
        graph[package] = {name for name in names if name in used and name != package}
    return graph


def floors(graph: dict[str, set[str]]) -> dict[str, int]:
    """Each package's floor: 0 for one that imports none of ours, else one above the highest it imports."""
    floor: dict[str, int] = {}

    def of(package: str, path: tuple[str, ...]) -> int:
        if package not in floor:
            if package in path:
                raise ValueError(f"packages import each other round a circle: {' -> '.join((*path, package))}")
            floor[package] = 1 + max((of(low, (*path, package)) for low in graph[package]), default=-1)
        return floor[package]

    for package in graph:
        of(package, ())
    return floor


def direct(graph: dict[str, set[str]]) -> dict[str, set[str]]:
    """The imports a diagram draws: those not already implied through another package imported (a transitive
    reduction), so each arrow says something."""
    def below(package: str) -> set[str]:
        reached: set[str] = set()
        todo = list(graph[package])
        while todo:
            low = todo.pop()
            if low not in reached:
                reached.add(low)
                todo += graph[low]
        return reached

    return {package: {low for low in lows if not any(low in below(other) for other in lows - {low})}
            for package, lows in graph.items()}


def diagram(graph: dict[str, set[str]]) -> str:
    """The packages floor by floor, the top first; under each, the packages it imports directly (``->``)."""
    floor, arrows = floors(graph), direct(graph)
    lines = []
    for level in range(max(floor.values()), -1, -1):
        here = sorted(p for p in graph if floor[p] == level)
        lines.append(f"floor {level}  " + "   ".join(f"{p}/" for p in here))
        lines += [f"           {p}/ -> {', '.join(sorted(arrows[p]))}" for p in here if arrows[p]]
    return "\n".join(lines)


def table(graph: dict[str, set[str]]) -> list[str]:
    """Markdown rows: each package, its floor, every package it imports and every package that imports it."""
    floor = floors(graph)
    rows = ["| package | floor | imports | imported by |", "|---|---|---|---|"]
    for package in sorted(graph, key=lambda p: (-floor[p], p)):
        users = sorted(p for p, lows in graph.items() if package in lows)
        rows.append(f"| `{package}/` | {floor[package]} | {', '.join(f'`{p}`' for p in sorted(graph[package])) or '-'}"
                    f" | {', '.join(f'`{p}`' for p in users) or '-'} |")
    return rows
