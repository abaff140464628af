"""The flight computer: the ``lunarsim-rover`` wheel carries only the rover's code and dependencies, installs
into a fresh environment, runs the agent against a real router, and its systemd units verify."""

from __future__ import annotations

import ast
import shutil
import subprocess
import sys
import threading
from pathlib import Path

import pytest
import zenoh
from procs import REPO, stop, wait_for

from bus.zenoh_config import build_config
from deploy.flight import build_wheel as flight
from schemas.keyspace import Keyspace

THIRD_PARTY = {"zenoh", "msgspec", "pydantic", "pydantic_core", "yaml", "serial"}
"""What the flight wheel's dependencies provide (pydantic_core is pydantic's own, installed with it; pyserial only
with its ``serial`` extra)."""
PROJECT_ROOTS = {"schemas", "bus", "shared", "rover_agent", "lander_agent", "world_service", "scenarios", "harness",
                 "sessions", "hardware", "web", "deploy"}
GROUND_ONLY = ("world_service", "numpy", "trimesh", "matplotlib", "mcap", "foxglove", "rich", "lander_agent",
               "sessions", "web", "harness", "deploy")
UNITS = REPO / "deploy" / "systemd"


def _imports(path: Path) -> set[str]:
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
            names |= {f"{node.module}.{alias.name}" for alias in node.names}
    return names


def _flight_modules() -> set[str]:
    return {".".join(p.with_suffix("").parts).removesuffix(".__init__") for p in flight.staged_files(REPO)}


def test_flight_code_imports_nothing_outside_the_wheel_and_its_dependencies():
    modules = _flight_modules()
    packages = {m.rsplit(".", 1)[0] for m in modules} | modules
    stray = []
    for rel in flight.staged_files(REPO):
        for name in _imports(REPO / rel):
            root = name.split(".")[0]
            if root in PROJECT_ROOTS:
                if name not in packages and name.rsplit(".", 1)[0] not in modules:
                    stray.append(f"{rel}: {name}")
            elif root not in THIRD_PARTY and root not in sys.stdlib_module_names and root != "__future__":
                stray.append(f"{rel}: {name}")
    assert not stray, "flight code imports what the flight wheel does not carry:\n" + "\n".join(stray)


def test_the_flight_wheel_carries_the_agent_and_the_bridge_but_no_ground_code():
    modules = _flight_modules()
    assert {"rover_agent.commands.rover", "hardware.commands.bridge", "bus.zenoh_config", "schemas.messages"} <= modules
    assert not any(m.split(".")[0] in ("world_service", "lander_agent") for m in modules)
    assert not any(m.startswith(("sessions", "deploy.launcher", "deploy.batch")) for m in modules)


@pytest.mark.e2e
def test_the_flight_environment_has_none_of_the_ground_dependencies(flight_env):
    python = flight_env / "bin" / "python"
    for name in GROUND_ONLY:
        found = subprocess.run([str(python), "-c", f"import {name}"], capture_output=True, text=True,
                               cwd=flight_env)  # not the repository: -c puts the working folder on the path
        assert found.returncode != 0 and "ModuleNotFoundError" in found.stderr, f"{name} is installed"
    for script in ("lunarsim-rover", "lunarsim-bridge"):
        shown = subprocess.run([str(flight_env / "bin" / script), "--help"], capture_output=True, text=True)
        assert shown.returncode == 0 and "--id" in shown.stdout, shown.stderr


@pytest.mark.e2e
def test_the_flight_rover_agent_joins_a_real_router(flight_env, router):
    keys = Keyspace("flight")
    present = threading.Event()
    with zenoh.open(build_config(connect=[router])) as session:
        session.liveliness().declare_subscriber(keys.alive_rover(4), lambda s: present.set(), history=True)
        agent = subprocess.Popen([str(flight_env / "bin" / "lunarsim-rover"), "--id", "4", "--world", "flight",
                                  "--connect", router], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                 cwd=flight_env)
        try:
            wait_for(present.is_set, 30, "the flight agent's liveliness token")
            lines = []  # its start logged, then the wait said
            while len(lines) < 10 and not any("rover 4: waiting for the world service" in line for line in lines):
                lines.append(agent.stdout.readline())
            assert "rover 4: waiting for the world service" in lines[-1], lines
        finally:
            stop(agent)


def _units_for(bin_dir: Path, into: Path) -> list[Path]:
    """The shipped units, with ExecStart pointing at a real environment (verify checks it is executable)."""
    copies = []
    for unit in sorted(UNITS.glob("*.service")):
        copy = into / unit.name
        copy.write_text(unit.read_text().replace("/opt/lunarsim/venv/bin", str(bin_dir)))
        copies.append(copy)
    return copies


@pytest.mark.e2e
def test_the_systemd_units_verify_and_restart_on_failure(flight_env, tmp_path):
    if shutil.which("systemd-analyze") is None:
        pytest.skip("systemd-analyze is not installed (Debian package systemd)")
    copies = _units_for(flight_env / "bin", tmp_path)
    assert {c.name for c in copies} == {"lunarsim-rover@.service", "lunarsim-bridge@.service"}
    for copy in copies:
        text = copy.read_text()
        assert "Restart=on-failure" in text and "--id %i" in text and "User=lunarsim" in text
        instance = copy.with_name(copy.name.replace("@.", "@3."))
        checked = subprocess.run(["systemd-analyze", "verify", "--man=no", str(instance)], capture_output=True,
                                 text=True, cwd=tmp_path)
        assert checked.returncode == 0 and not checked.stderr.strip(), checked.stderr
