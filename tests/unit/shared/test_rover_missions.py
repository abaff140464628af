"""Each rover's goals under ground commands (``shared.mission.RoverMissions``), which the lander and the world
both keep: bounded however many commands arrive, and the index of who shares a goal always the one built afresh."""

from __future__ import annotations

import contextlib
import random
from collections import defaultdict
from pathlib import Path

import pytest

from schemas import messages as m
from schemas.scenario import load_scenario
from shared.mission import COMMANDED_GOALS, REQUESTS_KEPT, CommandRefused, RoverMissions

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"


def _missions(rovers: int = 4) -> RoverMissions:
    return RoverMissions(load_scenario(SCENARIOS / "crater_and_return.yaml").with_overrides(rovers=rovers))


def _target(request_id: str = "", rover_id: int | None = None, x: float = 40.0) -> m.GroundCommand:
    return m.GroundCommand(request_id=request_id, command="set_target", rover_id=rover_id, x=x, z=40.0)


def test_the_ground_adds_at_most_so_many_goals_to_a_rover_and_then_hears_why_not():
    missions = _missions()
    planned = len(missions.goals[1])
    for i in range(COMMANDED_GOALS):
        missions.apply(_target(rover_id=1, x=float(i % 50)))
    with pytest.raises(CommandRefused, match=f"rover 1 has had {COMMANDED_GOALS} goals from the ground"):
        missions.apply(_target(rover_id=1))
    with pytest.raises(CommandRefused, match="rover 1 has had"):
        missions.apply(m.GroundCommand(command="return", rover_id=1))
    assert len(missions.goals[1]) == planned + COMMANDED_GOALS
    assert missions.apply(_target(rover_id=2)) == [2]  # the others are not held up
    with pytest.raises(CommandRefused, match="rover 1"):  # nor half-applied to the team
        missions.apply(_target())
    assert len(missions.goals[2]) == planned + 1 and len(missions.goals[3]) == planned


def test_the_outcomes_of_the_last_requests_are_kept_and_no_more():
    missions = _missions()
    for i in range(REQUESTS_KEPT + 10):
        missions.apply(m.GroundCommand(request_id=f"r{i}", command="stop", rover_id=1 + i % 4))
    missions.apply(_target(request_id="last", rover_id=3))
    assert len(missions.outcomes) == REQUESTS_KEPT and "r10" not in missions.outcomes and "r11" in missions.outcomes
    goals = {rid: len(g) for rid, g in missions.goals.items()}
    assert missions.apply(_target(request_id="last", rover_id=2)) == [3]  # the first outcome
    assert {rid: len(g) for rid, g in missions.goals.items()} == goals  # a resend changes nothing


def test_who_shares_a_goal_is_what_an_index_built_afresh_says():
    rng = random.Random(5)
    missions = _missions(rovers=6)
    for _ in range(300):
        rover = rng.choice([None, *range(1, 7)])
        kind = rng.choice(["set_target", "return", "stop"])
        with contextlib.suppress(CommandRefused):  # a return or stop for every rover: refused
            missions.apply(m.GroundCommand(command=kind, rover_id=rover, x=float(rng.randrange(3)), z=40.0))
        fresh: dict = defaultdict(list)
        for rid, goals in missions.goals.items():
            for i, goal in enumerate(goals):
                fresh[(i, goal)].append(rid)
        for (index, goal), rovers in fresh.items():
            assert missions.sharing(index, goal) == rovers
