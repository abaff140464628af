"""The shared-landmark gauge (``rover_agent.estimation.shared_gauge``) gives, bit for bit, what the pose filter's
matrix algebra gives for a sighting of a teammate: a lockstep run's repeat, and every mission's result, rest on
it. Its answers are checked against that algebra written out with ``matrices`` over arbitrary estimates,
including the singular and non-finite ones."""

from __future__ import annotations

import math
import random

from hypothesis import given, settings
from hypothesis import strategies as st

from rover_agent.estimation.matrices import Matrix, add, inverse2, quadratic
from rover_agent.estimation.pose_filter import Landmark, Localisation, NoiseModel
from rover_agent.estimation.shared_gauge import SharedGauge
from shared.pose import Pose

FLOATS = st.floats(-1e3, 1e3) | st.sampled_from([0.0, -0.0, 1e-10, math.inf, math.nan])
VARIANCES = st.floats(0.0, 1e3) | st.sampled_from([0.0, 1e-12, math.inf, math.nan])
PAIRS = st.tuples(FLOATS, FLOATS)


def _matrix(values: tuple[float, float, float, float]) -> Matrix:
    return [[values[0], values[1]], [values[2], values[3]]]


def _by_matrices(pose: Pose, cov: Matrix, landmark: Landmark) -> tuple[list[float], Matrix, float]:
    """The residual, the sighting's covariance and the distance as lists of lists work them out."""
    hr = math.radians(pose.heading)
    sx, sz = landmark.seen
    ox, oz = sz * math.sin(hr) + sx * math.cos(hr), sz * math.cos(hr) - sx * math.sin(hr)
    y = [landmark.at[0] - ox - pose.x, landmark.at[1] - oz - pose.z]
    sensor, turn = landmark.sensor_std ** 2, cov[2][2]
    r = add(landmark.cov, [[sensor + turn * oz * oz, -turn * oz * ox], [-turn * oz * ox, sensor + turn * ox * ox]])
    s_inv = inverse2(add([row[:2] for row in cov[:2]], r))
    return y, r, math.inf if s_inv is None else quadratic(y, s_inv)


def _same(a: float, b: float) -> bool:
    return a == b or (math.isnan(a) and math.isnan(b))


@settings(max_examples=400, deadline=None)
@given(st.tuples(FLOATS, FLOATS, st.floats(0.0, 360.0)), st.lists(VARIANCES, min_size=9, max_size=9),
       st.lists(PAIRS, min_size=1, max_size=3), st.lists(st.tuples(PAIRS, st.tuples(*[VARIANCES] * 4)),
                                                          min_size=1, max_size=3), st.floats(0.0, 2.0))
def test_every_pair_weighs_what_the_matrix_algebra_weighs_bit_for_bit(pose, cov, seen, landmarks, sensor_std) -> None:
    pose = Pose(*pose)
    cov = [cov[0:3], cov[3:6], cov[6:9]]
    gauge = SharedGauge(pose, cov, sensor_std)
    loc = Localisation(pose, NoiseModel(), cov)
    table = gauge.table(seen, [(at, _matrix(spread)) for at, spread in landmarks])
    for j, (at, spread) in enumerate(landmarks):
        for k, place in enumerate(seen + seen):  # the second time from the gauge's memory of the place
            landmark = Landmark(place, at, _matrix(spread), sensor_std, shared=True)
            y, r, distance = _by_matrices(pose, cov, landmark)
            assert _same(table[k % len(seen)][j], distance)
            assert _same(gauge(place, at, landmark.cov), distance)
            assert _same(loc.mahalanobis(landmark), distance)
            implied_y, implied_r = gauge.implied(place, at, landmark.cov)
            assert all(map(_same, implied_y, y))
            assert all(map(_same, [*implied_r[0], *implied_r[1]], [*r[0], *r[1]]))


def test_a_crowd_of_random_pairs_weighs_what_the_matrix_algebra_weighs_bit_for_bit() -> None:
    """Uniform draws, whose every operation rounds (hypothesis favours values that add up exactly): a re-ordered
    sum in the gauge shows here as a last bit."""
    rng = random.Random(7)
    for _ in range(300):
        pose = Pose(rng.uniform(-50, 50), rng.uniform(-50, 50), rng.uniform(0, 360))
        a, b, c = rng.uniform(0, 2), rng.uniform(0, 2), rng.uniform(-0.5, 0.5)
        cov = [[a, c, 0.01], [c, b, -0.02], [0.01, -0.02, rng.uniform(0, 0.1)]]
        seen = [(rng.uniform(-10, 10), rng.uniform(0, 15)) for _ in range(4)]
        landmarks = []
        for _ in range(6):
            s, t, u = rng.uniform(0, 3), rng.uniform(0, 3), rng.uniform(-0.5, 0.5)
            landmarks.append(((rng.uniform(-60, 60), rng.uniform(-60, 60)), [[s, u], [u, t]]))
        table = SharedGauge(pose, cov, 0.3).table(seen, landmarks)
        for k, place in enumerate(seen):
            for j, (at, spread) in enumerate(landmarks):
                assert table[k][j] == _by_matrices(pose, cov, Landmark(place, at, spread, 0.3, shared=True))[2]


def test_a_singular_sum_of_uncertainties_is_infinitely_far() -> None:
    exact = [[0.0] * 3 for _ in range(3)]
    assert SharedGauge(Pose(0.0, 0.0, 0.0), exact, 0.0)((1.0, 2.0), (3.0, 4.0), [[0.0, 0.0], [0.0, 0.0]]) == math.inf
