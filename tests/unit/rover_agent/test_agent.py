"""The whole rover agent (``rover_agent.agent``) fed encoded samples, no router: from calibration and a mission
direction to actions, the world's answers to them, reports to the lander and station requests."""

from __future__ import annotations

import math

import pytest
from agent_kit import BOXED_IN, PARAMS, joined_agent

from rover_agent.mission.stations import STATION_ASK_M, STATION_ASK_RETRY_S
from rover_agent.rules.tuning import MAX_BLOCKED_ROTATIONS
from schemas import codec, radio
from schemas import keyspace as ks
from schemas import messages as m
from shared.pose import Pose

KEYS = ks.Keyspace("w")


def _feed(agent, message):
    topic = next(t for t, model in m.TOPIC_MODELS.items() if model is type(message))
    return agent.handle(topic, codec.encode(message))


def _ready_agent(x=0.0, z=20.0, heading=180.0, bearing=180.0, distance=100.0, kind="waypoint"):
    """An agent told where it stands and where to go (the goal 100 m south of the lander by default)."""
    agent = joined_agent(1, KEYS, PARAMS)
    assert _feed(agent, m.Calibration(x=x, z=z, heading_deg=heading)) == []
    out = _feed(agent, m.MissionDirection(goal_index=0, goals_total=1, kind=kind, bearing_deg=bearing,
                                          distance_m=distance))
    assert [key for key, _ in out] == [KEYS.rover(1, ks.STATUS)]
    assert out[0][1].state == "migration" and out[0][1].goal_index == 0
    return agent


def test_agent_emits_a_move_action_after_calibration_direction_gyroscope_and_perception():
    agent = _ready_agent()
    assert agent.pose == Pose(0.0, 20.0, 180.0)
    assert _feed(agent, m.Perception(stamp=0.05, angles_deg=[], distances_m=[], kinds=[])) == []  # no pitch yet
    assert _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0)) == []
    out = _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert len(out) == 1
    key, move = out[0]
    assert key == "lunar/w/rover/1/move_action"
    assert isinstance(move, m.MoveAction)
    assert move.x == pytest.approx(0.0, abs=1e-3) and move.z == pytest.approx(9.0)
    # one action in flight: further perception does not start another
    assert _feed(agent, m.Perception(stamp=0.4, angles_deg=[], distances_m=[], kinds=[])) == []


def test_agent_does_nothing_without_calibration_or_goal():
    agent = joined_agent(1, KEYS, PARAMS)
    _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0))
    assert _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[])) == []
    _feed(agent, m.Calibration(x=0.0, z=0.0, heading_deg=0.0))
    assert _feed(agent, m.Perception(stamp=0.3, angles_deg=[], distances_m=[], kinds=[])) == []


def _moving_agent():
    agent = _ready_agent()
    _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0))
    (key, _), = _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert key == KEYS.rover(1, ks.MOVE_ACTION)
    return agent


def test_completed_move_updates_the_pose_by_dead_reckoning():
    agent = _moving_agent()
    out = _feed(agent, m.NavigationStatus(stamp=0.6, action="move", remaining=4.0))
    assert out == [] and agent.pose == Pose(0.0, 20.0, 180.0)  # running: nothing changes yet
    assert _feed(agent, m.NavigationStatus(stamp=3.0, action="move", remaining=0.0, outcome="completed")) == []
    assert agent.actions.in_flight is None
    assert agent.pose.x == pytest.approx(0.0, abs=1e-6)
    assert agent.pose.z == pytest.approx(11.0)
    assert agent.pose.heading == pytest.approx(180.0, abs=1e-6)


def test_agent_decides_again_only_on_data_taken_after_the_move():
    agent = _moving_agent()
    _feed(agent, m.NavigationStatus(stamp=3.0, action="move", remaining=0.0, outcome="completed"))
    assert _feed(agent, m.Perception(stamp=2.9, angles_deg=[], distances_m=[], kinds=[])) == []  # stale scan
    assert _feed(agent, m.Perception(stamp=3.1, angles_deg=[], distances_m=[], kinds=[])) == []  # stale pitch
    _feed(agent, m.Gyroscope(stamp=3.05, pitch_deg=0.0))
    out = _feed(agent, m.Perception(stamp=3.2, angles_deg=[], distances_m=[], kinds=[]))
    assert [key for key, _ in out] == [KEYS.rover(1, ks.MOVE_ACTION)]


def test_completed_rotate_updates_the_heading():
    agent = _ready_agent(bearing=0.0)  # goal north of the lander, behind a rover facing south
    _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0))
    (key, rotate), = _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert key == KEYS.rover(1, ks.ROTATE_ACTION) and abs(rotate.degrees) == pytest.approx(180.0)
    _feed(agent, m.NavigationStatus(stamp=2.0, action="rotate", remaining=0.0, outcome="completed"))
    assert ((agent.pose.heading + 180.0) % 360.0 - 180.0) == pytest.approx(0.0, abs=1e-6)
    assert (agent.pose.x, agent.pose.z) == (0.0, 20.0)


def test_rover_close_ahead_during_a_move_sends_one_cancel_and_the_result_sets_the_pose():
    agent = _moving_agent()
    rover_ahead = m.Perception(stamp=0.4, angles_deg=[0.0], distances_m=[2.0], kinds=["rover"])
    flight = agent.actions.in_flight.action_id
    assert _feed(agent, rover_ahead) == [(KEYS.rover(1, ks.CANCEL_ACTION), m.CancelAction(action_id=flight))]
    assert _feed(agent, rover_ahead) == []  # once
    _feed(agent, m.NavigationStatus(stamp=0.6, action="move", remaining=0.0, outcome="cancelled"))
    assert agent.pose == Pose(0.0, 20.0, 180.0)
    _feed(agent, m.CancelResult(x=0.0, z=3.0, angle_deg=0.0))
    assert agent.actions.in_flight is None
    assert agent.pose.x == pytest.approx(0.0, abs=1e-9) and agent.pose.z == pytest.approx(17.0)


def test_rover_to_the_side_during_a_move_does_not_cancel():
    agent = _moving_agent()
    assert _feed(agent, m.Perception(stamp=0.4, angles_deg=[90.0], distances_m=[2.0], kinds=["rover"])) == []


def test_rejected_move_settles_and_tries_another_direction():
    agent = _moving_agent()
    _feed(agent, m.ActionRejected(action="move", reason="blocked"))
    assert agent.actions.in_flight is None
    _feed(agent, m.Gyroscope(stamp=0.3, pitch_deg=0.0))
    (key, move), = _feed(agent, m.Perception(stamp=0.4, angles_deg=[], distances_m=[], kinds=[]))
    assert key == KEYS.rover(1, ks.MOVE_ACTION)
    assert math.degrees(math.atan2(move.x, move.z)) == pytest.approx(10.0, abs=1e-3)


def test_reaching_the_final_waypoint_reports_to_the_lander():
    agent = _ready_agent(z=5.0, bearing=0.0, distance=10.0, heading=0.0)  # goal 5 m ahead
    _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0))
    out = _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert [key for key, _ in out] == [KEYS.rover(1, ks.COMM_OUT), KEYS.rover(1, ks.STATUS)]
    comm = out[0][1]
    assert comm.targets == [ks.LANDER_ID] and comm.channel == "comm_in"
    assert radio.unpack(comm.payload) == radio.GoalReport(goal_index=0, outcome="reached")
    assert out[1][1].state == "done" and agent.state == "done"
    assert _feed(agent, m.Perception(stamp=0.4, angles_deg=[], distances_m=[], kinds=[])) == []


def test_garbage_payloads_are_counted_and_answered_with_nothing():
    agent = _ready_agent()
    assert agent.handle(ks.PERCEPTION, b"\x93garbage") == []
    assert agent.handle(ks.GYROSCOPE, codec.encode(m.MoveAction(x=1.0, z=1.0))) == []
    assert agent.handle("no_such_topic", b"") == []
    assert agent.rejected.total == 3
    assert agent.pose == Pose(0.0, 20.0, 180.0)


def _station_requests(out, rover: int = 1) -> list[radio.StationRequest]:
    messages = [radio.unpack(msg.payload) for key, msg in out if key == KEYS.rover(rover, ks.COMM_OUT)]
    return [msg for msg in messages if isinstance(msg, radio.StationRequest)]


def test_near_a_shared_waypoint_the_agent_asks_for_its_station_until_it_comes():
    agent = joined_agent(1, KEYS, PARAMS)
    _feed(agent, m.Calibration(x=0.0, z=0.0, heading_deg=0.0))
    shared = {"goal_index": 0, "goals_total": 1, "kind": "waypoint", "bearing_deg": 0.0, "distance_m": 40.0,
              "shared": True}
    _feed(agent, m.MissionDirection(**shared))

    def perceive(stamp):
        return _station_requests(_feed(agent, m.Perception(stamp=stamp, angles_deg=[], distances_m=[], kinds=[])))

    assert perceive(0.2) == []  # 40 m away: not yet
    agent.estimator.place(Pose(0.0, 40.0 - STATION_ASK_M + 1.0, 0.0))
    assert perceive(0.4) == [radio.StationRequest(goal_index=0, x=0.0, z=26.0)]
    assert perceive(0.6) == []  # not again at once...
    assert len(perceive(0.4 + STATION_ASK_RETRY_S)) == 1  # ...but again when no answer came
    _feed(agent, m.MissionDirection(**shared, station=(3.2, 0.0)))
    assert agent.mission.goal.target == (3.2, 40.0)
    assert perceive(10.0) == []


def test_a_stuck_rover_says_why_in_its_status():
    agent = _ready_agent()
    statuses = []
    for k in range(3 * MAX_BLOCKED_ROTATIONS):
        t = 1.0 + k
        _feed(agent, m.Gyroscope(stamp=t, pitch_deg=0.0))
        out = _feed(agent, m.Perception(stamp=t + 0.05, angles_deg=[h.angle_deg for h in BOXED_IN],
                                        distances_m=[h.distance_m for h in BOXED_IN], kinds=[h.kind for h in BOXED_IN]))
        statuses += [msg for key, msg in out if key == KEYS.rover(1, ks.STATUS)]
        if agent.state == "stuck":
            break
        assert agent.actions.in_flight is not None  # a rotation: the world says it is done
        _feed(agent, m.NavigationStatus(stamp=t + 0.1, action="rotate", remaining=0.0, outcome="completed",
                                        action_id=agent.actions.in_flight.action_id))
    assert statuses and statuses[-1].state == "stuck"
    assert statuses[-1].detail.endswith("without finding a free way")


def test_the_agent_asks_for_a_crest_station_once_crater_terrain_is_in_view_or_from_inside_the_bowl():
    """The rover does not know the crater's size: it asks once the crater's terrain is in view, however far from
    the goal. Inside the bowl it sees no rim ahead (a crater's terrain shows where a ray enters it), and without a
    station it would walk to and fro across the goal for ever: near the goal, it asks by the distance."""
    agent = joined_agent(1, KEYS, PARAMS)
    _feed(agent, m.Calibration(x=0.0, z=0.0, heading_deg=0.0))
    _feed(agent, m.MissionDirection(goal_index=0, goals_total=1, kind="crater", bearing_deg=0.0, distance_m=60.0,
                                    shared=True))
    nothing = m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[])
    agent.estimator.place(Pose(0.0, 30.0, 0.0))  # 30 m out, nothing of the crater in view
    assert _station_requests(_feed(agent, nothing)) == []
    seen = m.Perception(stamp=0.4, angles_deg=[0.0], distances_m=[8.0], kinds=["crater_terrain"])
    assert _station_requests(_feed(agent, seen)) == [radio.StationRequest(goal_index=0, x=0.0, z=30.0)]
    inside = joined_agent(2, KEYS, PARAMS)
    _feed(inside, m.Calibration(x=0.0, z=0.0, heading_deg=0.0))
    _feed(inside, m.MissionDirection(goal_index=0, goals_total=1, kind="crater", bearing_deg=0.0, distance_m=60.0,
                                     shared=True))
    inside.estimator.place(Pose(0.0, 55.0, 0.0))  # in the bowl, 5 m from the goal: no rim in view
    out = _feed(inside, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert _station_requests(out, rover=2) == [radio.StationRequest(goal_index=0, x=0.0, z=55.0)]
