"""User behaviours (report 4.4): found by name, checked against the contract, run by the agent."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest
from procs import REPO

from deploy.behaviour_check import scripted_problems
from harness.loopback import run_mission
from rover_agent.behaviour import BaseBehaviour, DefaultBehaviour, MoveTo, Rotate
from rover_agent.examples import StraightLine
from rover_agent.registry import UnknownBehaviour, load_behaviour
from schemas.params import RoverParams
from schemas.scenario import load_scenario

BROKEN = '''
from rover_agent.behaviour import BaseBehaviour, MoveTo

class Backwards(BaseBehaviour):
    def decide(self, view):
        return MoveTo(0.0, -5.0)  # behind the rover: outside any field of view
'''


def test_behaviours_are_found_by_name_or_path():
    assert load_behaviour("default") is DefaultBehaviour
    assert load_behaviour("straight") is StraightLine
    assert load_behaviour("rover_agent.examples:StraightLine") is StraightLine


@pytest.mark.parametrize(("name", "says"), [
    ("nosuch", "use one of default, straight"),
    ("rover_agent.examples:Missing", "cannot be loaded"),
    ("rover_agent.behaviour:View", "not a subclass"),
])
def test_unknown_behaviours_are_refused_with_the_reason(name, says):
    with pytest.raises(UnknownBehaviour, match=says):
        load_behaviour(name)


def test_the_built_in_behaviours_keep_the_contract():
    assert scripted_problems(DefaultBehaviour, RoverParams()) == []
    assert scripted_problems(StraightLine, RoverParams()) == []


def test_a_behaviour_that_breaks_the_contract_is_caught():
    class Backwards(BaseBehaviour):
        def decide(self, view):
            return MoveTo(0.0, -5.0)

    class Restless(BaseBehaviour):
        turns = 0

        def decide(self, view):
            Restless.turns += 1
            return Rotate(float(Restless.turns))

    problems = scripted_problems(Backwards, RoverParams())
    assert any("outside the 210 degree field of view" in p for p in problems)
    assert any("expected Finish('reached')" in p for p in problems)
    assert any("not deterministic" in p for p in scripted_problems(Restless, RoverParams()))


def test_the_example_behaviour_completes_a_mission():
    scenario = load_scenario(REPO / "scenarios" / "crater_observation.yaml").with_overrides(rovers=2)
    world = run_mission(scenario, 300, behaviour=StraightLine)
    assert world.complete and world.report().rover_collisions == 0


def test_check_behaviour_command_exits_1_on_a_broken_behaviour(tmp_path):
    (tmp_path / "my_behaviour.py").write_text(BROKEN)
    env = {**os.environ, "PYTHONPATH": f"{tmp_path}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    proc = subprocess.run([sys.executable, "-m", "deploy.cli", "check-behaviour", "my_behaviour:Backwards",
                           "--max-sim-time", "20"], cwd=REPO, capture_output=True, text=True, timeout=120, env=env)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "problem: goal ahead, nothing in view: MoveTo(x=0.0, z=-5.0) is outside" in proc.stdout
