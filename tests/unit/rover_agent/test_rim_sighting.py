"""A crater's rim as a landmark (``sightings.rim_centre``, ``Estimator.learn``): crater terrain hits scripted as
perception draws them, where rays enter the circle at which the crater's terrain begins; no world, no router."""

from __future__ import annotations

import copy
import logging
import math
import random

from bus.rejections import Rejections
from rover_agent.decisions import Goal, Hit, MoveTo
from rover_agent.estimation import estimator as estimator_module
from rover_agent.estimation import rim_look
from rover_agent.estimation.estimator import Estimator
from rover_agent.estimation.pose_filter import Localisation, NoiseModel
from rover_agent.estimation.sightings import rim_centre, rim_landmark
from rover_agent.mission.goals import Mission
from schemas import messages as m
from schemas.params import NavigationParams, RoverParams
from shared.pose import Pose

RAYS = [-105.0 + i * 210.0 / 49 for i in range(50)]


def scan(centre: tuple[float, float], edge: float, reach: float = 10.0) -> tuple[Hit, ...]:
    """Crater terrain hits of a circle (rover-relative centre, x right, z ahead) as the rays meet it."""
    hits = []
    for a in RAYS:
        dx, dz = math.sin(math.radians(a)), math.cos(math.radians(a))
        b = -(dx * centre[0] + dz * centre[1])
        c = centre[0] ** 2 + centre[1] ** 2 - edge ** 2
        if (disc := b * b - c) >= 0 and (t := -b - math.sqrt(disc)) >= 0 and t <= reach:
            hits.append(Hit(round(a, 3), round(t, 3), "crater_terrain"))
    return tuple(hits)


def test_the_centre_of_a_rim_in_view_is_fitted_from_its_arc():
    for centre, edge in (((3.0, 25.0), 19.5), ((-10.0, 52.0), 45.5), ((6.0, 18.0), 15.6)):
        fitted = rim_centre(scan(centre, edge), edge)
        assert fitted is not None and math.dist(fitted, centre) < 0.05


def test_no_fit_from_a_few_hits_a_rim_of_another_size_or_from_inside():
    hits = scan((3.0, 25.0), 19.5)
    assert rim_centre(hits[:3], 19.5) is None
    assert rim_centre(hits, 30.0) is None  # a crater the plan does not have: the hits stray from its circle
    assert rim_centre(scan((0.0, 5.0), 19.5), 19.5) is None  # inside the rim no ray enters: nothing to fit


def test_a_rover_off_its_estimate_is_fixed_by_the_rim_of_its_crater_goal():
    params = RoverParams(navigation=NavigationParams(slip_std=0.05, heading_noise_std_deg=1.0))
    est = Estimator(1, params, Rejections(logging.getLogger("test")))
    est.place(Pose(0.0, 0.0, 0.0))
    for _ in range(12):  # walked ~100 m north by its estimate; the ground took it 6 m east of that
        est.completed(est.pose, MoveTo(0.0, 8.0))
    std_before = est.localisation.position_std
    truth = (est.pose.x + 6.0, est.pose.z)
    crater = (truth[0] + 2.0, truth[1] + 25.0, 19.5)  # dead ahead of where the rover truly stands
    hits = scan((crater[0] - truth[0], crater[1] - truth[1]), crater[2])
    est.localise(100.0, hits, "migrating", [])
    assert est.pose.x == 0.0  # no crater goal given yet: crater terrain is only ground
    est.learn(Goal(0, 1, "crater", crater[0], crater[1] - 3.0, rim=crater))
    est.localise(100.2, hits, "migrating", [])
    assert math.dist((est.pose.x, est.pose.z), truth) < 0.4 * 6.0  # one look: the rest may be the heading's
    assert est.localisation.position_std < std_before


def test_the_lander_tells_the_crater_of_a_crater_goal_and_the_rover_keeps_it():
    params = RoverParams()
    mission = Mission(1, params, None)
    goal = mission.direction(m.MissionDirection(goal_index=0, goals_total=1, kind="crater", bearing_deg=90.0,
                                                distance_m=100.0, rim=(2.0, -1.0, 19.5)), 0.0)
    assert goal is not None and goal.rim is not None
    assert [round(v, 6) for v in goal.rim] == [102.0, -1.0, 19.5]


def unsure_heading(x: float, z: float, heading: float, heading_std_deg: float) -> Localisation:
    return Localisation(Pose(x, z, heading), NoiseModel(0.05, math.radians(1.0)),
                        [[4.0, 0.0, 0.0], [0.0, 4.0, 0.0], [0.0, 0.0, math.radians(heading_std_deg) ** 2]])


def test_a_rover_just_out_of_a_crater_it_left_turns_once_to_look_at_its_rim():
    rims = {0: (0.0, 0.0, 35.0)}  # the first goal's crater; the rover is on its way to goal 1
    walking_out = unsure_heading(0.0, 38.0, 0.0, 4.0)  # 3 m outside the rim, facing away from it
    looked: set[int] = set()
    assert rim_look.turn(walking_out, rims, 1, looked, 10.0) == (0, -180.0)
    assert rim_look.turn(walking_out, rims, 0, set(), 10.0) is None  # still bound for that crater: nothing left
    assert rim_look.turn(unsure_heading(0.0, 38.0, 0.0, 1.0), rims, 1, set(), 10.0) is None  # sure of its heading
    assert rim_look.turn(unsure_heading(0.0, 35.5, 0.0, 4.0), rims, 1, set(), 10.0) is None  # not out of it yet
    assert rim_look.turn(unsure_heading(0.0, 50.0, 0.0, 4.0), rims, 1, set(), 10.0) is None  # the rim out of view
    sideways = set()
    assert rim_look.turn(unsure_heading(0.0, 38.0, 200.0, 4.0), rims, 1, sideways, 10.0) is None  # in view: no turn
    assert sideways == {0}


def test_the_estimator_looks_back_once_a_crater():
    params = RoverParams(navigation=NavigationParams(slip_std=0.05, heading_noise_std_deg=1.0))
    est = Estimator(1, params, Rejections(logging.getLogger("test")))
    est.resume(Pose(0.0, 38.0, 0.0), [[4.0, 0.0, 0.0], [0.0, 4.0, 0.0], [0.0, 0.0, math.radians(4.0) ** 2]])
    est.learn(Goal(0, 2, "crater", 0.0, 0.0, rim=(0.0, 0.0, 35.0)))
    onward = Goal(1, 2, "waypoint", 0.0, 150.0)
    assert abs(est.look_back(onward, 10.0)) == 180.0
    assert est.look_back(onward, 10.0) is None


def _walked_off(rng: random.Random) -> tuple[Estimator, tuple[float, float]]:
    """An estimator that walked ~100 m north with slip and heading noise, and where the rover truly stands."""
    params = RoverParams(navigation=NavigationParams(slip_std=rng.uniform(0.01, 0.1),
                                                     heading_noise_std_deg=rng.uniform(0.1, 3.0)))
    est = Estimator(1, params, Rejections(logging.getLogger("test")))
    est.place(Pose(0.0, 0.0, 0.0))
    for _ in range(12):
        est.completed(est.pose, MoveTo(0.0, 8.0))
    return est, (est.pose.x + rng.uniform(-8.0, 8.0), est.pose.z + rng.uniform(-8.0, 8.0))


def _counted_fits(monkeypatch) -> list[float]:
    """The radius of each rim fit the estimator makes from now on."""
    fitted: list[float] = []

    def counted(hits: tuple[Hit, ...], edge: float) -> tuple[float, float] | None:
        fitted.append(edge)
        return rim_centre(hits, edge)

    monkeypatch.setattr(estimator_module, "rim_centre", counted)
    return fitted


def test_rims_a_scan_cannot_show_cost_no_fit_and_change_no_correction(monkeypatch):
    """Against the plain rule (fit every rim kept, take the nearest sighting, gate it): the same pose and
    covariance after each scan, with rims near and far, of the crater seen, of its radius elsewhere and of other
    radii; and only rims the gate could take are fitted."""
    fitted = _counted_fits(monkeypatch)
    rng = random.Random(11)
    for case in range(150):
        est, truth = _walked_off(rng)
        crater = (truth[0] + rng.uniform(-5.0, 5.0), truth[1] + rng.uniform(22.0, 30.0), rng.choice([15.6, 19.5]))
        hits = scan((crater[0] - truth[0], crater[1] - truth[1]), crater[2])
        rims = [crater] + [(crater[0] + rng.uniform(-60.0, 60.0), crater[1] + rng.uniform(-60.0, 60.0),
                            rng.choice([crater[2], 12.0, 30.0])) for _ in range(rng.randrange(0, 6))]
        rims += [(rng.uniform(1e3, 1e5), rng.uniform(-1e5, 1e5), 5.0 + i) for i in range(rng.randrange(0, 40))]
        for index, rim in enumerate(rims):
            est.learn(Goal(index, len(rims), "crater", rim[0], rim[1], rim=rim))
        plain = copy.deepcopy(est.localisation)
        marks = [rim_landmark(centre, rim) for rim in set(est.rims.values())
                 if (centre := rim_centre(hits, rim[2])) is not None]
        if marks:
            plain.observe(min(marks, key=plain.mahalanobis))
        fitted.clear()
        est.localise(100.0, hits, "migrating", [])
        assert (est.pose, est.localisation.cov) == (plain.pose, plain.cov), f"case {case}"
        assert len(fitted) == len(set(fitted)) <= 4, f"case {case}: fitted {fitted}"


def test_a_scan_fits_the_radii_of_the_nearest_rims_only_however_many_the_lander_names(monkeypatch):
    fitted = _counted_fits(monkeypatch)
    est, truth = _walked_off(random.Random(3))
    crater = (truth[0], truth[1] + 25.0, 19.5)
    rims = [(crater[0] + 0.01 * i, crater[1] + 0.5 * i, 19.0 + 0.01 * i) for i in range(1, 60)] + [crater]
    for index, rim in enumerate(rims):
        est.learn(Goal(index, len(rims), "crater", rim[0], rim[1], rim=rim))
    est.localise(100.0, scan((0.0, 25.0), 19.5), "migrating", [])
    assert len(fitted) == estimator_module.MAX_RIM_FITS
    assert sorted(fitted) == [19.01, 19.02, 19.03, 19.5]  # the rims whose edges lie nearest the estimate
