"""What a research policy is told of each agent: which actions its rover can take now (``action_mask``), and, with
``leave_when_done``, that a rover done with its mission leaves the episode while the others go on."""

from __future__ import annotations

import numpy as np
from pettingzoo.test import parallel_api_test
from procs import SCENARIOS

from rover_env import spaces as sp
from rover_env.env import LunarSimEnv
from schemas.scenario import load_scenario

CRATER = load_scenario(SCENARIOS / "crater_observation.yaml")


def _still() -> dict:
    return {"command": 0, "move": np.zeros(2, np.float32), "rotate": np.zeros(1, np.float32), "speed": 0,
            "goal": 0, "radio": 0, "radio_out": np.zeros(sp.RADIO_FLOATS, np.float32)}


def _allowed(infos: dict, agent: str, part: str) -> set[str]:
    names = sp.COMMANDS if part == "command" else sp.GOAL_REPORTS
    return {name for name, ok in zip(names, infos[agent]["action_mask"][part], strict=True) if ok}


def test_the_mask_forbids_a_second_move_while_one_runs_and_allows_its_cancel():
    env = LunarSimEnv(CRATER, max_sim_time=60.0)
    _, infos = env.reset(seed=1)
    assert _allowed(infos, "rover1", "command") == {"none", "move", "rotate", "photo"}
    still = dict.fromkeys(env.agents, _still())
    while "reached" not in _allowed(infos, "rover1", "goal"):  # no goal report before the lander's direction
        _, _, _, _, infos = env.step(still)
    _, _, _, _, infos = env.step({**still, "rover1": {**_still(), "command": 1, "move": np.array([0, 2], np.float32)}})
    assert _allowed(infos, "rover1", "command") == {"none", "cancel", "photo"}
    for _ in range(400):  # until the move's end is heard
        if "move" in _allowed(infos, "rover1", "command"):
            break
        _, _, _, _, infos = env.step(still)
    assert not env.rounds.world.actuator.bodies[1].busy and {"move", "rotate"} <= _allowed(infos, "rover1", "command")
    assert "cancel" not in _allowed(infos, "rover1", "command")


def test_one_photo_at_a_time():
    env = LunarSimEnv(CRATER, max_sim_time=60.0)
    env.reset(seed=1)
    still = dict.fromkeys(env.agents, _still())
    _, _, _, _, infos = env.step({**still, "rover2": {**_still(), "command": 4}})
    assert "photo" not in _allowed(infos, "rover2", "command")
    for _ in range(400):
        if "photo" in _allowed(infos, "rover2", "command"):
            break
        _, _, _, _, infos = env.step(still)
    assert "photo" in _allowed(infos, "rover2", "command")  # the photo came back: another may be taken


def test_a_rover_that_says_it_is_done_leaves_while_the_others_go_on():
    env = LunarSimEnv(CRATER, max_sim_time=30.0, leave_when_done=True)
    _, infos = env.reset(seed=1)
    still = dict.fromkeys(env.agents, _still())
    while "stuck" not in _allowed(infos, "rover3", "goal"):
        _, _, _, _, infos = env.step(still)
    _, _, terminations, truncations, _ = env.step({**still, "rover3": {**_still(), "goal": 2}})
    assert terminations["rover3"] and not truncations["rover3"]
    assert "rover3" not in env.agents and len(env.agents) == len(CRATER.rovers) - 1
    assert not any(terminations[a] for a in env.agents)
    others = {agent: _still() for agent in env.agents}
    for _ in range(100):  # the world takes the rover's status with its tick's answers
        _, _, terminations, _, _ = env.step(others)
        assert "rover3" not in terminations
        if env.rounds.world.referee.status[3].state == "stuck":
            break
    assert env.rounds.world.referee.status[3].state == "stuck" and len(env.agents) == len(CRATER.rovers) - 1


def test_leaving_agents_keep_to_the_pettingzoo_api():
    parallel_api_test(LunarSimEnv(CRATER, max_sim_time=60.0, leave_when_done=True), num_cycles=400)
