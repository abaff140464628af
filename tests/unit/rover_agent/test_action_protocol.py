"""The action protocol survives lost, repeated and late samples: actions carry ids, the world answers a repeated id
with how that action stands, re-sends an end until the agent has heard it, and agents ask again after silence."""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from agent_kit import RUN, joined_agent

from harness.loopback import run_mission
from rover_agent.actions.ids import ActionIds
from rover_agent.actions.in_flight import ACTION_QUERY_S
from rover_agent.agent import RoverAgent
from rover_agent.restarts.saved_state import SavedState, load_state, save_state
from schemas import codec
from schemas import keyspace as ks
from schemas import messages as m
from schemas.keyspace import Keyspace
from schemas.scenario import load_scenario
from shared.pose import Pose
from world_service.sim import World

SCENARIOS = Path(__file__).resolve().parents[3] / "scenarios"
KEYS = Keyspace("t")


def _world() -> World:
    return World(load_scenario(SCENARIOS / "crater_observation.yaml").with_overrides(rovers=1), KEYS)


def _send(world: World, topic: str, message: m.Message) -> list:
    return world.receive(KEYS.rover(1, topic), codec.encode(message))


def _of(out, topic: str) -> list:
    return [msg for key, msg in out if key == KEYS.rover(1, topic)]


def _until_idle(world: World, limit: int = 400) -> list:
    out = []
    for _ in range(limit):
        out += world.step()
        if not world.actuator.bodies[1].busy:
            return out
    raise AssertionError("the action did not end")


# ---- the world's side ----


def test_an_action_sent_again_is_answered_not_started_twice():
    world = _world()
    first = _of(_send(world, ks.ROTATE_ACTION, m.RotateAction(degrees=90, action_id=7)), ks.NAVIGATION_STATUS)
    assert first[0].action_id == 7 and first[0].outcome == "running"
    world.step()
    heading = world.actuator.bodies[1].heading
    again = _of(_send(world, ks.ROTATE_ACTION, m.RotateAction(degrees=90, action_id=7)), ks.NAVIGATION_STATUS)
    assert again[0].action_id == 7 and again[0].outcome == "running"
    assert again[0].remaining < first[0].remaining  # the same rotation, further on: not a second one
    ended = _of(_until_idle(world), ks.NAVIGATION_STATUS)
    assert ended[-1].outcome == "completed" and ended[-1].action_id == 7
    turned = (world.actuator.bodies[1].heading - heading) % 360.0
    late = _of(_send(world, ks.ROTATE_ACTION, m.RotateAction(degrees=90, action_id=7)), ks.NAVIGATION_STATUS)
    assert late == [ended[-1]]  # its end again
    assert not world.actuator.bodies[1].busy and (world.actuator.bodies[1].heading - heading) % 360.0 == turned


def test_a_late_duplicate_of_an_older_action_is_refused_and_never_moves_the_rover():
    world = _world()
    _send(world, ks.ROTATE_ACTION, m.RotateAction(degrees=10, action_id=5))
    _until_idle(world)
    _send(world, ks.ROTATE_ACTION, m.RotateAction(degrees=10, action_id=6))
    _until_idle(world)
    heading = world.actuator.bodies[1].heading
    refused = _of(_send(world, ks.ROTATE_ACTION, m.RotateAction(degrees=10, action_id=4)), ks.ACTION_REJECTED)
    assert refused[0].reason == "stale" and refused[0].action_id == 4
    assert not world.actuator.bodies[1].busy and world.actuator.bodies[1].heading == heading


def test_a_refused_action_sent_again_gets_the_same_refusal():
    world = _world()
    behind = m.MoveAction(x=0.0, z=-5.0, action_id=3)  # out of the field of view
    first = _of(_send(world, ks.MOVE_ACTION, behind), ks.ACTION_REJECTED)
    again = _of(_send(world, ks.MOVE_ACTION, behind), ks.ACTION_REJECTED)
    assert first == again and first[0].reason == "out_of_view" and first[0].action_id == 3


def test_the_end_is_resent_until_the_agents_status_says_it_was_heard():
    world = _world()
    _send(world, ks.ROTATE_ACTION, m.RotateAction(degrees=30, action_id=9))
    _until_idle(world)
    later = [o for _ in range(int(3.5 / world.clock.dt)) for o in world.step()]
    ends = [s for s in _of(later, ks.NAVIGATION_STATUS) if s.outcome == "completed"]
    assert len(ends) >= 3 and {s.action_id for s in ends} == {9}
    _send(world, ks.STATUS, m.RoverStatus(stamp=world.clock.sim_time, state="migration", action_id=9))
    quiet = [o for _ in range(int(3.0 / world.clock.dt)) for o in world.step()]
    assert not _of(quiet, ks.NAVIGATION_STATUS)


def test_an_agent_away_is_told_how_its_action_ended_once_it_is_back():
    world = _world()
    _send(world, ks.ROTATE_ACTION, m.RotateAction(degrees=90, action_id=11))
    world.step()
    world.set_alive(1, False)  # the router went away: the watchdog stops the rover
    away = [o for _ in range(int(3.0 / world.clock.dt)) for o in world.step()]
    assert len(_of(away, ks.CANCEL_RESULT)) == 1  # published as it ended, but nothing re-sent to nobody
    world.set_alive(1, True)
    back = [o for _ in range(int(2.5 / world.clock.dt)) for o in world.step()]
    resent = _of(back, ks.CANCEL_RESULT)
    assert len(resent) >= 2 and all(r.reason == "cancelled" and r.action_id == 11 for r in resent)


def test_a_cancel_naming_an_ended_action_gets_its_end():
    world = _world()
    _send(world, ks.ROTATE_ACTION, m.RotateAction(degrees=5, action_id=2))
    ended = _of(_until_idle(world), ks.NAVIGATION_STATUS)[-1]
    assert _of(_send(world, ks.CANCEL_ACTION, m.CancelAction(action_id=2)), ks.NAVIGATION_STATUS) == [ended]
    refused = _of(_send(world, ks.CANCEL_ACTION, m.CancelAction(action_id=99)), ks.ACTION_REJECTED)
    assert refused[0].reason == "no_action"


def test_an_action_that_comes_after_its_own_cancel_never_starts():
    """A copy delayed on the way, after a cancel that found no such action: its agent settled where it stood, so
    started now, the rover would drive where its agent does not watch."""
    world = _world()
    (refusal,) = _of(_send(world, ks.CANCEL_ACTION, m.CancelAction(action_id=7)), ks.ACTION_REJECTED)
    assert refusal.reason == "no_action"
    late = _send(world, ks.MOVE_ACTION, m.MoveAction(x=0.0, z=1.0, action_id=7))
    assert not world.actuator.bodies[1].busy and _of(late, ks.ACTION_REJECTED)[0].reason == "stale"
    _send(world, ks.MOVE_ACTION, m.MoveAction(x=0.0, z=1.0, action_id=8))
    assert world.actuator.bodies[1].busy  # the agent's next action starts


def test_a_photo_action_while_the_rover_turns_leaves_the_turn_named_in_its_status_and_end():
    """The camera works beside a turn: an id-less photo action (anyone's, in open mode) leaves the turn's record,
    so the agent asking after its turn hears it running, not refused as "in progress" while its rover turns
    unwatched: its dead reckoning would go wrong, and its rover end "done" far from its goal."""
    world = _world()
    _send(world, ks.ROTATE_ACTION, m.RotateAction(degrees=90, action_id=7))
    assert _send(world, ks.PHOTO_ACTION, m.PhotoAction(label="../../x")) == []
    (asked,) = _of(_send(world, ks.ROTATE_ACTION, m.RotateAction(degrees=90, action_id=7)), ks.NAVIGATION_STATUS)
    assert asked.action_id == 7 and asked.outcome == "running"
    statuses = _of(_until_idle(world), ks.NAVIGATION_STATUS)
    assert statuses[-1].outcome == "completed" and {s.action_id for s in statuses} == {7}
    assert [job.label for job in world.shutter.jobs] == ["../../x"]


# ---- the agent's side ----


def _moving_agent(state_file: Path | None = None) -> RoverAgent:
    agent = joined_agent(1, KEYS, load_scenario(SCENARIOS / "crater_observation.yaml").rover_params,
                         state_file=state_file)
    agent.handle(ks.CALIBRATION, codec.encode(m.Calibration(x=0.0, z=20.0, heading_deg=180.0)))
    agent.handle(ks.MISSION_DIRECTION, codec.encode(m.MissionDirection(goal_index=0, goals_total=1, kind="waypoint",
                                                                       bearing_deg=180.0, distance_m=100.0)))
    agent.handle(ks.GYROSCOPE, codec.encode(m.Gyroscope(stamp=0.1, pitch_deg=0.0)))
    (key, move), = agent.handle(ks.PERCEPTION, codec.encode(m.Perception(stamp=0.2, angles_deg=[], distances_m=[],
                                                                          kinds=[])))
    assert key == KEYS.rover(1, ks.MOVE_ACTION) and move.action_id > 0
    return agent


def _clock(t: float) -> m.Clock:
    return m.Clock(tick=round(t / 0.05), sim_time=t, time_scale=1.0, run=RUN)


def test_an_agent_that_hears_nothing_of_its_action_asks_again_with_the_same_id():
    agent = _moving_agent()
    sent = agent.actions.in_flight.action_id
    assert not [key for key, _ in agent.on_clock(_clock(0.2 + ACTION_QUERY_S / 2)) if key.endswith(ks.MOVE_ACTION)]
    asked = [msg for key, msg in agent.on_clock(_clock(0.3 + ACTION_QUERY_S)) if key.endswith(ks.MOVE_ACTION)]
    assert len(asked) == 1 and asked[0].action_id == sent
    assert agent.actions.in_flight.query_due() == pytest.approx(0.3 + 2 * ACTION_QUERY_S)
    assert agent.next_wake() <= agent.actions.in_flight.query_due()  # a lockstep world waits for the query


def test_running_status_keeps_the_agent_from_asking():
    agent = _moving_agent()
    sent = agent.actions.in_flight.action_id
    for t in (0.4, 1.0, 1.6, 2.2, 2.8):
        agent.handle(ks.NAVIGATION_STATUS, codec.encode(m.NavigationStatus(stamp=t, action="move", remaining=3.0,
                                                                           action_id=sent)))
        assert not [k for k, _ in agent.on_clock(_clock(t)) if k.endswith(ks.MOVE_ACTION)]


def test_an_old_actions_end_sent_again_does_not_end_the_new_one():
    agent = _moving_agent()
    old = m.NavigationStatus(stamp=0.5, action="move", remaining=0.0, outcome="completed",
                             action_id=agent.actions.in_flight.action_id - 1)
    agent.handle(ks.NAVIGATION_STATUS, codec.encode(old))
    assert agent.actions.in_flight is not None and agent.pose == Pose(0.0, 20.0, 180.0)


def test_a_cancel_the_world_never_had_an_action_for_settles_where_it_started():
    agent = _moving_agent()
    flight = agent.actions.in_flight
    agent.handle(ks.ACTION_REJECTED, codec.encode(m.ActionRejected(action="cancel", reason="no_action",
                                                                   action_id=flight.action_id)))
    assert agent.actions.in_flight is None and agent.pose == flight.start


def test_ids_of_an_agent_restarted_without_its_state_never_repeat_its_earlier_ones():
    first = ActionIds()
    earlier = [first.take(t) for t in (0.0, 0.2, 0.4)]
    assert earlier == [1, 2, 3]
    later = ActionIds()
    assert later.take(0.6) > max(earlier)


# ---- restarts ----


def test_a_restarted_agent_resumes_its_pose_and_asks_how_its_action_ended(tmp_path):
    path = tmp_path / "rover1.json"
    agent = _moving_agent(path)
    flight = agent.actions.in_flight
    agent._save()
    from rover_agent.restarts.saved_state import STATE_WRITER

    STATE_WRITER.flush()
    saved = load_state(path)
    assert saved.run == RUN and saved.flight.action_id == flight.action_id
    again = RoverAgent(1, KEYS, agent.params, state_file=path)
    asked = again.on_clock(_clock(30.0))
    assert again.pose == Pose(0.0, 20.0, 180.0)
    assert [msg.action_id for key, msg in asked if key.endswith(ks.MOVE_ACTION)] == [flight.action_id]
    done = m.NavigationStatus(stamp=30.0, action="move", remaining=0.0, outcome="completed",
                              action_id=flight.action_id)
    again.handle(ks.NAVIGATION_STATUS, codec.encode(done))
    assert again.actions.in_flight is None and again.pose.z == pytest.approx(20.0 - flight.decision.z)


def test_a_state_saved_in_another_run_is_not_resumed(tmp_path):
    path = tmp_path / "rover1.json"
    save_state(path, SavedState("old-run", Pose(50.0, 50.0, 0.0)))
    agent = joined_agent(1, KEYS, _moving_agent().params, state_file=path)
    assert agent.pose is None and not agent.restarts.lost


def test_an_agent_joining_late_without_a_saved_pose_says_it_is_lost_and_does_not_drive(caplog):
    agent = RoverAgent(1, KEYS, _moving_agent().params)
    agent.on_clock(_clock(40.0))
    assert agent.restarts.lost and "does not know where it is" in caplog.text
    agent.handle(ks.CALIBRATION, codec.encode(m.Calibration(x=0.0, z=20.0, heading_deg=180.0)))
    assert agent.pose is None  # the dispatch pose is not where a rover 40 s into its mission stands
    status = agent.status()[1]
    assert "position unknown" in status.detail


def test_a_restarted_agent_neither_acts_nor_assumes_a_pose_before_its_first_clock(tmp_path):
    """Perception can reach a restarted agent before the clock: long silence from the lander then looks like a
    lost calibration, and an action sent on an assumed pose would outrank every id the agent resumes with."""
    path = tmp_path / "rover1.json"
    flight = _moving_agent().actions.in_flight
    save_state(path, SavedState(RUN, Pose(0.0, 20.0, 180.0), flight.saved(), flight.action_id + 1))
    again = RoverAgent(1, KEYS, _moving_agent().params, state_file=path,
                       dispatch=m.Calibration(x=0.0, z=20.0, heading_deg=180.0))
    for t in range(30, 90, 5):
        again.handle(ks.GYROSCOPE, codec.encode(m.Gyroscope(stamp=float(t), pitch_deg=0.0)))
        assert again.handle(ks.PERCEPTION, codec.encode(m.Perception(stamp=float(t), angles_deg=[], distances_m=[],
                                                                      kinds=[]))) == []
    assert again.pose is None and again.actions.in_flight is None
    asked = again.on_clock(_clock(90.0))
    assert [msg.action_id for key, msg in asked if key.endswith(ks.MOVE_ACTION)] == [flight.action_id]


def test_an_action_refused_as_older_than_the_rovers_latest_renews_the_agents_ids():
    """The world has a later action of this rover than the agent knows of (an earlier life's): the agent's next
    ids must outrank it, or every action it sends is refused as stale."""
    world = _world()
    while world.clock.sim_time < 12.5:  # the earlier life ran past 10 s, and the agent's clock (12 s) lags the world's
        world.step()
    earlier = ActionIds().take(10.0)
    _send(world, ks.MOVE_ACTION, m.MoveAction(x=0.0, z=1.0, action_id=earlier))
    _until_idle(world)
    agent = _moving_agent()
    out = _send(world, ks.MOVE_ACTION, agent.actions.in_flight.request(agent.send)[1])
    (refusal,) = _of(out, ks.ACTION_REJECTED)
    assert refusal.reason == "stale"
    agent.handle(ks.ACTION_REJECTED, codec.encode(refusal))
    assert agent.actions.in_flight is None and agent.pose == Pose(0.0, 20.0, 180.0)
    agent.handle(ks.GYROSCOPE, codec.encode(m.Gyroscope(stamp=12.0, pitch_deg=0.0)))
    (_, move), = agent.handle(ks.PERCEPTION, codec.encode(m.Perception(stamp=12.0, angles_deg=[], distances_m=[],
                                                                          kinds=[])))
    assert move.action_id > earlier
    assert _of(_send(world, ks.MOVE_ACTION, move), ks.NAVIGATION_STATUS)[0].action_id == move.action_id


# ---- whole missions over a lossy link (in process, lockstep) ----


def _world_to_agents(keys: Keyspace):
    inputs = set(World.INPUT_TOPICS) | {ks.ACK}

    def from_world(key: str) -> bool:
        if key.startswith(f"{keys.prefix}/rover/"):
            return key.rsplit("/", 1)[-1] not in inputs
        return key in (keys.lander(ks.COMM_IN), keys.lander(ks.COMM_PARTNERS))

    return from_world


@pytest.mark.parametrize("loss", [0.05, 0.2])
def test_crater_mission_completes_with_random_loss_on_every_world_to_agent_key(loss):
    scenario = load_scenario(SCENARIOS / "crater_observation.yaml")
    rng = random.Random(7)
    from_world = _world_to_agents(ks.Keyspace("loopback"))
    world = run_mission(scenario, 400.0, drop=lambda key, _: from_world(key) and rng.random() < loss)
    report = world.report()
    assert report.complete and report.rovers_reached_final_goal == 5, report
    assert report.rover_collisions == 0 and report.rovers_stalled == 0, report


def test_mission_completes_when_every_action_end_is_lost_the_first_time():
    """The mechanism alone: the first end of each action is lost; the re-sent end or the agent's query ends it."""
    scenario = load_scenario(SCENARIOS / "crater_observation.yaml")
    seen: set[tuple[str, int]] = set()

    def first_end(key: str, message: m.Message) -> bool:
        if isinstance(message, m.NavigationStatus | m.CancelResult) and getattr(message, "outcome", "x") != "running":
            mark = (key, message.action_id)
            if mark not in seen:
                seen.add(mark)
                return True
        return False

    report = run_mission(scenario, 400.0, drop=first_end).report()
    assert seen and report.complete and report.rovers_reached_final_goal == 5, report


def test_one_camera_takes_one_photo_at_a_time_so_a_flood_of_photo_actions_queues_no_renders():
    world = _world()
    assert _send(world, ks.PHOTO_ACTION, m.PhotoAction(label="a", action_id=1)) == []
    refused = _of(_send(world, ks.PHOTO_ACTION, m.PhotoAction(label="b", action_id=2)), ks.ACTION_REJECTED)
    assert [(r.reason, r.action_id) for r in refused] == [("action_in_progress", 2)]
    assert len(world.shutter.jobs) == 1
    while world.clock.sim_time < world.scenario.rover_params.camera.capture_time_s:
        world.step()
    assert _send(world, ks.PHOTO_ACTION, m.PhotoAction(label="c", action_id=3)) == []
    assert len(world.shutter.jobs) == 2
    _send(world, ks.ROTATE_ACTION, m.RotateAction(degrees=0.5, action_id=4))  # another action between photos
    refused = _of(_send(world, ks.PHOTO_ACTION, m.PhotoAction(label="d", action_id=5)), ks.ACTION_REJECTED)
    assert [r.reason for r in refused] == ["action_in_progress"] and len(world.shutter.jobs) == 2
