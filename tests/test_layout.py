"""The layout's import rules, read from the source (every import, also those inside functions): each package
depends only on the packages below it, no two modules import each other round a circle, and no module outgrows one
concept. What a newcomer reads in docs/concepts/processes.md about the layout holds because this test does (what the
flight wheel carries is ``tests/test_flight.py``'s)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
MAY_IMPORT: dict[str, set[str]] = {
    "schemas": set(),
    "bus": {"schemas"},
    "world_service": {"schemas", "bus"},
    "rover_agent": {"schemas", "bus"},
    "lander_agent": {"schemas", "bus"},
    "scenarios": {"schemas"},
    "harness": {"schemas", "bus", "world_service", "rover_agent", "lander_agent"},
    "rover_env": {"schemas", "bus", "world_service", "rover_agent", "lander_agent", "harness"},
    "sessions": {"schemas", "bus", "world_service", "lander_agent"},
    "hardware": {"schemas", "bus"},
    "web": {"schemas", "bus", "sessions", "world_service", "lander_agent"},
    "deploy": {"schemas", "bus", "world_service", "rover_agent", "lander_agent", "scenarios", "harness", "rover_env",
               "sessions", "hardware", "web"},
}
"""Each package's allowed imports among LunarSim's own: downwards only (the table in docs/concepts/processes.md)."""
WORLD_SERVICE: dict[str, set[str]] = {
    # what the parts share
    "geometry": set(),
    "clock": set(),
    "scene": {"geometry"},
    "terrain": set(),
    # the parts the simulated world holds, each owning its state
    "camera": {"scene", "terrain"},
    "actuation": {"clock", "scene", "terrain", "camera"},
    "power": {"scene", "terrain", "actuation"},
    "radio": {"geometry", "scene", "terrain"},
    "sensors": {"geometry", "clock", "scene", "terrain", "actuation"},
    "outcome": {"geometry", "scene"},
    # the pure cores over them
    "sim": {"clock", "scene", "terrain", "camera", "actuation", "power", "radio", "sensors", "outcome"},
    "twin": {"clock", "camera", "radio", "outcome"},
    # the process: what its loop needs of a world, the loop and the command
    "served": {"clock", "camera"},
    "lockstep": {"served"},
    "rover_ids": set(),
    "presence": {"served", "lockstep", "rover_ids"},
    "resume": {"sim"},
    "service": {"served", "lockstep", "presence", "rover_ids", "camera"},
    "app": {"served", "service", "resume", "sim", "twin"},
    "__main__": set(),
    "__init__": set(),
}
"""Inside ``world_service``, what each subpackage or top-level module may import of the others: the parts import
only what they share and the parts below them, never the world that holds them, and the service's loop sees a world
only through ``served``."""
MAX_LINES = 400


def _modules() -> dict[str, Path]:
    found = {}
    for package in MAY_IMPORT:
        for path in sorted((REPO / package).rglob("*.py")):
            if "node_modules" in path.parts:
                continue
            parts = path.relative_to(REPO).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            found[name] = path
    return found


MODULES = _modules()


def _imports(name: str, path: Path) -> set[str]:
    """The LunarSim modules ``name`` imports, at any depth of the file, resolved to module names."""
    tree = ast.parse(path.read_text(), str(path))
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    targets: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package.split(".")[: len(package.split(".")) - node.level + 1] + ([base] if base
                                                                                                    else []))
            targets.add(base)
            targets.update(f"{base}.{alias.name}" for alias in node.names)
    return {t for t in targets if t in MODULES and t != name}


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


@pytest.mark.parametrize("package", sorted(MAY_IMPORT))
def test_each_package_imports_only_the_packages_below_it(package):
    wrong = sorted(f"{name} imports {target}" for name, targets in GRAPH.items() if name.split(".")[0] == package
                   for target in targets
                   if target.split(".")[0] != package and target.split(".")[0] not in MAY_IMPORT[package])
    assert not wrong, "\n".join(wrong)


def test_no_modules_import_each_other_round_a_circle():
    circles = []
    done: set[str] = set()

    def visit(node: str, path: list[str], on_path: set[str]) -> None:
        for target in sorted(GRAPH[node]):
            if target in on_path:
                circles.append(" -> ".join([*path[path.index(target):], target]))
            elif target not in done:
                visit(target, [*path, target], on_path | {target})
        done.add(node)

    for name in sorted(GRAPH):
        if name not in done:
            visit(name, [name], {name})
    assert not circles, "\n".join(circles)


def test_every_package_and_subpackage_ships_in_the_wheel():
    """``pip install .`` installs the packages pyproject.toml names, not their subpackages: each must be named."""
    import tomllib

    listed = set(tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {name for name, path in MODULES.items() if path.name == "__init__.py"}
    assert found <= listed, sorted(found - listed)


def test_no_module_is_over_400_lines():
    long = {name: n for name, path in MODULES.items() if (n := len(path.read_text().splitlines())) > MAX_LINES}
    assert not long, long


def _member(name: str) -> str:
    """The subpackage or top-level module of ``world_service`` that module ``name`` belongs to."""
    parts = name.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_every_member_of_the_world_service_has_its_place():
    members = {_member(name) for name in MODULES if name.split(".")[0] == "world_service"}
    assert members == set(WORLD_SERVICE), "add new members to WORLD_SERVICE, drop gone ones"


def test_the_world_service_s_members_import_only_what_they_may():
    # ``from world_service import geometry`` also names the package's root, which imports nothing
    inside = {name: {t for t in targets if t.split(".")[0] == "world_service" and t != "world_service"}
              for name, targets in GRAPH.items() if name.split(".")[0] == "world_service"}
    wrong = sorted(f"{name} imports {target}" for name, targets in inside.items() for target in targets
                   if _member(target) != _member(name) and _member(target) not in WORLD_SERVICE[_member(name)])
    assert not wrong, "\n".join(wrong)


def test_the_world_service_s_members_stack_without_a_circle():
    placed: list[str] = []
    left = dict(WORLD_SERVICE)
    while left:
        ready = sorted(member for member, below in left.items() if below <= set(placed))
        assert ready, f"members importing each other round a circle: {sorted(left)}"
        placed += ready
        for member in ready:
            del left[member]
