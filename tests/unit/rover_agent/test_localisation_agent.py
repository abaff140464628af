"""The pose estimator inside the rover agent (``rover_agent.estimation.estimator``), fed scripted samples as the world
and the radio would send them: zero noise changes nothing, the lander seen corrects the estimate, teammates in range
hear it, and a rover too unsure for its waypoint goes by the lander first (``rover_agent.estimation.lander_fix``)."""

from __future__ import annotations

import itertools
import math

import msgspec
import pytest
from agent_kit import joined_agent
from hostile import pack_radio

from harness.loopback import run_mission
from rover_agent.agent import RoverAgent
from rover_agent.estimation.estimator import Estimator
from rover_agent.estimation.lander_fix import (
    DETAIL,
    FIX_STD_M,
    LANDER_GOAL,
    MAX_RINGS,
    RING_SPACING,
    SEARCH_SIGMAS,
    LanderFix,
    search_spots,
)
from rover_agent.estimation.pose_filter import Localisation, NoiseModel
from rover_agent.restarts.saved_state import SavedState
from scenarios.generator import generate
from schemas import codec, radio
from schemas import keyspace as ks
from schemas import messages as m
from schemas.frames import to_relative
from schemas.keyspace import Keyspace
from schemas.params import RoverParams
from shared.pose import Pose

KEYS = Keyspace("w")
QUIET = RoverParams()
NOISY = msgspec.convert({"navigation": {"slip_std": 0.05, "heading_noise_std_deg": 1.0}}, RoverParams)


def _feed(agent: RoverAgent, message: m.Message) -> list:
    topic = next(t for t, model in m.TOPIC_MODELS.items() if model is type(message))
    return agent.handle(topic, codec.encode(message))


def _lander_scan(stamp: float, truth: Pose) -> m.Perception:
    """The lander (radius 1.5 at the origin) as a scan from the true pose shows it."""
    p = QUIET.perception
    angles, distances = [], []
    for i in range(p.perception_granularity):
        angle = -p.field_of_view_degrees / 2 + i * p.field_of_view_degrees / (p.perception_granularity - 1)
        h = math.radians(truth.heading + angle)
        dx, dz = math.sin(h), math.cos(h)
        b, c = truth.x * dx + truth.z * dz, truth.x ** 2 + truth.z ** 2 - 1.5 ** 2
        if b * b - c >= 0 and (t := -b - math.sqrt(b * b - c)) > 0 and t <= p.perception_radius:
            angles.append(round(angle, 3))
            distances.append(round(t, 3))
    return m.Perception(stamp=stamp, angles_deg=angles, distances_m=distances, kinds=["lander"] * len(angles))


def _walked(params: RoverParams, partners: list[int] = ()) -> RoverAgent:
    """An agent calibrated 15 m south of the lander facing north, a goal far east, one 9 m move done: the lander
    is 6 m ahead."""
    agent = joined_agent(1, KEYS, params)
    _feed(agent, m.Calibration(x=0.0, z=-15.0, heading_deg=0.0))
    _feed(agent, m.MissionDirection(goal_index=0, goals_total=1, kind="waypoint", bearing_deg=20.0, distance_m=300.0))
    _feed(agent, m.CommPartners(ids=[0, *partners]))
    _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0))
    (key, _), = [o for o in _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
                    if o[0] != KEYS.rover(1, ks.COMM_OUT)]
    assert key == KEYS.rover(1, ks.MOVE_ACTION)
    _feed(agent, m.NavigationStatus(stamp=3.0, action="move", remaining=0.0, outcome="completed",
                                    action_id=agent.actions.in_flight.action_id))
    _feed(agent, m.Gyroscope(stamp=3.1, pitch_deg=0.0))
    return agent


def _estimates(out: list) -> list[radio.PoseEstimate]:
    return [radio.unpack(msg.payload) for key, msg in out if key == KEYS.rover(1, ks.COMM_OUT)
            and isinstance(radio.unpack(msg.payload), radio.PoseEstimate)]


def test_without_noise_the_lander_seen_changes_nothing_and_nothing_is_told():
    agent = _walked(QUIET, partners=[2])
    assert agent.estimator.localisation.exact
    before = agent.pose
    truth = Pose(0.3, -6.2, 3.0)  # wherever the rover really is, an exact estimate is not corrected
    out = _feed(agent, _lander_scan(3.2, truth))
    assert agent.pose.x == before.x and agent.pose.z == before.z and _estimates(out) == []


def test_the_lander_seen_standing_still_corrects_the_estimate():
    agent = _walked(NOISY)
    p = agent.pose
    assert math.hypot(p.x, p.z + 15.0) == pytest.approx(9.0, abs=1e-3)
    assert agent.estimator.localisation.position_std > 0.4
    truth = Pose(p.x + 0.5, p.z - 0.4, p.heading + 2.0)  # the move slipped and turned
    for stamp in (3.2, 3.4, 3.6):  # each scan sets a move off, which the world refuses: it stays where it is
        _feed(agent, m.Gyroscope(stamp=stamp - 0.05, pitch_deg=0.0))
        _feed(agent, _lander_scan(stamp, truth))
        _feed(agent, m.ActionRejected(action="move", reason="blocked", action_id=agent.actions.in_flight.action_id))
    seen = to_relative(truth.x, truth.z, truth.heading, 0.0, 0.0)
    assert to_relative(agent.pose.x, agent.pose.z, agent.pose.heading, 0.0, 0.0) == pytest.approx(seen, abs=0.1)
    assert math.hypot(agent.pose.x - truth.x, agent.pose.z - truth.z) < 0.4


def test_a_scan_taken_during_a_move_corrects_nothing():
    agent = _walked(NOISY)
    _feed(agent, m.Perception(stamp=3.2, angles_deg=[], distances_m=[], kinds=[]))  # decides: a move in flight
    assert agent.actions.in_flight is not None
    before = agent.pose
    _feed(agent, _lander_scan(3.4, Pose(0.5, -6.4, 2.0)))
    assert agent.pose == before


def test_the_estimate_goes_to_the_rovers_in_range_once_a_second():
    agent = _walked(NOISY, partners=[2, 5])
    out = _feed(agent, m.Perception(stamp=3.2, angles_deg=[], distances_m=[], kinds=[]))
    (sent,) = [msg for key, msg in out if key == KEYS.rover(1, ks.COMM_OUT)]
    assert sent.targets == [2, 5]
    (estimate,) = _estimates(out)
    assert (estimate.x, estimate.z) == (round(agent.pose.x, 3), round(agent.pose.z, 3))
    assert estimate.moving  # between two moves: it may have set off by the time a teammate sees it
    assert estimate.cov_xx == pytest.approx(agent.estimator.localisation.cov[0][0], abs=1e-6) and estimate.cov_xx > 0
    assert _estimates(_feed(agent, m.Perception(stamp=3.4, angles_deg=[], distances_m=[], kinds=[]))) == []
    # walking: where the move has got to, from the world's metres still to go
    _feed(agent, m.NavigationStatus(stamp=4.0, action="move", remaining=6.0,
                                    action_id=agent.actions.in_flight.action_id))
    (walking,) = _estimates(_feed(agent, m.Perception(stamp=4.2, angles_deg=[], distances_m=[], kinds=[])))
    assert walking.moving and walking.stamp == 4.0
    assert math.hypot(walking.x - agent.pose.x, walking.z - agent.pose.z) == pytest.approx(3.0, abs=1e-3)


def test_a_rover_done_at_its_goal_says_it_stays_there():
    agent = _walked(NOISY, partners=[2])
    agent.behaviour.state = "done"
    (estimate,) = _estimates(_feed(agent, m.Perception(stamp=3.2, angles_deg=[], distances_m=[], kinds=[])))
    assert not estimate.moving


def test_nobody_in_range_hears_nothing():
    agent = _walked(NOISY)
    assert _estimates(_feed(agent, m.Perception(stamp=3.2, angles_deg=[], distances_m=[], kinds=[]))) == []


def test_a_teammates_estimate_is_kept_latest_first():
    agent = _walked(NOISY)  # its clock: 3.1 (an estimate stamped more than a second ahead of it is dropped)
    for stamp, x in ((3.0, 1.0), (2.5, 2.0)):
        estimate = radio.PoseEstimate(stamp=stamp, x=x, z=0.0, cov_xx=1.0, cov_xz=0.0, cov_zz=1.0)
        _feed(agent, m.InboundComm(sender=3, payload=radio.pack(estimate)))
    assert agent.estimator.teammates[3].estimate.x == 1.0


def test_the_saved_state_keeps_the_covariance():
    agent = _walked(NOISY)
    state = SavedState("run", agent.pose, None, 7, agent.estimator.localisation.cov)
    again = SavedState.from_json(state.to_json())
    assert again.cov == agent.estimator.localisation.cov and again.pose == agent.pose
    assert SavedState.from_json(SavedState("run", agent.pose).to_json()).cov is None  # older files load too


def _unsure_with_a_return(distance: float, bearing: float = 90.0) -> RoverAgent:
    """A noisy rover 120 m north of the lander, unsure by several metres, sent to a waypoint (by default back near
    the lander)."""
    agent = joined_agent(1, KEYS, NOISY)
    agent.estimator.place(Pose(0.0, 120.0, 180.0))
    agent.estimator.localisation.cov = [[16.0, 0.0, 0.0], [0.0, 16.0, 0.0], [0.0, 0.0, math.radians(3.0) ** 2]]
    _feed(agent, m.MissionDirection(goal_index=1, goals_total=2, kind="waypoint", bearing_deg=bearing,
                                    distance_m=distance))
    _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0))
    return agent


def test_a_rover_too_unsure_for_its_waypoint_goes_by_the_lander_first():
    agent = _unsure_with_a_return(25.0)
    assert agent.estimator.localisation.predicted_std(agent.mission.goal.target, 9.0) > FIX_STD_M
    out = _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert agent.estimator.fix.active and agent.view(0.2, agent.pose, ()).goal == LANDER_GOAL
    assert [key for key, _ in out] == [KEYS.rover(1, ks.MOVE_ACTION)]
    assert agent.status()[1].detail == DETAIL


def test_a_waypoint_the_lander_is_far_off_the_way_to_is_not_worth_going_by_it():
    agent = _unsure_with_a_return(240.0, bearing=0.0)  # 120 m on, away from the lander
    _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert not agent.estimator.fix.active and agent.view(0.2, agent.pose, ()).goal == agent.mission.goal


def test_once_sure_again_the_rover_goes_on_to_its_goal():
    agent = _unsure_with_a_return(25.0)
    _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    _feed(agent, m.NavigationStatus(stamp=3.0, action="move", remaining=0.0, outcome="completed",
                                    action_id=agent.actions.in_flight.action_id))
    agent.estimator.localisation.cov = [[0.2, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 1e-4]]  # as if it saw the lander
    _feed(agent, m.Gyroscope(stamp=3.1, pitch_deg=0.0))
    _feed(agent, m.Perception(stamp=3.2, angles_deg=[], distances_m=[], kinds=[]))
    assert not agent.estimator.fix.active and agent.view(3.2, agent.pose, ()).goal == agent.mission.goal
    assert agent.estimator.fix.decided == 1  # once a goal: it does not set off for the lander again


def test_a_noise_free_rover_never_goes_by_the_lander():
    agent = joined_agent(1, KEYS, QUIET)
    agent.estimator.place(Pose(0.0, 120.0, 180.0))
    _feed(agent, m.MissionDirection(goal_index=1, goals_total=2, kind="waypoint", bearing_deg=90.0, distance_m=25.0))
    _feed(agent, m.Gyroscope(stamp=0.1, pitch_deg=0.0))
    _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert not agent.estimator.fix.active


def test_a_rover_that_does_not_see_the_lander_where_it_thought_looks_round_then_searches_then_goes_on():
    fix = LanderFix(decided=1, active=True)
    assert fix.goal == LANDER_GOAL
    assert fix.arrived("reached", (0.5, 0.5), 10.0) == "look"
    assert fix.arrived("reached", (0.5, 0.5), 10.0) == "search"
    first = fix.goal
    assert math.hypot(first.x, first.z) == pytest.approx(10.0) and first.kind == "waypoint"
    seen = [first]
    while fix.arrived("reached", (first.x, first.z), 10.0) == "search":
        seen.append(fix.goal)
    assert len({(g.x, g.z) for g in seen}) == 4  # four spots round the estimated place, then on to its goal
    assert LanderFix(active=True).arrived("stuck", (0.0, 0.0), 10.0) == "over"  # no closer: on to its goal


def test_a_rover_done_with_an_unsure_estimate_says_how_far_off_it_may_be():
    agent = joined_agent(1, KEYS, NOISY)
    agent.estimator.place(Pose(0.0, 40.0, 0.0))
    agent.behaviour.state = "done"
    assert agent.status()[1].detail == ""  # sure of its pose: nothing to say
    agent.estimator.localisation.cov = [[32.0, 0.0, 0.0], [0.0, 32.0, 0.0], [0.0, 0.0, 1e-3]]
    assert agent.status()[1].detail == "at its goal by its own estimate, which may be 8 m off (1 sigma)"


def test_a_search_spot_the_rover_cannot_reach_is_passed_over_not_the_end_of_the_search():
    fix = LanderFix(decided=1, active=True, looked=True)
    fix.arrived("reached", (0.0, 0.0), 10.0, 20.0)
    first = fix.goal
    assert fix.arrived("stuck", (0.0, 0.0), 10.0, 20.0) == "search"
    assert (fix.goal.x, fix.goal.z) != (first.x, first.z)


def test_a_search_whose_estimate_becomes_much_surer_goes_back_to_look_where_the_lander_now_should_be():
    fix = LanderFix(decided=1, active=True, looked=True)
    fix.arrived("reached", (0.0, 0.0), 10.0, 9.0)  # planned for a 9 m error: two rings
    loc = Localisation(Pose(-16.5, 4.3, 0.0), NoiseModel(0.05, math.radians(1.0)),
                       [[2.4, 0.0, 0.0], [0.0, 2.4, 0.0], [0.0, 0.0, 1e-3]])  # a teammate seen: 2.2 m now
    assert fix.sharpened(loc) and fix.goal == LANDER_GOAL and not fix.looked
    assert not fix.sharpened(loc)  # not searching now: once per halving of the error
    assert fix.arrived("reached", (0.0, 0.0), 10.0, loc.position_std) == "look"
    assert fix.arrived("reached", (0.0, 0.0), 10.0, loc.position_std) == "search"
    assert len(fix.spots) == 5  # one ring for the surer estimate
    loc.cov = [[2.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 1e-3]]
    assert not fix.sharpened(loc)  # a little surer is not enough


def _farthest_unseen(way: list[tuple[float, float]], reach: float) -> float:
    """Over a grid of points within ``reach`` of the origin: the largest distance from one to the walk ``way``."""

    def to_leg(p, a, b):
        ax, az, bx, bz = *a, *b
        length2 = (bx - ax) ** 2 + (bz - az) ** 2
        t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((p[0] - ax) * (bx - ax) + (p[1] - az) * (bz - az)) / length2))
        return math.dist(p, (ax + t * (bx - ax), az + t * (bz - az)))

    grid = [(x, z) for x in range(-int(reach), int(reach) + 1) for z in range(-int(reach), int(reach) + 1)
            if math.hypot(x, z) <= reach]
    return max(min(to_leg(p, a, b) for a, b in itertools.pairwise(way)) for p in grid)


@pytest.mark.parametrize("position_std", [0.0, 6.0, 9.0, 20.0, 200.0])
def test_the_search_for_the_lander_sees_as_far_out_as_the_estimate_is_unsure(position_std):
    radius = 10.0
    spots = search_spots(radius, position_std, (0.5, 0.5))
    reach = min(SEARCH_SIGMAS * position_std, radius + (MAX_RINGS - 1) * RING_SPACING * radius)
    way = [(0.0, 0.0), *spots]  # it searches from the lander's estimated place, where it has turned round
    assert _farthest_unseen(way, max(reach, radius)) <= radius  # every place in reach passes in view
    if SEARCH_SIGMAS * position_std <= radius * (1.0 + math.cos(math.pi / 4)):  # in view from a square round it
        assert [math.hypot(*p) for p in spots] == pytest.approx([radius] * len(spots))  # one ring, a fairly sure rover
    assert max(math.hypot(*p) for p in spots) <= radius + (MAX_RINGS - 1) * RING_SPACING * radius + 1e-9


def _mission(localising: bool):
    """A generated noise-free mission whose rovers start within sight of the lander (the daisy family)."""
    made = generate(44)
    assert made.classes["noise"] == "none" and made.classes["family"] == "daisy"
    if not localising:  # plain dead reckoning: no corrections, nothing told, no way by the lander
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(Estimator, "localise", lambda self, *args: None)
            patch.setattr(Estimator, "share", lambda self, *args: None)
            patch.setattr(Estimator, "mind_fix", lambda self, goal: None)
            return run_mission(made.scenario, 120.0).report()
    return run_mission(made.scenario, 120.0).report()


def test_noise_free_missions_run_exactly_as_plain_dead_reckoning():
    with_estimator, without = _mission(True), _mission(False)
    unclocked = [msgspec.structs.replace(report, wall_time_s=None) for report in (with_estimator, without)]
    assert unclocked[0] == unclocked[1]


# ---- bad input: hostile estimates, stamps and senders; a corrupt saved covariance ----


def _heard(agent: RoverAgent, sender: int, estimate: radio.PoseEstimate | bytes) -> list:
    """Built unchecked (a Struct checks nothing when built): a hostile sender id is the receiver's to refuse; an
    estimate given as bytes is a radio payload as sent."""
    payload = estimate if isinstance(estimate, bytes) else radio.pack(estimate)
    return _feed(agent, m.InboundComm(sender=sender, payload=payload))


def test_a_teammates_estimate_that_is_no_covariance_is_rejected_and_corrupts_nothing():
    """cov_xz 0.25 with zero variances passed the schema; matched (one rover seen, one in range), it turned this
    rover's variances negative, and its own next PoseEstimate failed validation inside the perception handler."""
    from schemas.frames import to_world

    agent = _walked(NOISY, partners=[2])
    p = agent.pose
    x, z = to_world(p.x, p.z, p.heading, 0.0, 5.0)
    bad = pack_radio("pose_estimate", {"stamp": 3.0, "x": round(x, 3), "z": round(z, 3), "cov_xx": 0.0,
                                       "cov_xz": 0.25, "cov_zz": 0.0, "moving": False})
    _heard(agent, 2, bad)
    assert agent.rejected.total == 1 and 2 not in agent.estimator.teammates
    out = _feed(agent, m.Perception(stamp=3.2, angles_deg=[0.0], distances_m=[4.5], kinds=["rover"]))
    assert min(agent.estimator.localisation.cov[i][i] for i in range(3)) > 0 and _estimates(out)


def test_an_estimate_from_the_future_does_not_lock_the_teammates_real_ones_out():
    agent = _walked(NOISY)  # its clock: 3.1
    _heard(agent, 3, radio.PoseEstimate(stamp=1e9, x=50.0, z=50.0, cov_xx=0.01, cov_xz=0.0, cov_zz=0.01))
    _heard(agent, 3, radio.PoseEstimate(stamp=3.0, x=1.0, z=2.0, cov_xx=1.0, cov_xz=0.0, cov_zz=1.0))
    assert agent.estimator.teammates[3].estimate.stamp == 3.0 and agent.rejected.total == 1


@pytest.mark.parametrize("sender", [ks.LANDER_ID, 1, -4, 10**12])
def test_an_estimate_from_the_lander_itself_or_no_rover_is_dropped_and_counted(sender):
    agent = _walked(NOISY)
    _heard(agent, sender, radio.PoseEstimate(stamp=3.0, x=1.0, z=2.0, cov_xx=1.0, cov_xz=0.0, cov_zz=1.0))
    assert agent.estimator.teammates == {} and agent.rejected.total == 1


def test_teammates_not_heard_for_long_are_forgotten():
    """Never matched once stale, and a flood of senders must not pile up."""
    agent = _walked(NOISY)
    for sender in range(2, 40):
        _heard(agent, sender, radio.PoseEstimate(stamp=3.0, x=1.0, z=2.0, cov_xx=1.0, cov_xz=0.0, cov_zz=1.0))
    agent.now = 10.0
    _heard(agent, 2, radio.PoseEstimate(stamp=10.0, x=1.0, z=2.0, cov_xx=1.0, cov_xz=0.0, cov_zz=1.0))
    assert list(agent.estimator.teammates) == [2]


@pytest.mark.parametrize("cov", [[[math.nan, 0, 0], [0, 1, 0], [0, 0, 0.01]], [[-1, 0, 0], [0, -1, 0], [0, 0, 0.01]],
                                 [[1, 5, 0], [5, 1, 0], [0, 0, 0.01]], [[1, 0, 0], [0.5, 1, 0], [0, 0, 0.01]],
                                 [[math.inf, 0, 0], [0, 1, 0], [0, 0, 0.01]]])
def test_a_restart_with_a_corrupt_saved_covariance_resumes_without_it(tmp_path, cov):
    """A NaN variance (json reads NaN) crashed the agent at its first estimate told; a negative one likewise."""
    import json

    path = tmp_path / "rover1.json"
    path.write_text(json.dumps({"run": "r1", "pose": {"x": 0.0, "z": -6.0, "heading": 0.0}, "flight": None,
                                "next_action": 3, "cov": cov}))
    agent = RoverAgent(1, KEYS, NOISY, state_file=path)
    agent.on_clock(m.Clock(tick=500, sim_time=50.0, time_scale=1.0, run="r1"))
    assert agent.pose == Pose(0.0, -6.0, 0.0) and not agent.restarts.lost
    _feed(agent, m.CommPartners(ids=[0, 2]))
    _feed(agent, m.Perception(stamp=50.2, angles_deg=[], distances_m=[], kinds=[]))
    assert agent.estimator.localisation.exact  # as an older file without a covariance: nothing half-read


def test_a_goal_any_distance_off_is_decided_at_once():
    """The way by the lander was weighed by walking the direct way move by move: a MissionDirection as far off as
    the wire allows hung the agent (a regression hangs this test)."""
    from schemas.wire_limits import DISTANCE_LIMIT_M

    agent = _unsure_with_a_return(DISTANCE_LIMIT_M)
    _feed(agent, m.Perception(stamp=0.2, angles_deg=[], distances_m=[], kinds=[]))
    assert not agent.estimator.fix.active


def _clock(agent: RoverAgent, t: float) -> list:
    return agent.on_clock(m.Clock(tick=int(t * 10), sim_time=t, time_scale=1.0, run=agent.restarts.run))


def _reported(out: list) -> list[m.EstimatedPose]:
    return [msg for key, msg in out if key == KEYS.rover(1, ks.POSE_ESTIMATE)]


def test_the_agent_reports_its_own_estimate_and_covariance_with_its_status():
    agent = _walked(NOISY)
    out = _clock(agent, 3.2)
    (report,) = _reported(out)
    assert KEYS.rover(1, ks.STATUS) in [key for key, _ in out], "the estimate goes with the periodic status"
    loc = agent.estimator.localisation
    assert (report.x, report.z, report.heading_deg) == (loc.pose.x, loc.pose.z, loc.pose.heading)
    assert report.matrix() == loc.cov and report.cov_xx > 0 and not report.moving
    assert _reported(_clock(agent, 3.6)) == [], "no more often than the status"
    # walking: where the move has got to, as sure as that is
    _feed(agent, m.Perception(stamp=4.3, angles_deg=[], distances_m=[], kinds=[]))
    flight = agent.actions.in_flight
    _feed(agent, m.NavigationStatus(stamp=4.5, action="move", remaining=1.0, action_id=flight.action_id))
    (walking,) = _reported(_clock(agent, 4.6))
    expected, _ = loc.part_way(flight.start, flight.decision.x, flight.decision.z, flight.walked)
    assert walking.moving and (walking.x, walking.z) == pytest.approx((expected.x, expected.z))


def test_an_agent_that_does_not_know_where_it_is_reports_no_estimate():
    agent = joined_agent(1, KEYS, NOISY)
    assert _reported(_clock(agent, 1.5)) == []
