"""The layout's import rules, read from the source (every import, also those inside functions): each package
depends only on the packages below it, no two modules import each other round a circle, and no module outgrows one
concept. What a newcomer reads in docs/concepts/processes.md about the layout holds because this test does (what the
flight wheel carries is ``tests/e2e/test_flight.py``'s)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
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
    "ros2_bridge": {"schemas", "bus", "sessions", "world_service", "lander_agent"},
    "deploy": {"schemas", "bus", "world_service", "rover_agent", "lander_agent", "scenarios", "harness", "rover_env",
               "sessions", "hardware", "web", "ros2_bridge"},
}
"""Each package's allowed imports among LunarSim's own: downwards only (the table in docs/concepts/processes.md)."""
UNITS: dict[str, set[str]] = {
    # the rover agent: three modules every part speaks in, then its parts, each importing only those below it
    "rover_agent.dead_reckoning": set(),
    "rover_agent.decisions": {"rover_agent.dead_reckoning"},
    "rover_agent.outgoing": set(),
    "rover_agent.restarts": {"rover_agent.dead_reckoning"},
    "rover_agent.actions": {"rover_agent.dead_reckoning", "rover_agent.decisions", "rover_agent.outgoing",
                            "rover_agent.restarts"},
    "rover_agent.estimation": {"rover_agent.dead_reckoning", "rover_agent.decisions", "rover_agent.actions"},
    "rover_agent.mission": {"rover_agent.dead_reckoning", "rover_agent.decisions", "rover_agent.estimation"},
    "rover_agent.rules": {"rover_agent.dead_reckoning", "rover_agent.decisions", "rover_agent.estimation"},
    # the world service: what its parts share, the parts (never the world that holds them), the pure cores over
    # them, and the process (what its loop needs of a world, the loop, the command)
    "world_service.geometry": set(),
    "world_service.clock": set(),
    "world_service.scene": {"world_service.geometry"},
    "world_service.terrain": set(),
    "world_service.camera": {"world_service.scene", "world_service.terrain"},
    "world_service.actuation": {"world_service.clock", "world_service.scene", "world_service.terrain",
                                "world_service.camera"},
    "world_service.power": {"world_service.scene", "world_service.terrain", "world_service.actuation"},
    "world_service.radio": {"world_service.geometry", "world_service.scene", "world_service.terrain"},
    "world_service.sensors": {"world_service.geometry", "world_service.clock", "world_service.scene",
                              "world_service.terrain", "world_service.actuation"},
    "world_service.outcome": {"world_service.geometry", "world_service.scene"},
    "world_service.sim": {"world_service.clock", "world_service.scene", "world_service.terrain",
                          "world_service.camera", "world_service.actuation", "world_service.power",
                          "world_service.radio", "world_service.sensors", "world_service.outcome"},
    "world_service.twin": {"world_service.clock", "world_service.camera", "world_service.radio",
                           "world_service.outcome"},
    "world_service.served": {"world_service.clock", "world_service.camera"},
    "world_service.lockstep": {"world_service.served"},
    "world_service.rover_ids": set(),
    "world_service.presence": {"world_service.served", "world_service.lockstep", "world_service.rover_ids"},
    "world_service.resume": {"world_service.sim"},
    "world_service.service": {"world_service.served", "world_service.lockstep", "world_service.presence",
                              "world_service.rover_ids", "world_service.camera"},
    "world_service.app": {"world_service.served", "world_service.service", "world_service.resume", "world_service.sim",
                          "world_service.twin"},
    "world_service.__main__": set(),
}
"""Inside a package: each member's allowed imports among the package's own members. A rover agent's other
top-level modules (its coordinator, its command) stand above every unit and may import them all; every member of
the world service has its place here, and its loop sees a world only through ``served``."""
LAYERED = ("rover_agent", "world_service")
"""Packages whose every subpackage is a unit of ``UNITS``."""
EVERY_MEMBER = ("world_service",)
"""Packages whose every top-level module is a unit too."""
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


def _unit(name: str) -> str | None:
    """The unit of ``UNITS`` a module belongs to: the longest that names it or a package holding it."""
    found = [unit for unit in UNITS if name == unit or name.startswith(unit + ".")]
    return max(found, key=len, default=None)


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


@pytest.mark.parametrize("unit", sorted(UNITS))
def test_each_subpackage_imports_only_the_units_below_it(unit):
    package = unit.split(".")[0]
    wrong = sorted(f"{name} imports {target}" for name, targets in GRAPH.items() if _unit(name) == unit
                   for target in targets
                   if target.split(".")[0] == package and target != package and _unit(target) != unit
                   and _unit(target) not in UNITS[unit])
    assert not wrong, "\n".join(wrong)


def test_the_units_stack_without_a_circle():
    stack: list[str] = []

    def below(unit: str, path: tuple[str, ...]) -> None:
        for lower in sorted(UNITS[unit]):
            assert lower not in path, " -> ".join([*path, lower])
            below(lower, (*path, lower))
        stack.append(unit)

    for unit in sorted(UNITS):
        below(unit, (unit,))
    assert set(stack) == set(UNITS)


@pytest.mark.parametrize("package", LAYERED)
def test_every_subpackage_says_what_it_may_import(package):
    subpackages = {name for name, path in MODULES.items() if path.name == "__init__.py" and "." in name
                   and name.split(".")[0] == package}
    assert subpackages <= set(UNITS), sorted(subpackages - set(UNITS))


@pytest.mark.parametrize("package", EVERY_MEMBER)
def test_every_member_has_its_place(package):
    members = {".".join(name.split(".")[:2]) for name in MODULES if name.startswith(package + ".")}
    assert members == {unit for unit in UNITS if unit.startswith(package + ".")}, "add new members, drop gone ones"
