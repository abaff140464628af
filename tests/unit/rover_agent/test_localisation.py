"""The pose estimator (``rover_agent.estimation.pose_filter``) and what perception shows it
(``rover_agent.estimation.sightings``), with scripted sensor streams: a known path driven with the world's own noise
model from a seeded generator, and the hits a perception scan would give of the lander and of other rovers from the
true pose. No world, no router."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest
from hostile import pack_radio

from rover_agent.decisions import Hit
from rover_agent.estimation.pose_filter import CI_WEIGHTS, Landmark, Localisation, NoiseModel
from rover_agent.estimation.sightings import (
    AMBIGUITY,
    FORGET_AFTER_S,
    MATCH_GATE,
    Teammate,
    lander_centre,
    lander_landmark,
    match_teammates,
    rover_centres,
    teammate_landmark,
)
from schemas import codec, radio
from schemas.frames import bearing_deg, to_relative, to_world
from schemas.params import NavigationParams, RoverParams
from shared.pose import Pose
from world_service.actuation import navigation as nav

PARAMS = RoverParams()
FOV, RAYS, RANGE = (PARAMS.perception.field_of_view_degrees, PARAMS.perception.perception_granularity,
                    PARAMS.perception.perception_radius)
RAY_STEP = FOV / (RAYS - 1)
NOISY = NoiseModel(slip_std=0.05, heading_std_rad=math.radians(1.0))  # the generator's 'high' noise


def by_pair(distance):
    """The table ``match_teammates`` weighs, from a distance of one pair."""
    return lambda centres, mates: [[distance(centre, mate) for mate in mates] for centre in centres]


# ---- the world's noise, and what a scan shows ----


def true_move(pose: Pose, rel_x: float, rel_z: float, rng: np.random.Generator, noise: NoiseModel) -> Pose:
    """Where a move really ends, drawn as ``world_service.actuation.actuator`` draws it: a slip on each rover-relative
    axis in proportion to the move's length, and a turn of the heading on arrival."""
    sigma = noise.slip_std * math.hypot(rel_x, rel_z)
    slip = rng.normal(0.0, sigma, 2) if sigma > 0 else (0.0, 0.0)
    turn = math.degrees(rng.normal(0.0, noise.heading_std_rad)) if noise.heading_std_rad > 0 else 0.0
    x, z = to_world(pose.x, pose.z, pose.heading, rel_x + slip[0], rel_z + slip[1])
    face = to_world(pose.x, pose.z, pose.heading, rel_x, rel_z)
    return Pose(x, z, (bearing_deg(face[0] - pose.x, face[1] - pose.z) + turn) % 360.0)


def true_rotate(pose: Pose, degrees: float, rng: np.random.Generator, noise: NoiseModel) -> Pose:
    turn = math.degrees(rng.normal(0.0, noise.heading_std_rad)) if noise.heading_std_rad > 0 else 0.0
    return Pose(pose.x, pose.z, (pose.heading + degrees + turn) % 360.0)


def scan(pose: Pose, circles: list[tuple[float, float, float, str]]) -> tuple[Hit, ...]:
    """The hits a perception scan from the true ``pose`` gives of upright circles (x, z, radius, kind)."""
    hits = []
    for angle in np.linspace(-FOV / 2, FOV / 2, RAYS):
        h = math.radians(pose.heading + angle)
        dx, dz = math.sin(h), math.cos(h)
        best = (math.inf, "")
        for cx, cz, r, kind in circles:
            ox, oz = pose.x - cx, pose.z - cz
            b, c = ox * dx + oz * dz, ox * ox + oz * oz - r * r
            disc = b * b - c
            if disc >= 0 and (t := -b - math.sqrt(disc)) > 0 and t < best[0]:
                best = (t, kind)
        if best[0] <= RANGE:
            hits.append(Hit(round(float(angle), 3), round(best[0], 3), best[1]))
    return tuple(hits)


def nees(loc: Localisation, truth: Pose) -> float:
    """Normalised estimation error squared of the whole pose: about 3 on average when the covariance is right."""
    e = np.array([loc.pose.x - truth.x, loc.pose.z - truth.z,
                  math.radians((loc.pose.heading - truth.heading + 180.0) % 360.0 - 180.0)])
    return float(e @ np.linalg.solve(np.array(loc.cov), e))


LEG = [(0.0, 8.0), (1.5, 7.5), (0.0, 8.0), (-2.0, 7.0)]


def drive(loc: Localisation, truth: Pose, rng: np.random.Generator, noise: NoiseModel, moves: int,
          turn_every: int = 5) -> Pose:
    """Moves along a wavy line with a rotate now and then, the estimate following the commands."""
    for i in range(moves):
        rel = LEG[i % len(LEG)]
        start = loc.pose
        truth = true_move(truth, *rel, rng, noise)
        loc.moved(start, *rel)
        if turn_every and i % turn_every == turn_every - 1:
            truth = true_rotate(truth, 20.0, rng, noise)
            loc.rotated(loc.pose, 20.0)
    return truth


# ---- prediction ----


def test_the_test_model_of_a_move_is_the_worlds():
    """The closed form above ends where ``world_service.actuation.navigation`` walks a slipped, turned move to."""
    rng = np.random.default_rng(3)
    body = nav.RoverBody(1, 2.0, -3.0, 40.0)
    slip, turn = tuple(rng.normal(0.0, 0.4, 2)), float(rng.normal(0.0, 1.0))
    body.start_move(1.5, 7.5, slip, turn)
    while nav.step(body, 0.05, NavigationParams()) is None:
        pass

    class Fixed:  # replays the same draws (the world's turn in degrees, the model's in radians)
        def normal(self, mean, sigma, size=None):
            return np.array(slip) if size == 2 else math.radians(turn)

    expected = true_move(Pose(2.0, -3.0, 40.0), 1.5, 7.5, Fixed(), NoiseModel(0.1, 0.1))
    assert (body.x, body.z, body.heading) == pytest.approx((expected.x, expected.z, expected.heading), abs=1e-6)


def test_without_noise_the_estimate_is_dead_reckoning_and_stays_exact():
    loc = Localisation(Pose(3.0, 4.0, 90.0), NoiseModel.of(NavigationParams()))
    dead = Pose(3.0, 4.0, 90.0)
    for rel in LEG * 3:
        loc.moved(loc.pose, *rel)
        dead = dead.after_move(*rel)
    loc.rotated(loc.pose, -33.0)
    loc.stopped_early(loc.pose, 0.4, 2.5, 3.0)
    dead = dead.after_rotate(-33.0).after_partial(0.4, 2.5, 3.0)
    assert loc.pose == dead and loc.exact and loc.cov == [[0.0] * 3] * 3
    sighting = Landmark((1.0, 5.0), (0.0, 0.0), [[0.0, 0.0], [0.0, 0.0]], 0.2)
    assert not loc.observe(sighting, gate=None) and loc.pose == dead  # an exact estimate has nothing to correct
    shared = Landmark((1.0, 5.0), (30.0, 40.0), [[4.0, 0.0], [0.0, 4.0]], 0.3, shared=True)
    assert not loc.observe(shared, gate=None) and loc.pose == dead


def test_the_covariance_grows_as_the_rovers_own_noise_says():
    """Over many seeded runs of the same path the errors of dead reckoning have the covariance the filter
    predicts: average NEES near 3 (three states), and each position variance within 15% of the sample's."""
    runs, errors, predicted = 400, [], None
    for seed in range(runs):
        rng = np.random.default_rng(seed)
        loc = Localisation(Pose(0.0, 0.0, 0.0), NOISY)
        truth = drive(loc, Pose(0.0, 0.0, 0.0), rng, NOISY, 25)
        errors.append(nees(loc, truth))
        predicted = loc.cov
    assert 2.6 < float(np.mean(errors)) < 3.4
    assert predicted[0][0] > 1.0 and predicted[1][1] > 0.5  # metres: the drift is real


def test_the_position_variances_match_the_sample():
    runs, ends = 600, []
    for seed in range(runs):
        rng = np.random.default_rng(10_000 + seed)
        loc = Localisation(Pose(0.0, 0.0, 0.0), NOISY)
        truth = drive(loc, Pose(0.0, 0.0, 0.0), rng, NOISY, 20)
        ends.append((truth.x - loc.pose.x, truth.z - loc.pose.z))
    sample = np.cov(np.array(ends).T)
    assert sample[0][0] == pytest.approx(loc.cov[0][0], rel=0.15)
    assert sample[1][1] == pytest.approx(loc.cov[1][1], rel=0.15)


# ---- the lander ----


def test_the_landers_centre_is_fitted_from_its_hits():
    pose = Pose(4.0, -7.0, 300.0)
    hits = scan(pose, [(0.0, 0.0, 1.5, "lander")])
    assert sum(h.kind == "lander" for h in hits) >= 3
    centre = lander_centre(hits)
    assert centre == pytest.approx(to_relative(pose.x, pose.z, pose.heading, 0.0, 0.0), abs=0.02)
    assert lander_centre(hits[:2]) is None  # two hits pin no circle down
    assert lander_centre(tuple(Hit(h.angle_deg, h.distance_m, "obstacle") for h in hits)) is None


def test_lander_sightings_shrink_the_error_and_the_covariance_stays_consistent():
    """Walking past the lander with high noise: seen from several places, it pulls the estimate in."""
    final_errors, dead_errors, scores = [], [], []
    for seed in range(60):
        rng = np.random.default_rng(500 + seed)
        start = Pose(-6.0, -40.0, 0.0)
        loc, dead = Localisation(start, NOISY), Localisation(start, NOISY)
        truth = start
        for i in range(6):  # north to z = +8, past the lander at the origin on its right
            rel = (0.0, 8.0)
            truth = true_move(truth, *rel, rng, NOISY)
            loc.moved(loc.pose, *rel)
            dead.moved(dead.pose, *rel)
            if i % 3 == 2:
                truth = true_rotate(truth, 0.0, rng, NOISY)
                loc.rotated(loc.pose, 0.0)
                dead.rotated(dead.pose, 0.0)
            if (centre := lander_centre(scan(truth, [(0.0, 0.0, 1.5, "lander")]))) is not None:
                loc.observe(lander_landmark(centre), gate=None)
        final_errors.append(math.hypot(loc.pose.x - truth.x, loc.pose.z - truth.z))
        dead_errors.append(math.hypot(dead.pose.x - truth.x, dead.pose.z - truth.z))
        scores.append(nees(loc, truth))
    assert np.median(final_errors) < 0.5 * np.median(dead_errors)
    assert float(np.mean(scores)) < 4.5  # consistent: not overconfident after the corrections


def test_seen_from_one_spot_the_lander_fixes_what_it_can_and_says_what_it_cannot():
    """One landmark from one spot fixes the distance to it and the bearing to it, not where round it the rover
    stands: the estimate puts the lander where it is seen, and the covariance keeps the rest of the error."""
    rng = np.random.default_rng(7)
    loc = Localisation(Pose(0.0, -12.0, 0.0), NOISY)
    truth = drive(loc, Pose(0.0, -12.0, 0.0), rng, NOISY, 12)
    # walk back where the estimate believes the start is, then turn to face the lander: it is about 5 m ahead
    error_before = math.hypot(loc.pose.x - truth.x, loc.pose.z - truth.z)
    rel = to_relative(loc.pose.x, loc.pose.z, loc.pose.heading, 0.0, -6.0)
    truth, _ = true_move(truth, *rel, rng, NOISY), loc.moved(loc.pose, *rel)
    turn = (bearing_deg(-loc.pose.x, -loc.pose.z) - loc.pose.heading + 180.0) % 360.0 - 180.0
    truth, _ = true_rotate(truth, turn, rng, NOISY), loc.rotated(loc.pose, turn)
    for _ in range(5):
        centre = lander_centre(scan(truth, [(0.0, 0.0, 1.5, "lander")]))
        assert centre is not None
        loc.observe(lander_landmark(centre), gate=None)
    assert error_before > 2.0
    seen = to_relative(truth.x, truth.z, truth.heading, 0.0, 0.0)
    assert to_relative(loc.pose.x, loc.pose.z, loc.pose.heading, 0.0, 0.0) == pytest.approx(seen, abs=0.1)
    assert math.hypot(loc.pose.x - truth.x, loc.pose.z - truth.z) < min(1.0, 0.5 * error_before)
    assert nees(loc, truth) < 11.3  # chi-square, 3 degrees of freedom, 99%


def out_and_back(rng: np.random.Generator) -> tuple[Localisation, Pose]:
    """Two legs of 15-40 m out from beside the lander in moves of about 2.5 m, then back towards it by the
    estimate, stopping 4-12 m short, facing it."""
    loc = Localisation(Pose(0.0, 3.0, 0.0), NOISY)
    truth = loc.pose
    for turn, length in [(rng.uniform(-60.0, 60.0), rng.uniform(15.0, 40.0)) for _ in range(2)] + [(None, None)]:
        if turn is None:
            turn = (bearing_deg(-loc.pose.x, -loc.pose.z) - loc.pose.heading + 180.0) % 360.0 - 180.0
            length = math.hypot(loc.pose.x, loc.pose.z) - rng.uniform(4.0, 12.0)
        truth, _ = true_rotate(truth, turn, rng, NOISY), loc.rotated(loc.pose, turn)
        moves = max(1, round(length / 2.5))
        for _ in range(moves):
            truth, _ = true_move(truth, 0.0, length / moves, rng, NOISY), loc.moved(loc.pose, 0.0, length / moves)
    return loc, truth


def test_the_first_sighting_of_the_lander_after_a_long_walk_leaves_the_estimate_honest():
    """Back from a long walk at high noise the estimate is metres off, so the lander shows at a range unlike the
    one the estimate predicts. An update linearised only there turns the sighting by the wrong offset in the
    heading: it left one sighting in ten with a pose far from the truth that it stated as sure (NEES beyond the
    99.9% gate). Linearised again at each new estimate, the update stays honest."""
    before, after = [], []
    for seed in range(200):
        loc, truth = out_and_back(np.random.default_rng(2_000 + seed))
        centre = lander_centre(scan(truth, [(0.0, 0.0, 1.5, "lander")]))
        if centre is None:
            continue
        before.append(nees(loc, truth))
        assert loc.observe(lander_landmark(centre), gate=None)
        after.append(nees(loc, truth))
    before, after = np.array(before), np.array(after)
    assert len(after) >= 150
    assert np.mean(before > 16.27) < 0.02  # the walk's own estimates are honest (chi-square, 3 dof, 99.9%) ...
    assert np.mean(after > 16.27) < 0.02  # ... and stay so after the sighting
    assert np.mean(after) < 3.0


# ---- other rovers ----


def test_rovers_seen_are_told_apart_and_their_centres_fitted():
    pose = Pose(0.0, 0.0, 10.0)
    others = [(2.0, 6.0, 0.5, "rover"), (-4.0, 3.0, 0.5, "rover"), (1.0, 9.0, 0.5, "rover")]
    centres = rover_centres(scan(pose, others), 0.5, RAY_STEP)
    expected = sorted(to_relative(pose.x, pose.z, pose.heading, x, z) for x, z, _, _ in others)
    assert len(centres) == 3
    for got, want in zip(sorted(centres), expected, strict=True):
        assert got == pytest.approx(want, abs=0.3)


def estimate(x: float, z: float, var: float, stamp: float = 10.0, moving: bool = False) -> radio.PoseEstimate:
    return radio.PoseEstimate(stamp=stamp, x=x, z=z, cov_xx=var, cov_xz=0.0, cov_zz=var, moving=moving)


def test_a_better_localised_teammate_pulls_the_estimate_in():
    loc = Localisation(Pose(3.0, 2.0, 0.0), NOISY, [[9.0, 0.0, 0.0], [0.0, 9.0, 0.0], [0.0, 0.0, 1e-4]])
    truth, mate = Pose(0.0, 0.0, 0.0), Teammate(2, estimate(5.0, 6.0, 0.04))
    seen = to_relative(truth.x, truth.z, truth.heading, 5.0, 6.0)
    assert loc.observe(teammate_landmark(seen, mate, 10.0, 3.5))
    assert math.hypot(loc.pose.x, loc.pose.z) < 0.6 and loc.position_std < 1.0


def test_sightings_of_one_teammate_over_and_over_never_blow_the_heading_up():
    """Covariance intersection over the whole pose scaled the heading's variance, which a sighting of a position
    does not observe, by 1 / w each time: it grew without bound. Only the position is intersected."""
    loc = Localisation(Pose(1.0, 1.0, 5.0), NOISY, [[4.0, 0.5, 0.02], [0.5, 4.0, -0.01], [0.02, -0.01, 0.01]])
    mate = Teammate(2, estimate(0.0, 7.0, 4.0))
    for _ in range(200):
        loc.observe(teammate_landmark(to_relative(0.0, 0.0, 0.0, 0.0, 7.0), mate, 10.0, 3.5))
    assert loc.cov[2][2] <= 0.01 + 1e-12
    assert loc.cov[0][0] < 5.0 and loc.cov[1][1] < 5.0  # between the estimate's 4 and the sighting's 4.6
    assert np.all(np.linalg.eigvalsh(np.array(loc.cov)) > -1e-12)


def test_teammates_estimates_that_share_errors_leave_the_covariance_consistent():
    """Two rovers that keep correcting each other from the same few sightings: each still covers its true error
    (intersection, not a plain update that would count the same information again and again)."""
    scores = []
    for seed in range(200):
        rng = np.random.default_rng(9000 + seed)
        a, b = Localisation(Pose(0.0, 0.0, 0.0), NOISY), Localisation(Pose(6.0, 0.0, 0.0), NOISY)
        ta = drive(a, Pose(0.0, 0.0, 0.0), rng, NOISY, 10)
        tb = drive(b, Pose(6.0, 0.0, 0.0), rng, NOISY, 10)
        for _ in range(5):
            for me, truth_me, other, truth_other, rid in ((a, ta, b, tb, 2), (b, tb, a, ta, 1)):
                seen = to_relative(truth_me.x, truth_me.z, truth_me.heading, truth_other.x, truth_other.z)
                c = other.cov
                mate = Teammate(rid, radio.PoseEstimate(stamp=0.0, x=other.pose.x, z=other.pose.z, cov_xx=c[0][0],
                                                        cov_xz=c[0][1], cov_zz=c[1][1]))
                me.observe(teammate_landmark(seen, mate, 0.0, 3.5), gate=None)
        scores += [nees(a, ta), nees(b, tb)]
    assert float(np.mean(scores)) < 3.5


def test_a_teammate_is_matched_only_where_the_match_cannot_well_be_another():
    loc = Localisation(Pose(0.0, 0.0, 0.0), NOISY, [[0.25, 0.0, 0.0], [0.0, 0.25, 0.0], [0.0, 0.0, 1e-4]])
    a, b = Teammate(2, estimate(3.0, 6.0, 0.25)), Teammate(3, estimate(-3.0, 6.0, 0.25))

    def distance(seen, mate):
        return loc.mahalanobis(teammate_landmark(seen, mate, 10.0, 3.5))

    seen_a, seen_b = (3.2, 5.9), (-2.9, 6.2)
    pairs = match_teammates([seen_a, seen_b], [a, b], [0, 2, 3], 10.0, 10.0, by_pair(distance))
    assert {(seen, mate.rover_id) for seen, mate in pairs} == {(seen_a, 2), (seen_b, 3)}
    close = Teammate(3, estimate(3.5, 6.0, 0.25))  # two estimates where one rover is seen: neither is taken
    assert match_teammates([seen_a], [a, close], [0, 2, 3], 10.0, 10.0, by_pair(distance)) == []
    stale = Teammate(2, estimate(3.0, 6.0, 0.25, stamp=5.0))
    assert match_teammates([seen_a], [stale, b], [0, 2, 3], 10.0, 10.0, by_pair(distance)) == []


def test_a_teammate_whose_estimate_has_just_gone_stale_still_counts_against_a_match():
    """A rover seen where a teammate's estimate, told 1.1 s ago, puts it, and another teammate's fresh estimate
    1.5 m off: the rover seen is not taken for the second because the first's estimate is just past matching (in
    a crowd that moved estimates metres off and left them sure of it). Forgotten, it no longer counts."""
    loc = Localisation(Pose(0.0, 0.0, 0.0), NOISY, [[0.25, 0.0, 0.0], [0.0, 0.25, 0.0], [0.0, 0.0, 1e-4]])

    def distance(seen, mate):
        return loc.mahalanobis(teammate_landmark(seen, mate, 10.0, 3.5))

    fresh, seen = Teammate(2, estimate(3.0, 6.0, 0.25)), (1.5, 6.0)
    assert distance(seen, fresh) < MATCH_GATE
    just_stale = Teammate(3, estimate(1.5, 6.0, 0.25, stamp=10.0 - 1.1))
    assert match_teammates([seen], [fresh, just_stale], [0, 2, 3], 10.0, 40.0, by_pair(distance)) == []
    forgotten = Teammate(3, estimate(1.5, 6.0, 0.25, stamp=10.0 - FORGET_AFTER_S - 0.1))
    assert match_teammates([seen], [fresh, forgotten], [0, 2, 3], 10.0, 40.0, by_pair(distance)) == [(seen, fresh)]


def test_one_rover_seen_and_one_in_radio_range_are_each_other_wherever_the_estimates_put_them():
    far_off = Teammate(4, estimate(40.0, -20.0, 100.0))
    pairs = match_teammates([(1.0, 5.0)], [far_off], [0, 4], 10.0, 10.0, by_pair(lambda seen, mate: math.inf))
    assert pairs == [((1.0, 5.0), far_off)]
    at_range_edge = match_teammates([(1.0, 9.5)], [far_off], [0, 4], 10.0, 10.0, by_pair(lambda s, m: math.inf))
    assert at_range_edge == []


def test_a_walking_teammate_counts_as_less_sure():
    still = teammate_landmark((0.0, 5.0), Teammate(2, estimate(0.0, 5.0, 1.0)), 10.5, 3.5)
    walking = teammate_landmark((0.0, 5.0), Teammate(2, estimate(0.0, 5.0, 1.0, moving=True)), 10.5, 3.5)
    assert still.cov[0][0] == 1.0 and walking.cov[0][0] == pytest.approx(1.0 + 1.75 ** 2)


def test_the_intersection_weight_in_closed_form_is_the_best_on_the_grid_or_better():
    """det(w P^-1 + (1 - w) R^-1) is a quadratic in w: its maximum needs no search (the grid is the fallback for a
    position covariance that is still singular)."""
    from rover_agent.estimation.matrices import scaled
    from rover_agent.estimation.pose_filter import _intersection_weight, _intersection_weight_on_grid, _kalman

    def volume(p, r, w):
        c = _kalman(scaled(p, 1 / w), scaled(p, 1 / w), scaled(p, 1 / w), scaled(r, 1 / (1 - w)), [0.0, 0.0])[0]
        return c[0][0] * c[1][1] - c[0][1] * c[1][0]

    rng = np.random.default_rng(11)
    for _ in range(300):
        p, r = (m @ m.T + 0.01 * np.eye(2) for m in rng.normal(0.0, 2.0, (2, 2, 2)))
        p, r = p.tolist(), r.tolist()
        assert volume(p, r, _intersection_weight(p, r)) <= volume(p, r, _intersection_weight_on_grid(p, r)) * (1 + 1e-9)
    assert _intersection_weight([[1.0, 0.0], [0.0, 0.0]], [[1.0, 0.0], [0.0, 1.0]]) in CI_WEIGHTS


# ---- bad input: a hostile or corrupt estimate must not corrupt this one ----


@pytest.mark.parametrize("fields", [
    {"cov_xx": 0.0, "cov_xz": 0.25, "cov_zz": 0.0},  # not positive semi-definite
    {"cov_xx": 1.0, "cov_xz": -3.0, "cov_zz": 1.0},
    {"x": 1e300},  # no place a rover can be
    {"cov_xx": 1e300},
    {"stamp": -5.0},
])
def test_a_pose_estimate_that_is_no_estimate_is_refused_by_the_schema(fields):
    good = {"stamp": 10.0, "x": 1.0, "z": 2.0, "cov_xx": 1.0, "cov_xz": 0.5, "cov_zz": 1.0}
    codec.checked(radio.PoseEstimate(**good))
    with pytest.raises(ValueError):  # a bound when checked, a cross-field rule when built
        codec.checked(radio.PoseEstimate(**{**good, **fields}))
    with pytest.raises(codec.DecodeError):  # what the agent counts as a rejected sample
        radio.unpack(pack_radio("pose_estimate", {**good, **fields, "moving": False}))  # as sent, never built


def test_an_estimate_rounded_to_the_micrometre_squared_is_still_accepted():
    """A sender rounds each entry to 6 decimals: a nearly singular covariance may come a hair past singular."""
    radio.PoseEstimate(stamp=1.0, x=0.0, z=0.0, cov_xx=0.0, cov_xz=0.0000005, cov_zz=0.0)
    radio.PoseEstimate(stamp=1.0, x=0.0, z=0.0, cov_xx=0.0, cov_xz=0.000003, cov_zz=4.0)


@pytest.mark.parametrize("cov", [[[0.0, 0.25], [0.25, 0.0]], [[-1.0, 0.0], [0.0, 1.0]],
                                 [[math.nan, 0.0], [0.0, 1.0]], [[0.0, 1e154], [1e154, 1.7e308]]])
def test_a_landmark_whose_covariance_is_no_covariance_changes_nothing(cov):
    """Defence in depth behind the schema: an update with a sighting noise that is not positive definite can turn
    the estimate's own variances negative (and the agent's next PoseEstimate would then not validate)."""
    loc = Localisation(Pose(3.0, 2.0, 0.0), NOISY, [[9.0, 0.0, 0.0], [0.0, 9.0, 0.0], [0.0, 0.0, 1e-4]])
    before = ([list(r) for r in loc.cov], loc.pose)
    landmark = Landmark((5.0, 6.0), (8.0, 8.0), cov, 0.3, shared=True)
    assert not loc.observe(landmark)
    assert not loc.observe(landmark, gate=None)
    assert not loc.observe(Landmark((5.0, 6.0), (8.0, 8.0), cov, 0.3))
    assert (loc.cov, loc.pose) == before


def test_a_sighting_too_far_off_to_measure_is_outside_the_gate():
    """Its Mahalanobis distance overflows to NaN, which compared as inside any gate: the pose went to 1e299."""
    loc = Localisation(Pose(3.0, 2.0, 0.0), NOISY, [[9.0, 0.0, 0.0], [0.0, 9.0, 0.0], [0.0, 0.0, 1e-4]])
    assert not loc.observe(Landmark((5.0, 6.0), (1e300, 1e300), [[1e200, 1e6], [1e6, 1.0]], 0.3, shared=True))
    assert loc.pose == Pose(3.0, 2.0, 0.0)


def test_the_way_to_a_remote_goal_is_predicted_at_once_and_as_step_by_step():
    """The prediction walked the way move by move: a goal ten thousand kilometres off (a MissionDirection's
    distance is any finite number) took minutes, one 1e300 m off never ended."""
    import time

    loc = Localisation(Pose(1.0, -2.0, 30.0), NOISY, [[2.0, 0.3, 0.01], [0.3, 1.0, -0.02], [0.01, -0.02, 1e-3]])
    ahead = Localisation(loc.pose, NOISY, loc.cov)
    to = (60.0, 75.0)
    turn = (math.degrees(math.atan2(to[0] - 1.0, to[1] + 2.0)) - 30.0) % 360.0
    ahead.rotated(ahead.pose, turn)
    left = math.hypot(to[0] - 1.0, to[1] + 2.0)
    while left > 1e-9:
        ahead.moved(ahead.pose, 0.0, min(9.0, left))
        left -= min(9.0, left)
    assert loc.predicted_std(to, 9.0) == pytest.approx(ahead.position_std, rel=1e-9)
    started = time.perf_counter()
    assert loc.predicted_std((0.0, 1e7), 9.0) > 1e3
    assert loc.predicted_std((0.0, 1e300), 9.0) == math.inf
    assert loc.predicted_std((1e300, 0.0), 9.0) == math.inf
    assert time.perf_counter() - started < 1.0


def test_a_rover_hit_at_no_distance_gives_a_centre_rather_than_a_crash():
    """The Perception schema allows a distance of 0 (a distance under half a millimetre, rounded)."""
    centres = rover_centres((Hit(0.0, 0.0, "rover"), Hit(4.0, 0.0, "rover")), 0.5, RAY_STEP)
    assert len(centres) == 1 and all(math.isfinite(v) for v in centres[0])


def test_matching_takes_the_pairs_no_other_pairing_comes_near_as_a_table_of_distances_says():
    """The rule, checked pair by pair against every other pairing of either (as matching first did it, in time
    growing with the cube of the rovers), on random tables with ties, infinities and NaNs."""
    rng = random.Random(12)
    for _ in range(400):
        n_seen, n_fresh, n_stale = rng.randint(1, 6), rng.randint(0, 5), rng.randint(0, 3)
        pool = [0.5, 3.0, 9.0, 9.21, 12.0, 18.21, 30.0, math.inf, math.nan]
        table = [[rng.choice(pool) if rng.random() < 0.4 else rng.uniform(0.0, 40.0)
                  for _ in range(n_fresh + n_stale)] for _ in range(n_seen)]
        fresh = [Teammate(2 + j, estimate(0.0, 0.0, 1.0)) for j in range(n_fresh)]
        stale = [Teammate(20 + j, estimate(0.0, 0.0, 1.0, stamp=10.0 - 1.5)) for j in range(n_stale)]
        centres = [(float(k), 5.0) for k in range(n_seen)]
        column = {id(mate): j for j, mate in enumerate(fresh + stale)}

        def distance(seen, mate, table=table, column=column):
            return table[int(seen[0])][column[id(mate)]]

        expected = []
        for k in range(n_seen):
            for j in range(n_fresh):
                best = table[k][j]
                others = [v for i, v in enumerate(table[k]) if i != j] + [table[i][j] for i in range(n_seen) if i != k]
                if not best > MATCH_GATE and all(other >= best + AMBIGUITY for other in others):
                    expected.append((centres[k], fresh[j]))
        got = match_teammates(centres, fresh + stale, [0, 2, 3, 4], 10.0, 1.0, by_pair(distance))
        assert got == expected, table
