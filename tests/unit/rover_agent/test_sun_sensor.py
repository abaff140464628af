"""An absolute heading reading (a sun sensor's) in the pose filter and the estimator: pure logic with scripted
actions and readings, no world, no router."""

from __future__ import annotations

import logging
import math

import pytest

from bus.rejections import Rejections
from rover_agent.decisions import MoveTo
from rover_agent.estimation.estimator import Estimator
from rover_agent.estimation.pose_filter import Localisation, NoiseModel
from schemas.params import NavigationParams, PerceptionParams, RoverParams
from shared.pose import Pose

NOISY = NoiseModel(slip_std=0.05, heading_std_rad=math.radians(1.0))


def walked(moves: int) -> Localisation:
    """An estimate after ``moves`` moves of 9 m straight ahead (+z) from an exact start."""
    loc = Localisation(Pose(0.0, 0.0, 0.0), NOISY)
    for _ in range(moves):
        loc.moved(loc.pose, 0.0, 9.0)
    return loc


def test_a_heading_reading_corrects_the_heading_and_the_lateral_drift_it_swung():
    loc = walked(30)
    heading_var, lateral_var, along_var = loc.cov[2][2], loc.cov[0][0], loc.cov[1][1]
    assert lateral_var > 4 * along_var  # walking along +z, the heading's error swings the walk aside (x)
    assert loc.observe_heading(3.0, 0.5)  # the sun says the rover faces 3 degrees right of its estimate
    assert loc.cov[2][2] < 0.1 * heading_var
    assert loc.cov[0][0] < lateral_var  # the heading's covariance with x corrects x along with it
    assert loc.cov[1][1] == pytest.approx(along_var, rel=0.05)  # a heading says little of the way walked
    assert 0.0 < loc.pose.heading < 3.0  # pulled towards the reading, by their variances
    assert loc.pose.x > 0.0  # facing further right all along: the walk went right of the estimate's way


def test_a_reading_across_north_is_taken_the_short_way_round():
    loc = Localisation(Pose(0.0, 0.0, 359.0), NOISY, [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.01]])
    assert loc.observe_heading(1.0, 1.0)
    assert loc.pose.heading < 2.0 or loc.pose.heading > 358.0


def test_an_exact_heading_takes_no_reading():
    loc = Localisation(Pose(0.0, 0.0, 10.0), NoiseModel())
    assert not loc.observe_heading(20.0, 1.0)
    assert loc.pose.heading == 10.0


def test_the_estimator_fuses_one_reading_a_stop():
    params = RoverParams(navigation=NavigationParams(slip_std=0.05, heading_noise_std_deg=1.0),
                         perception=PerceptionParams(sun_sensor=True, sun_sensor_noise_std_deg=2.0))
    est = Estimator(1, params, Rejections(logging.getLogger("test"), "test"))
    est.place(Pose(0.0, 0.0, 0.0))
    est.sun(5.0)  # told where it stands, exactly: nothing to correct
    assert est.pose.heading == 0.0
    for _ in range(20):
        est.completed(est.pose, MoveTo(0.0, 9.0))
    before = est.localisation.cov[2][2]
    est.sun(5.0)
    once = est.localisation.cov[2][2]
    assert once < before
    est.sun(5.0)  # the same stop: no news
    assert est.localisation.cov[2][2] == once
    est.completed(est.pose, MoveTo(0.0, 9.0))
    est.sun(5.0)
    assert est.localisation.cov[2][2] < once + math.radians(1.0) ** 2
