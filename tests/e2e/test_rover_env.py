"""The PettingZoo environment: PettingZoo's own API and seed tests, observations inside their declared spaces,
the shipped agent as a policy giving the same report as the in-process mission and as ``lunarsim run --lockstep
--seed`` through real processes, and actions that cannot forge another rover's samples."""

from __future__ import annotations

import re
from functools import partial

import msgspec
import numpy as np
import pytest
from gymnasium.utils.env_checker import data_equivalence
from pettingzoo.test import parallel_api_test, parallel_seed_test
from procs import SCENARIOS, free_port, run_cli_mission

from harness.loopback import run_mission
from rover_env import spaces as sp
from rover_env.actions import ActionError
from rover_env.env import LunarSimEnv
from rover_env.policy import AgentPolicy, run_episode
from rover_env.vector import EPISODE, VectorEnv, evaluate
from schemas import keyspace as ks
from schemas import messages as m
from schemas.scenario import Scenario, load_scenario

REPORT_SCENARIOS = ("crater_observation", "crater_and_return", "maze", "maze_crater_return")
"""The report's editor profiles (appendix C.3, figures 27-30), with their shipped noise."""
LAUNCHER_ONLY = {"wall_time_s", "map_corridor_mapped", "map_obstacles_found", "map_obstacle_precision"}
EQUAL_FOR_S = 90.0
"""Simulated seconds of a mission an episode and ``lunarsim run --lockstep`` are compared over."""


def crater_env(**kwargs) -> LunarSimEnv:
    return LunarSimEnv(load_scenario(SCENARIOS / "crater_observation.yaml"), **kwargs)


def test_pettingzoo_parallel_api_test():
    parallel_api_test(crater_env(max_sim_time=60.0), num_cycles=400)


def test_pettingzoo_parallel_seed_test():
    parallel_seed_test(lambda: crater_env(max_sim_time=60.0), num_cycles=200)


def test_random_actions_give_observations_inside_their_spaces_and_reach_the_world():
    env = crater_env(max_sim_time=5.0)
    observations, _ = env.reset(seed=3)
    for i, agent in enumerate(env.agents):
        env.action_space(agent).seed(i)
    heard = np.zeros(len(sp.HEARD_TOPICS), int)
    while env.agents:
        assert all(env.observation_space(a).contains(o) for a, o in observations.items())
        heard += sum(o["heard"] for o in observations.values())
        # never a goal report: random ones say "stuck" at once and end the mission before the radio reports
        actions = {agent: {**env.action_space(agent).sample(), "goal": 0} for agent in env.agents}
        observations, *_ = env.step(actions)
    for topic in (ks.CLOCK, ks.PERCEPTION, ks.NAVIGATION_STATUS, ks.GYROSCOPE, ks.COMM_IN, ks.COMM_PARTNERS,
                  ks.MISSION_DIRECTION):
        assert heard[sp.HEARD_TOPICS.index(topic)] > 0, topic


def test_a_move_command_drives_the_rover_and_its_end_comes_back_as_an_observation():
    env = crater_env(max_sim_time=60.0)
    env.reset()
    still = dict.fromkeys(env.agents, _still())
    observations, *_ = env.step({**still, "rover1": {**_still(), "command": 1, "move": np.array([0, 2], np.float32)}})
    completed = (sp.NAV_ACTIONS.index("move") + 1, sp.NAV_OUTCOMES.index("completed") + 1)
    while tuple(observations["rover1"]["navigation"]) != completed:
        observations, *_ = env.step(still)
    assert env.rounds.world.actuator.bodies[1].distance_covered == pytest.approx(2.0, abs=0.3)


def test_a_broadcast_of_numbers_arrives_as_numbers_at_the_rovers_in_range():
    env = crater_env(max_sim_time=10.0)
    env.reset()
    quiet = {agent: {**_still(), "radio": 0} for agent in env.agents}
    words = np.linspace(-1, 1, sp.RADIO_FLOATS, dtype=np.float32)
    observations, *_ = env.step({**quiet, "rover1": {**_still(), "radio": 1, "radio_out": words}})
    for _ in range(50):
        if any(o["radio_senders"][1] for o in observations.values()):
            break
        observations, *_ = env.step(quiet)
    heard_by = [a for a, o in observations.items() if o["radio_senders"][1]]
    assert heard_by and "rover1" not in heard_by
    assert np.array_equal(observations[heard_by[0]]["radio_in"][1], words)


def test_rovers_answering_each_other_without_end_do_not_stop_the_clock():
    env = crater_env(max_sim_time=3.0)
    env.reset()
    chatter = {**_still(), "radio": 1}
    while env.agents:
        env.step(dict.fromkeys(env.agents, chatter))
    assert env.rounds.world.clock.sim_time >= 3.0
    # Each answer to a radio delivery reaches the world after its next step, as over Zenoh: the chatter goes on
    # a hop a tick, in at most three rounds a tick (the step's samples, the clock, the late samples).
    ticks = 3.0 / env.rounds.world.clock.dt
    assert ticks * 2 <= env.cycles <= ticks * 3 + 3


def test_an_actions_end_is_observed_once_because_the_array_rover_says_it_heard_it():
    env = crater_env(max_sim_time=60.0)
    env.reset()
    still = dict.fromkeys(env.agents, _still())
    observations, *_ = env.step({**still, "rover1": {**_still(), "command": 1, "move": np.array([0, 2], np.float32)}})
    ends = 0
    while env.rounds.world.clock.sim_time < 8.0:  # the world re-sends an unheard end every second
        ends += observations["rover1"]["navigation"][1] == sp.NAV_OUTCOMES.index("completed") + 1
        observations, *_ = env.step(still)
    assert ends == 1


def test_a_collision_costs_its_reward_once_however_often_its_end_is_heard():
    env = crater_env(max_sim_time=10.0)
    env.reset()
    collided = m.NavigationStatus(stamp=1.0, action="move", remaining=0.0, outcome="collided", action_id=7)
    first = env.rewards.round(1, [(ks.NAVIGATION_STATUS, collided)])
    again = env.rewards.round(1, [(ks.NAVIGATION_STATUS, collided)])
    assert (first, again) == (-1.0, 0.0)


@pytest.mark.parametrize(("change", "named"), [({"command": 9}, "command=9"), ({"speed": 5}, "speed=5"),
                                               ({"move": np.array([0, 99], np.float32)}, "move=")])
def test_an_array_action_outside_its_space_is_refused_naming_the_rover_and_the_key(change, named):
    env = crater_env(max_sim_time=10.0)
    env.reset()
    with pytest.raises(ActionError, match=f"rover 1: outside the action space: {re.escape(named)}"):
        env.step({"rover1": {**_still(), **change}})
    with pytest.raises(ActionError, match="rover 1: an array action has the keys"):
        env.step({"rover1": {"command": 0}})
    with pytest.raises(ActionError, match="no live agent 'rover_1'"):
        env.step({"rover_1": _still()})


def test_a_broadcast_of_anything_leaves_every_observation_inside_its_space():
    env = crater_env(max_sim_time=10.0)
    env.reset()
    marked_nan = sp.RADIO_MARK + np.full(sp.RADIO_FLOATS, np.nan, np.float32).tobytes()
    nan = [("lunar/loopback/rover/1/comm_out", m.OutboundComm(targets=[2, 3], payload=marked_nan))]
    junk = [("lunar/loopback/rover/2/comm_out", m.OutboundComm(targets=[1, 3], payload=b"\xff" * 32))]
    for _ in range(30):
        observations, *_ = env.step({"rover1": nan, "rover2": junk})
        assert all(env.observation_space(a).contains(o) for a, o in observations.items())


def test_a_seeded_episode_repeats_observations_rewards_and_infos_step_for_step():
    def episode() -> list:
        env = crater_env(max_sim_time=8.0)
        steps = [env.reset(seed=9)]
        for i, agent in enumerate(env.agents):
            env.action_space(agent).seed(i)
        while env.agents:
            steps.append(env.step({a: {**env.action_space(a).sample(), "goal": 0} for a in env.agents}))
        return steps

    first, second = episode(), episode()
    assert len(first) > 50 and data_equivalence(first, second)


def _still() -> dict:
    return {"command": 0, "move": np.zeros(2, np.float32), "rotate": np.zeros(1, np.float32), "speed": 0,
            "goal": 0, "radio": 0, "radio_out": np.zeros(sp.RADIO_FLOATS, np.float32)}


@pytest.mark.parametrize("name", REPORT_SCENARIOS)
def test_the_shipped_agent_as_a_policy_scores_as_the_in_process_mission(name):
    scenario = load_scenario(SCENARIOS / f"{name}.yaml")
    env = LunarSimEnv(scenario, max_sim_time=900.0)
    report, totals = run_episode(env, AgentPolicy())
    assert report == run_mission(scenario, 900.0).report()
    assert report.complete
    reached = report.rovers_reached_final_goal
    assert sum(total > 0.5 for total in totals.values()) == reached  # +1 each for reaching, less the walk


@pytest.mark.e2e
@pytest.mark.parametrize("name", REPORT_SCENARIOS)
def test_an_episode_equals_lunarsim_run_lockstep_of_the_same_seed(tmp_path, name):
    """The first minute and a half: every step of it is compared, and whole missions are equal in process
    (the test above) as in process and through processes (``test_loopback_equals_processes``)."""
    scenario_file = SCENARIOS / f"{name}.yaml"
    env = LunarSimEnv(load_scenario(scenario_file), max_sim_time=EQUAL_FOR_S)
    report, _ = run_episode(env, AgentPolicy(), seed=11)
    processes, _ = run_cli_mission(tmp_path / "run", str(scenario_file), "--lockstep", "--seed", "11", "--quiet",
                                   "--no-record", "--max-sim-time", str(EQUAL_FOR_S), "--port", str(free_port()))
    in_env = msgspec.to_builtins(report)
    for field in LAUNCHER_ONLY:
        in_env.pop(field)
        processes.pop(field)
    assert in_env == processes


def test_a_seed_replays_an_episode_and_another_seed_changes_it():
    env = crater_env(max_sim_time=300.0)
    first, second, other = (run_episode(env, AgentPolicy(), seed=s)[0] for s in (5, 5, 6))
    assert first == second
    assert other != first


@pytest.mark.parametrize("forged", [
    ("lunar/loopback/rover/2/move_action", m.MoveAction(x=0, z=1)),  # another rover's key
    ("lunar/loopback/lander/comm_out", m.OutboundComm(targets=[1], payload=b"")),  # the lander's
    ("lunar/loopback/rover/1/perception", m.Perception(stamp=0, angles_deg=[], distances_m=[], kinds=[])),
    ("lunar/loopback/rover/1/move_action", m.RotateAction(degrees=5)),  # the wrong model for the key
    "move 1 m",
])
def test_a_message_action_may_publish_only_what_its_own_rover_publishes(forged):
    env = crater_env(max_sim_time=10.0)
    env.reset()
    with pytest.raises(ActionError, match="rover 1"):
        env.step({"rover1": [forged]})


def test_unknown_agents_are_named_errors():
    env = crater_env()
    with pytest.raises(KeyError, match="rover1, rover2"):
        env.action_space("rover9")
    with pytest.raises(RuntimeError, match="reset"):
        env.step({})


def test_many_seeds_in_worker_processes_score_as_one_process_does():
    make = partial(LunarSimEnv, load_scenario(SCENARIOS / "crater_observation.yaml").with_overrides(rovers=2), 120.0)
    results = evaluate(make, AgentPolicy, [3, 4], workers=2)
    assert [r["seed"] for r in results] == [3, 4]
    for result in results:
        report, returns = run_episode(make(), AgentPolicy(), seed=result["seed"])
        assert result["report"] == msgspec.to_builtins(report) and result["returns"] == returns


def test_a_workers_error_reaches_the_caller_named_and_every_worker_is_stopped():
    make = partial(LunarSimEnv, load_scenario(SCENARIOS / "crater_observation.yaml").with_overrides(rovers=2), 5.0)
    envs = VectorEnv(make, 2, seed=1)
    envs.reset()
    forged = [("lunar/loopback/rover/2/move_action", m.MoveAction(x=0, z=1))]
    with pytest.raises(RuntimeError, match=r"environment 0 of 2: ActionError: rover 1 may not publish"):
        envs.step([{"rover1": forged}, {"rover1": _still()}])
    workers = list(envs.workers)
    envs.close()
    envs.close()
    assert not any(worker.is_alive() for worker in workers)


def test_a_vector_of_environments_steps_together_and_starts_the_next_seed_when_an_episode_ends():
    make = partial(LunarSimEnv, load_scenario(SCENARIOS / "crater_observation.yaml").with_overrides(rovers=2), 1.0)
    with VectorEnv(make, 2, seed=10) as envs:
        (obs, _), _ = envs.reset()
        assert set(obs) == {"rover1", "rover2"}
        ended = []
        for _ in range(200):
            results = envs.step([dict.fromkeys(obs, _still())] * 2)
            ended += [infos[EPISODE]["seed"] for *_, infos in results if EPISODE in infos]
            if len(ended) >= 4:
                break
    assert sorted(ended[:4]) == [10, 11, 12, 13]


class GoThere:
    """A scripted array policy: dead-reckon from the calibration, turn to the mission direction's target, drive
    in steps, say the goal is reached. Enough to show the array interface can finish a mission on its own."""

    def __init__(self) -> None:
        self.pose = self.target = None
        self.waiting = None  # "rotate" or "move" in flight: (kind, amount)
        self.reported = False

    def act(self, obs: dict) -> dict:
        heard = dict(zip(sp.HEARD_TOPICS, obs["heard"], strict=True))
        if heard[ks.CALIBRATION] and self.pose is None:  # the lander repeats it; dead reckoning starts once
            self.pose = [float(v) for v in obs["calibration"]]
        if heard[ks.MISSION_DIRECTION]:
            _, _, bearing, distance = (float(v) for v in obs["direction"])
            self.target = (distance * np.sin(np.radians(bearing)), distance * np.cos(np.radians(bearing)))
        if heard[ks.NAVIGATION_STATUS] and obs["navigation"][1] == sp.NAV_OUTCOMES.index("completed") + 1:
            self._done()
        if self.pose is None or self.target is None or self.waiting or self.reported:
            return _still()
        dx, dz = self.target[0] - self.pose[0], self.target[1] - self.pose[1]
        if np.hypot(dx, dz) < 0.5:
            self.reported = True
            return {**_still(), "goal": sp.GOAL_REPORTS.index("reached")}
        turn = (np.degrees(np.arctan2(dx, dz)) - self.pose[2] + 180) % 360 - 180
        if abs(turn) > 1:
            self.waiting = ("rotate", turn)
            return {**_still(), "command": 2, "rotate": np.array([turn], np.float32)}
        step = min(np.hypot(dx, dz), 6.0)
        self.waiting = ("move", step)
        return {**_still(), "command": 1, "move": np.array([0, step], np.float32)}

    def _done(self) -> None:
        kind, amount = self.waiting
        x, z, heading = self.pose
        if kind == "rotate":
            self.pose = [x, z, (heading + amount) % 360]
        else:
            self.pose = [x + amount * np.sin(np.radians(heading)), z + amount * np.cos(np.radians(heading)), heading]
        self.waiting = None


def test_an_array_policy_can_finish_a_mission_on_its_own_and_is_rewarded_for_it():
    base = load_scenario(SCENARIOS / "crater_observation.yaml").with_overrides(rovers=1)
    data = base.model_dump()
    spawn = base.rovers[0]
    data["mission"] = [{"x": spawn.x - 12.0, "z": spawn.z + 3.0, "kind": "waypoint"}]
    env = LunarSimEnv(Scenario.model_validate(data), max_sim_time=300.0)
    observations, _ = env.reset()
    policy, total = GoThere(), 0.0
    while env.agents:
        observations, rewards, terminations, _, _ = env.step({"rover1": policy.act(observations["rover1"])})
        total += rewards["rover1"]
    assert terminations == {"rover1": True} and env.report().rovers_reached_final_goal == 1
    assert 0.8 < total < 1.0  # +1 for reaching, less a tenth a length of the ideal path walked
