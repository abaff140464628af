"""The layout's import rules, read from the source (every import, also those inside functions): each package
depends only on the packages below it, no two modules import each other round a circle, and no module outgrows one
concept. What a newcomer reads in docs/concepts/processes.md about the layout holds because this test does (what the
flight wheel carries is ``tests/e2e/test_flight.py``'s)."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
MAY_IMPORT: dict[str, set[str]] = {
    "schemas": set(),
    "bus": {"schemas"},
    "shared": {"schemas"},
    "world_service": {"schemas", "bus", "shared"},
    "rover_agent": {"schemas", "bus", "shared"},
    "lander_agent": {"schemas", "bus", "shared"},
    "scenarios": {"schemas"},
    "harness": {"schemas", "bus", "shared", "world_service", "rover_agent", "lander_agent"},
    "rover_env": {"schemas", "bus", "shared", "world_service", "rover_agent", "lander_agent", "harness"},
    "sessions": {"schemas", "bus", "shared", "world_service", "lander_agent"},
    "hardware": {"schemas", "bus", "shared"},
    "web": {"schemas", "bus", "shared", "scenarios", "sessions", "world_service", "lander_agent"},
    "ros2_bridge": {"schemas", "bus", "shared", "sessions", "world_service", "rover_agent", "lander_agent"},
    "deploy": {"schemas", "bus", "shared", "world_service", "rover_agent", "lander_agent", "scenarios", "harness",
               "rover_env", "sessions", "hardware", "web", "ros2_bridge"},
}
"""Each package's allowed imports among LunarSim's own: downwards only (the table in docs/concepts/processes.md)."""
UNITS: dict[str, set[str]] = {
    # the rover agent: two modules every part speaks in, then its parts, each importing only those below it
    "rover_agent.decisions": set(),
    "rover_agent.outgoing": set(),
    "rover_agent.restarts": set(),
    "rover_agent.actions": {"rover_agent.decisions", "rover_agent.outgoing", "rover_agent.restarts"},
    "rover_agent.estimation": {"rover_agent.decisions", "rover_agent.actions"},
    "rover_agent.mission": {"rover_agent.decisions", "rover_agent.estimation"},
    "rover_agent.rules": {"rover_agent.decisions", "rover_agent.estimation"},
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
    "world_service.__main__": set(),
}
"""Inside a package: each member's allowed imports among the package's own members. A rover agent's other
top-level modules (its coordinator, its loop) stand above every unit and may import them all; every member of
the world service has its place here, and its loop sees a world only through ``served``."""
COMMANDS = "commands"
"""Each package's commands (``<package>/commands/<command>.py``) stand above all its other members: they may import
any of them, and inside the package only its ``__main__`` imports them."""
ZENOH_IO: dict[str, set[str]] = {
    "world_service": {"world_service.service"},
    "rover_agent": {"rover_agent.runtime", "rover_agent.identity"},
    "lander_agent": {"lander_agent.runtime"},
    "hardware": {"hardware.runtime"},
}
"""Each process's modules that speak Zenoh: its loop (and the rover's id asked of the world). Everything else in the
process, its pure core first, and the in-process harness that drives those cores, imports no ``zenoh``."""
PURE = ("schemas", "shared", "world_service", "rover_agent", "lander_agent", "hardware", "harness")
"""Packages whose modules are pure apart from ``ZENOH_IO``, their commands and ``__main__``."""
FACADES = ("rover_agent", "hardware", "harness", "rover_env")
"""Packages whose ``__init__`` declares their public surface (``__all__``): what users import by the package's name."""
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
    """The LunarSim modules ``name`` imports, at any depth of the file, resolved to module names: ``from p import m``
    is module ``p.m``, ``from p import Name`` is ``p`` itself (its ``__init__``, a facade)."""
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
            modules = {f"{base}.{alias.name}" for alias in node.names} & MODULES.keys()
            targets.update(modules)
            if len(modules) < len(node.names):  # a name the package defines: its __init__ (a facade)
                targets.add(base)
    return {t for t in targets if t in MODULES and t != name}


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _imports_zenoh(path: Path) -> bool:
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import) and any(alias.name.split(".")[0] == "zenoh" for alias in node.names):
            return True
        if isinstance(node, ast.ImportFrom) and not node.level and (node.module or "").split(".")[0] == "zenoh":
            return True
    return False


def _reach(name: str) -> set[str]:
    """Every LunarSim module ``name`` imports, directly or through others."""
    seen: set[str] = set()
    todo = [name]
    while todo:
        for target in GRAPH[todo.pop()] - seen:
            seen.add(target)
            todo.append(target)
    return seen


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


def _command(name: str) -> bool:
    return name.split(".")[1:2] == [COMMANDS]


@pytest.mark.parametrize("package", LAYERED)
def test_every_subpackage_says_what_it_may_import(package):
    subpackages = {name for name, path in MODULES.items() if path.name == "__init__.py" and "." in name
                   and name.split(".")[0] == package and not _command(name)}
    assert subpackages <= set(UNITS), sorted(subpackages - set(UNITS))


@pytest.mark.parametrize("package", EVERY_MEMBER)
def test_every_member_has_its_place(package):
    members = {".".join(name.split(".")[:2]) for name in MODULES
               if name.startswith(package + ".") and not _command(name)}
    assert members == {unit for unit in UNITS if unit.startswith(package + ".")}, "add new members, drop gone ones"


def test_only_a_packages_main_imports_its_commands():
    wrong = sorted(f"{name} imports {target}" for name, targets in GRAPH.items() for target in targets
                   if _command(target) and target.split(".")[0] == name.split(".")[0] and not _command(name)
                   and name.split(".")[1:] != ["__main__"])
    assert not wrong, "\n".join(wrong)


@pytest.mark.parametrize("package", PURE)
def test_pure_modules_import_no_zenoh(package):
    """A core is tested without a router, and the harness runs the processes' cores in one process: neither may
    reach a Zenoh loop, however deep the import."""
    speaks = {name for name, path in MODULES.items() if _imports_zenoh(path)}
    io = set().union(*ZENOH_IO.values())
    pure = [name for name in MODULES if name.split(".")[0] == package and name not in io and not _command(name)
            and name.split(".")[-1] != "__main__"]
    wrong = sorted(f"{name} reaches {sorted((_reach(name) | {name}) & speaks)}" for name in pure
                   if (_reach(name) | {name}) & speaks)
    assert not wrong, "\n".join(wrong)


def test_each_process_speaks_zenoh_only_in_its_loop():
    """The list of Zenoh modules is the code's: one no longer speaking Zenoh leaves it."""
    for modules in ZENOH_IO.values():
        assert all(_imports_zenoh(MODULES[name]) or GRAPH[name] & {"bus.bus", "bus.zenoh_config"} for name in modules)


def test_the_harness_drives_the_lander_core_not_its_loop():
    harness = set().union(*(_reach(name) for name in MODULES if name.split(".")[0] == "harness"))
    assert "lander_agent.lander" in harness and not harness & set().union(*ZENOH_IO.values())


@pytest.mark.parametrize("package", FACADES)
def test_a_facade_gives_every_name_it_declares(package):
    module = importlib.import_module(package)
    assert module.__all__ and [name for name in module.__all__ if not hasattr(module, name)] == []


def test_the_architecture_diagram_reads_the_imports_this_test_checks():
    """docs/concepts/architecture.md draws the packages from ``deploy.package_graph``: it sees what this test sees."""
    from deploy.package_graph import package_imports

    ours = {package: {target.split(".")[0] for name, targets in GRAPH.items() if name.split(".")[0] == package
                      for target in targets} - {package} for package in MAY_IMPORT}
    assert package_imports(REPO) == ours
