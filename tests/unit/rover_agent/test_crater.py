"""At a crater goal (``rover_agent.rules.crater``), through the default behaviour with scripted views: out of the
bowl, up the rim by pitch, back off the bowl's wall, and the photographs once round."""

from __future__ import annotations

import pytest
from agent_kit import PARAMS, angle_of, fresh_behaviour, goal_at, view_of

from rover_agent.decisions import Finish, Goal, Hit, MoveTo, Rotate, TakePhoto
from rover_agent.rules.tuning import BOWL_PITCH, CROWD_SQUEEZE_S, MAX_BACKS
from shared.pose import Pose


def test_crater_goal_is_not_reached_by_distance_alone():
    goal = goal_at(0.0, 1.0, kind="crater")
    assert not isinstance(fresh_behaviour(goal).decide(view_of(goal)), Finish)


def test_in_a_crater_bowl_the_rover_walks_out_and_looks_back_for_the_rim():
    """A crater's terrain shows where a ray enters it: from inside the bowl no rim shows, and walking on for the
    goal the rover crossed it to and fro for ever. Near the goal with no rim ever seen, it walks out towards the
    lander, looks back at the goal after a long step, and climbs as usual once the rim shows."""
    goal, radius = goal_at(0.0, 50.0, kind="crater"), PARAMS.perception.perception_radius
    b = fresh_behaviour(goal)
    turn = b.decide(view_of(goal, pose=Pose(0.0, 48.0, 0.0)))
    assert isinstance(turn, Rotate) and abs(turn.degrees) == pytest.approx(180.0)  # the lander is behind it
    out = b.decide(view_of(goal, pose=Pose(0.0, 48.0, 180.0)))
    assert isinstance(out, MoveTo) and angle_of(out) == pytest.approx(0.0) and out.z == pytest.approx(0.9 * radius)
    b.moved(0.9 * radius)
    outside = Pose(0.0, 48.0 - 0.9 * radius, 180.0)
    look = b.decide(view_of(goal, pose=outside))
    assert isinstance(look, Rotate) and abs(look.degrees) == pytest.approx(180.0)  # look back at the goal
    rim = [Hit(float(a), 6.0, "crater_terrain") for a in range(-30, 31, 5)]
    climb = b.decide(view_of(goal, pose=Pose(0.0, outside.z, 0.0), hits=rim))
    assert b.state == "climbing" and isinstance(climb, MoveTo) and angle_of(climb) == pytest.approx(0.0)


CRATER_AHEAD = (Hit(0.0, 8.0, "crater_terrain"),)


def _crater_view(pitch, hits=CRATER_AHEAD, goal=None):
    return view_of(goal or goal_at(0.0, 60.0, kind="crater"), hits=hits, pitch=pitch)


RELAYED_CRATER = Goal(0, 1, "crater", 0.0, 60.0, relayed=True)  # a daisy chain stands for it


def _on_crest(b, decision) -> bool:
    """The rover judged itself on the crest: it starts observing with a first photo."""
    return isinstance(decision, TakePhoto) and b.state == "observing"


def test_crater_climb_finishes_on_the_crest_only_after_walking_the_perception_radius():
    b = fresh_behaviour(goal_at(0.0, 60.0, kind="crater"))
    first = b.decide(_crater_view(pitch=0.0))
    assert b.state == "climbing"
    assert first == MoveTo(0.0, PARAMS.behaviour.min_move_size)  # small steps while climbing
    b.moved(2.0)
    assert isinstance(b.decide(_crater_view(pitch=3.0, hits=())), MoveTo)  # up the rim
    b.moved(2.0)
    # flat again after only 4 m: a local optimum, not the crest (report 7.2.2)
    assert not _on_crest(b, b.decide(_crater_view(pitch=0.3, hits=())))
    b.moved(5.9)
    assert not _on_crest(b, b.decide(_crater_view(pitch=0.3, hits=())))  # 9.9 m < 10 m
    b.moved(0.1)
    assert not _on_crest(b, b.decide(_crater_view(pitch=1.0, hits=())))  # still climbing
    assert _on_crest(b, b.decide(_crater_view(pitch=0.5, hits=())))


def test_crater_climb_needs_a_real_climb():
    b = fresh_behaviour(goal_at(0.0, 60.0, kind="crater"))
    b.decide(_crater_view(pitch=0.0))
    b.moved(20.0)
    assert not _on_crest(b, b.decide(_crater_view(pitch=1.9, hits=())))  # never above 2 deg
    assert not _on_crest(b, b.decide(_crater_view(pitch=0.0, hits=())))


def test_distance_walked_before_seeing_the_crater_does_not_count():
    b = fresh_behaviour(goal_at(0.0, 60.0, kind="crater"))
    b.moved(50.0)
    assert not _on_crest(b, b.decide(_crater_view(pitch=3.0)))
    b.moved(5.0)
    assert not _on_crest(b, b.decide(_crater_view(pitch=0.0, hits=())))
    b.moved(5.0)
    assert _on_crest(b, b.decide(_crater_view(pitch=0.0, hits=())))


def test_a_new_goal_forgets_the_climb():
    b = fresh_behaviour(goal_at(0.0, 60.0, kind="crater"))
    b.decide(_crater_view(pitch=3.0))
    b.moved(12.0)
    b.start_goal(goal_at(0.0, 60.0, kind="crater", index=1, total=2))
    assert b.state == "migration"
    assert not _on_crest(b, b.decide(_crater_view(pitch=0.0, hits=())))


def test_a_step_over_the_crest_turns_a_relayed_rover_round_and_back_onto_it():
    goal = RELAYED_CRATER
    b = fresh_behaviour(goal)
    b.decide(_crater_view(pitch=0.0, goal=goal))
    b.moved(2.0)
    b.decide(_crater_view(pitch=9.0, hits=(), goal=goal))  # up the outer rim, a whole step
    b.moved(2.0)
    # 4 m from first seeing the crater and pitched down the bowl's wall: over the crest, out of the chain's sight
    assert b.decide(_crater_view(pitch=-BOWL_PITCH - 2, hits=(), goal=goal)) == Rotate(180.0)
    assert b.decide(view_of(goal, pose=Pose(0.0, 0.0, 180.0), pitch=15.0)) == MoveTo(
        0.0, PARAMS.behaviour.min_move_size / 2)  # one short step out of the bowl, facing away
    b.moved(1.0)
    # facing the crater again the pitch is still down the wall but no longer steep: observe from here
    assert _on_crest(b, b.decide(_crater_view(pitch=-2.0, hits=(), goal=goal)))


def test_a_step_over_the_crest_is_taken_back_with_or_without_a_chain():
    """A narrow rim's crest is a step wide: a rover on the bowl's wall is not on it (the report's rover stayed)."""
    goal = goal_at(0.0, 60.0, kind="crater")
    b = fresh_behaviour(goal)
    b.decide(_crater_view(pitch=9.0))
    b.moved(2.0)  # not yet a perception radius past the first crater terrain: still over the crest
    assert b.decide(_crater_view(pitch=-BOWL_PITCH - 2, hits=())) == Rotate(180.0)
    assert b.decide(view_of(goal, pose=Pose(0.0, 0.0, 180.0), pitch=15.0)) == MoveTo(
        0.0, PARAMS.behaviour.min_move_size / 2)
    b.moved(1.0)
    assert _on_crest(b, b.decide(_crater_view(pitch=-2.0, hits=())))


def test_a_rover_held_up_on_the_rim_by_rovers_on_the_crest_observes_from_there():
    """Rovers done on the crest stay there: one come later, up the rim and facing the crater, that they have
    long left no step towards it is a body or two from the crest, not stuck."""
    goal = goal_at(0.0, 60.0, kind="crater")
    wall = (*CRATER_AHEAD, *(Hit(a, 1.4, "rover") for a in range(-100, 101, 4)))
    b = fresh_behaviour(goal)
    b.decide(_crater_view(pitch=9.0))  # the rim: crater terrain ahead, climbing
    b.moved(2.0)
    held = [b.decide(view_of(goal, hits=wall, pitch=9.0, time=t)) for t in (0.0, 5.0, 10.0)]
    assert Finish("reached") not in held  # a moment's jam is waited out, not taken for the crest
    assert _on_crest(b, b.decide(view_of(goal, hits=wall, pitch=9.0, time=CROWD_SQUEEZE_S + 1)))


def test_a_rover_never_steps_back_out_of_the_bowl_more_than_a_few_times():
    b = fresh_behaviour(RELAYED_CRATER)
    b.decide(_crater_view(pitch=9.0, goal=RELAYED_CRATER))
    steep = _crater_view(pitch=-BOWL_PITCH - 5, hits=(), goal=RELAYED_CRATER)  # every step back refused
    for _ in range(MAX_BACKS):
        assert b.decide(steep) == Rotate(180.0)
        assert isinstance(b.decide(steep), MoveTo)
    assert _on_crest(b, b.decide(steep))  # then it observes from there rather than turn for ever


def test_a_rover_right_behind_keeps_a_relayed_rover_on_the_wall():
    b = fresh_behaviour(RELAYED_CRATER)
    b.decide(_crater_view(pitch=9.0, goal=RELAYED_CRATER))
    assert b.decide(_crater_view(pitch=-BOWL_PITCH - 2, hits=(), goal=RELAYED_CRATER)) == Rotate(180.0)
    behind = view_of(RELAYED_CRATER, pose=Pose(0.0, 0.0, 180.0), hits=(Hit(0.0, 1.6, "rover"),), pitch=15.0)
    assert not isinstance(b.decide(behind), MoveTo)  # no squeezing into it
    assert _on_crest(b, b.decide(_crater_view(pitch=-BOWL_PITCH - 2, hits=(), goal=RELAYED_CRATER)))


def test_crater_crest_is_not_judged_while_facing_away_from_the_crater():
    goal = goal_at(0.0, 60.0, kind="crater")
    b = fresh_behaviour(goal)
    b.decide(_crater_view(pitch=3.0))
    b.moved(12.0)
    facing_away = view_of(goal, pose=Pose(0.0, 20.0, 180.0), pitch=-3.0)  # downhill on the outer slope, back to it
    assert not _on_crest(b, b.decide(facing_away))


def test_on_the_rim_a_photo_every_30_degrees_once_round_then_done():
    b = fresh_behaviour(goal_at(0.0, 60.0, kind="crater"))
    b.state = "observing"
    view = _crater_view(pitch=0.0, hits=())
    decisions = [b.decide(view) for _ in range(23)]
    photos = [d for d in decisions if isinstance(d, TakePhoto)]
    assert len(photos) == 12 and decisions[0] == photos[0]
    assert [d for d in decisions if isinstance(d, Rotate)] == [Rotate(30.0)] * 11
    assert len({p.label for p in photos}) == 12 and photos[1].label == "goal1_030.0deg"
    assert b.decide(view) == Finish("reached")


def test_stepped_back_off_the_bowl_wall_and_level_facing_out_the_rover_observes_without_turning_back():
    """The photographs go once round from any heading: turning to the crater only to read the pitch, and back
    again, cost some four seconds a time."""
    goal = goal_at(0.0, 60.0, kind="crater")
    b = fresh_behaviour(goal)
    b.decide(_crater_view(pitch=9.0))
    b.moved(2.0)
    assert b.decide(_crater_view(pitch=-BOWL_PITCH - 2, hits=())) == Rotate(180.0)
    facing_out = Pose(0.0, 0.0, 180.0)
    assert isinstance(b.decide(view_of(goal, pose=facing_out, pitch=15.0)), MoveTo)  # the step back
    b.moved(1.0)
    still_wall = b.decide(view_of(goal, pose=facing_out, pitch=6.0))  # rising outwards yet: the bowl's wall
    assert still_wall == MoveTo(0.0, PARAMS.behaviour.min_move_size / 2)
    b.moved(1.0)
    assert _on_crest(b, b.decide(view_of(goal, pose=facing_out, pitch=0.2)))
