"""Report 3.4.7's statistics from world states: the report's path efficiency and the one over rovers that got there."""

from __future__ import annotations

import msgspec
import pytest

from schemas import messages as m
from schemas.scenario import Goal, parse_scenario
from shared.mission import RoverMissions
from world_service.outcome.completion import LANDER_GONE_S, Completion, all_finished
from world_service.outcome.statistics import MissionStats, lander_component

SCENARIO = parse_scenario({
    "name": "two", "lander": {"x": 0.0, "z": 0.0},
    "rovers": [{"x": 0.0, "z": 10.0}, {"x": 10.0, "z": 10.0}],
    "mission": [{"x": 0.0, "z": 110.0}],
})


def _truth(rid: int, x: float, z: float, covered: float, state: str) -> m.RoverTruth:
    return m.RoverTruth(id=rid, x=x, z=z, heading_deg=0.0, action="idle", state=state, goal_index=0,
                        distance_to_goal_m=0.0, distance_covered_m=covered, alive=True)


def _report(*rovers: m.RoverTruth) -> m.MissionReport:
    stats = MissionStats(SCENARIO, RoverMissions(SCENARIO))
    stats.observe(m.WorldState(stamp=100.0, rovers=list(rovers), completed_at=100.0))
    return stats.report()


def test_a_rover_that_stopped_short_cannot_raise_the_efficiency_of_those_that_reached():
    """Rover 1 walks 125 m for its 100 m; rover 2 gives up after 20 m. The report's figure (the mean ideal path
    over the mean distance walked) comes out above 1; over the rovers that reached it is rover 1's 0.8."""
    report = _report(_truth(1, 0.0, 110.0, 125.0, "done"), _truth(2, 10.0, 30.0, 20.0, "stuck"))
    assert report.rovers_reached_final_goal == 1 and report.rovers_stuck == 1
    ideal = (100.0 + (10.0**2 + 100.0**2) ** 0.5) / 2
    assert report.average_path_efficiency == pytest.approx(ideal / 72.5, abs=1e-6)
    assert report.average_path_efficiency > 1
    assert report.reached_path_efficiency == pytest.approx(100.0 / 125.0)


def test_a_rover_sent_back_before_its_goal_is_judged_on_the_way_it_was_asked_to_walk():
    """Told to return to the lander 40 m out, rover 1 walked 40 m out and 50 m back: its ideal path turns where it
    was turned, not at the crater it never had to reach (that made the efficiency 1.05 once)."""
    stats = MissionStats(SCENARIO, RoverMissions(SCENARIO))
    under_way = _truth(1, 0.0, 50.0, 40.0, "migration")
    stats.observe(m.WorldState(stamp=20.0, rovers=[under_way, _truth(2, 10.0, 30.0, 20.0, "migration")]))
    stats.command(m.GroundCommand(request_id="r", command="return", rover_id=1))
    home = msgspec.structs.replace(_truth(1, 0.0, 0.0, 90.0, "done"), goal_index=1)
    stats.observe(m.WorldState(stamp=60.0, rovers=[home, _truth(2, 0.0, 110.0, 101.0, "done")], completed_at=60.0))
    report = stats.report()
    assert report.rovers_reached_final_goal == 2
    assert report.reached_path_efficiency == pytest.approx((90.0 / 90.0 + 100.5 / 101.0) / 2, abs=1e-3)
    assert report.reached_path_efficiency <= 1


def test_no_rover_reached_gives_no_reached_efficiency():
    report = _report(_truth(1, 0.0, 30.0, 20.0, "stuck"), _truth(2, 10.0, 30.0, 20.0, "done"))
    assert report.rovers_reached_final_goal == 0 and report.reached_path_efficiency is None


def test_a_stalled_rover_counts_as_stuck_whatever_its_state_name():
    stalled = msgspec.structs.replace(_truth(2, 10.0, 30.0, 20.0, "migration"), stalled=True)
    report = _report(_truth(1, 0.0, 110.0, 100.0, "done"), stalled)
    assert report.rovers_stuck == 1 and report.rovers_stalled == 1
    assert report.reached_path_efficiency == pytest.approx(1.0)


def test_a_rover_that_relayed_is_left_out_of_the_reached_efficiency():
    """A relay held a chain spot instead of walking its goals: its ideal path is not the one it was sent on. A rover
    that only forwarded others' traffic on its way (the radio graph's relays) is not one."""
    stats = MissionStats(SCENARIO, RoverMissions(SCENARIO))
    relay, walker = _truth(1, 0.0, 110.0, 20.0, "done"), _truth(2, 0.0, 110.0, 125.0, "done")
    stats.observe(m.WorldState(stamp=50.0, rovers=[msgspec.structs.replace(relay, state="relay"), walker], relays=[2]))
    stats.observe(m.WorldState(stamp=100.0, rovers=[relay, walker], completed_at=100.0))
    report = stats.report()
    assert report.rovers_reached_final_goal == 2
    assert report.reached_path_efficiency == pytest.approx((10.0**2 + 100.0**2) ** 0.5 / 125.0)


def test_a_stalled_rover_still_moving_does_not_keep_the_mission_from_ending():
    """A rover walking to and fro for ever (across a crater's bowl, say) is counted stalled: the mission ends
    without it, moving or not. Any other rover still moving holds the end."""
    status = {1: m.RoverStatus(stamp=9.0, state="done"), 2: m.RoverStatus(stamp=9.0, state="climbing")}
    no_route = dict  # no photo pending: the radio is never asked
    assert not all_finished(status, {1: False, 2: True}, no_route)
    assert all_finished(status, {1: False, 2: True}, no_route, stalled=frozenset({2}))
    assert not all_finished(status, {1: True, 2: True}, no_route, stalled=frozenset({2}))


def test_a_mission_with_relays_among_the_finished_ends_once_they_stayed_so_dated_from_the_first():
    """At the last goal the lander may yet release the relays, and its word comes down the chain after the
    rovers' own status: the world must not end the mission in between, nor count the wait in its duration."""
    done, relay = m.RoverStatus(stamp=0.0, state="done"), m.RoverStatus(stamp=0.0, state="relay")
    walking = m.RoverStatus(stamp=0.0, state="migration")
    no_route, still = dict, {1: False, 2: False}
    wait = 65.0
    completion = Completion(wait)
    completion.check(50.0, {1: done, 2: relay}, still, no_route)
    completion.check(50.0 + wait / 2, {1: done, 2: walking}, still, no_route)  # released
    completion.check(70.0, {1: done, 2: relay}, still, no_route)
    completion.check(70.0 + wait / 2, {1: done, 2: relay}, still, no_route)
    assert completion.at is None
    completion.check(70.0 + wait, {1: done, 2: relay}, still, no_route)
    assert completion.at == 70.0
    at_once = Completion(wait)
    at_once.check(30.0, {1: done, 2: done}, still, no_route)  # no relay: nothing more can come
    assert at_once.at == 30.0


def test_a_photo_on_its_way_holds_the_end_only_while_a_lander_is_there_to_take_it():
    """The rovers have finished, one with a photo for the lander it can reach by radio. The lander agent dies: the
    photo will not arrive, and the world steps on (in lockstep, at full speed) with nothing left to end the
    mission. A lander that restarts within ``LANDER_GONE_S`` still gets it."""
    done = m.RoverStatus(stamp=0.0, state="done")
    holding = m.RoverStatus(stamp=0.0, state="done", photos_pending=1)
    still, in_reach = {1: False, 2: False}, lambda: {1: True, 2: True}
    completion = Completion()
    completion.check(50.0, {1: done, 2: holding}, still, in_reach)
    completion.note_lander(False, 60.0)
    completion.note_lander(True, 60.0 + LANDER_GONE_S / 2)  # a restart
    completion.note_lander(False, 100.0)
    completion.note_lander(False, 130.0)  # gone since 100, not since 130
    completion.check(100.0 + LANDER_GONE_S - 1.0, {1: done, 2: holding}, still, in_reach)
    assert completion.at is None
    completion.check(100.0 + LANDER_GONE_S, {1: done, 2: holding}, still, in_reach)
    assert completion.at == 100.0 + LANDER_GONE_S


def test_a_rover_claiming_a_goal_beyond_its_plan_while_the_ground_turns_it_leaves_the_report_finite():
    """A status is the rover's word: one naming goal 5 of a one-goal plan, then re-targeted by the ground, made the
    walk through its goals turn back to goal 1 at goal 5 for ever, and the world's step with it."""
    stats = MissionStats(SCENARIO, RoverMissions(SCENARIO))
    claim = msgspec.structs.replace(_truth(1, 0.0, 20.0, 10.0, "migration"), goal_index=5)
    stats.observe(m.WorldState(stamp=10.0, rovers=[claim, _truth(2, 10.0, 30.0, 20.0, "migration")]))
    def target(n: int) -> m.GroundCommand:
        return m.GroundCommand(request_id=f"t{n}", command="set_target", rover_id=1, x=0.0, z=12.0)

    stats.command(target(0))
    done = msgspec.structs.replace(claim, state="done")
    stats.observe(m.WorldState(stamp=20.0, rovers=[done, _truth(2, 10.0, 30.0, 20.0, "migration")]))
    for n in range(1, 5):
        stats.command(target(n))
    assert stats.missions.final_index(1) == 5
    goals = stats.ideal_goals(1)  # turned before its first goal (it named none of its plan), then goals 1 to 5
    assert goals[0] == Goal(x=0.0, z=20.0, kind="waypoint") and len(goals) == 6
    assert stats.report().rovers_reached_final_goal == 1  # done, as its status says


def test_the_lander_component_takes_each_rover_once_however_many_routes_reach_it():
    """A chain of 60 'diamonds' (each rover reached from the last by two relays): 2**60 shortest routes from the
    lander, one component of 181 nodes. A frontier kept per route never ended here."""
    links, top = [], 0
    for d in range(60):
        a, b, c = 3 * d + 1, 3 * d + 2, 3 * d + 3
        links += [(top, a), (top, b), (a, c), (b, c)]
        top = c
    links.append((500, 501))  # two rovers that hear only each other
    state = m.WorldState(stamp=1.0, rovers=[], comm_links=links)
    assert lander_component(state) == set(range(181))
