"""The code base stays ruff clean (the project's style contract), checked with every test run."""

from __future__ import annotations

import shutil
import subprocess
import sys

from procs import REPO

from deploy.cli import COMMANDS, command_module


def test_ruff_reports_nothing():
    ruff = shutil.which("ruff") or str(REPO / ".ci-venv" / "bin" / "ruff")
    proc = subprocess.run([ruff, "check", "--output-format", "concise", "."], cwd=REPO, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr


def loaded_after(setup: str, modules: tuple[str, ...]) -> list[str]:
    """Which of ``modules`` a fresh interpreter has imported after running ``setup``."""
    code = f"import sys\n{setup}\nprint(','.join(m for m in {modules!r} if m in sys.modules))"
    proc = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0, proc.stderr
    return [m for m in proc.stdout.strip().split(",") if m]


def test_rover_agent_imports_stay_light():
    """The flight-computer agent must not pull in NumPy or the world service (design doc)."""
    setup = "import rover_agent.commands.rover, rover_agent.runtime, rover_agent.agent"
    assert loaded_after(setup, ("numpy", "numba", "world_service", "rich", "yaml_world")) == []


def test_rover_agent_without_a_params_file_imports_no_yaml():
    """Without ``--params`` the agent has no file to read: it loads neither PyYAML nor the scenario models."""
    setup = ("from rover_agent.commands import rover; from rover_agent.registry import load_behaviour; "
             "load_behaviour('default'); assert rover.rover_params(None).perception.perception_radius > 0; "
             "assert rover._dispatch(None, [1]) == {}")
    assert loaded_after(setup, ("yaml", "schemas.scenario")) == []


FLIGHT_PATH = """
from bus import process
from rover_agent.commands import rover
from rover_agent import runtime
from rover_agent.agent import RoverAgent
from rover_agent.registry import load_behaviour
from schemas import codec, keyspace as ks, messages as m
params = rover.rover_params(None)
agent = RoverAgent(1, ks.Keyspace("w"), params, load_behaviour("default")(1, params))
agent.on_clock(codec.decode(m.Clock, codec.encode(m.Clock(tick=0, sim_time=0.0, time_scale=1.0, run="r"))))
out = agent.handle(ks.PERCEPTION, codec.encode(m.Perception(stamp=0.1, angles_deg=[0.0], distances_m=[3.0],
                                                            kinds=["obstacle"])))
assert agent.handle(ks.PERCEPTION, b"garbage") == [] and agent.rejected.total == 1
assert all(codec.encode(message) for _, message in out)
"""


def test_the_rover_agents_flight_path_imports_no_pydantic():
    """A flight computer's agent without ``--params``: start, a clock, a perception and a refused sample through the
    codec. Pydantic (its core and the validators it builds) was half the agent's memory: the wire models are msgspec
    Structs, and only the scenario models, for files, are pydantic."""
    assert loaded_after(FLIGHT_PATH, ("pydantic", "pydantic_core", "msgpack", "yaml", "schemas.scenario")) == []


def test_the_lunarsim_parser_imports_no_web_server():
    """Help for every command imports every command module to build its parser; aiohttp (a fifth of a second)
    waits until a command serves a page."""
    assert loaded_after("import deploy.cli; deploy.cli.build_parsers()", ("aiohttp", "numpy", "numba")) == []


def test_a_lunarsim_command_imports_its_own_command_module_alone():
    script = "import deploy.cli; deploy.cli.build_parsers(deploy.cli.named_command(['-v', 'scenario', 'check', 'x']))"
    others = [command_module(name) for name in COMMANDS if name != "scenario"]
    assert loaded_after(script, ("deploy.commands.scenario", *others)) == ["deploy.commands.scenario"]
