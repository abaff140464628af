"""What perception shows of things whose place the rover knows: the lander, rovers whose estimates it heard, and
the rim of a crater whose place and size the mission plan gives (``rim_centre``: a circle of known radius fitted
to its crater terrain hits).

Perception gives, for each ray that met something, its angle, distance and kind (report 10.1.3), so a thing is a
run of hits on its near side. Lander and rovers are upright cylinders: their centre, the point the filter needs
(``pose_filter``), is fitted from the hits. Perception says a hit is a rover, not which one; the radio
says which rovers are in range (``CommPartners``) and what each believes of its own place (``radio.PoseEstimate``),
so a rover seen is matched to a teammate's estimate only where the match can hardly be another
(``match_teammates``).

Pure functions of the hits: tested with scripted perception, no router.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from rover_agent.decisions import Hit
from rover_agent.estimation.matrices import Matrix
from rover_agent.estimation.pose_filter import Landmark
from schemas import radio

LANDER_SIGHTING_STD_M = 0.2
"""1-sigma error of the lander's fitted centre on each axis: an assumption for a real rover's ranging (the
simulated one is exact to the millimetre)."""
ROVER_SIGHTING_STD_M = 0.3
"""1-sigma error of another rover's fitted centre: a small rover shows on one or two rays, so its centre is known
to about its radius."""
MAX_FIT_RMS_M = 0.05
"""A lander fit whose hits stray from a circle by more than this is no fit (hits of something else)."""
MATCH_GATE = 9.21
"""Chi-square, 2 degrees of freedom, 99%: a rover seen farther than this (Mahalanobis, squared) from where a
teammate's estimate puts it is not that teammate."""
AMBIGUITY = 9.0
"""How much farther (Mahalanobis, squared) every other pairing must be for a match to stand: a likelihood ratio
of e^4.5, about 90."""
IN_RANGE_MARGIN_M = 2.0
"""A rover seen this much inside radio range was most likely in it too when the partners were last told (once a
second; rovers walk at most 3.5 m/s, and rarely straight apart)."""
ESTIMATE_MAX_AGE_S = 1.0
"""A teammate's estimate older than this is not matched: it walks up to 3.5 m a second."""
FORGET_AFTER_S = 2 * ESTIMATE_MAX_AGE_S
"""A teammate's estimate older than this is forgotten (``estimator.Estimator.heard``: a flood of senders must not
pile up). Until then it still counts against a match: a rover whose estimate has just gone stale (told a little
late, or lost) is still there to be seen, and must not be taken for another teammate because its own estimate
dropped out."""
RIM_SIGHTING_SHARE = 0.05
RIM_SIGHTING_LEAST_M = 1.0
"""1-sigma error of a crater's centre fitted to its rim, on each axis: this share of the radius at which its
terrain begins, at least the least. An assumption for a real rim, which is no perfect circle, and for the plan's
measure of it from orbit (the simulated rim is exact)."""
MIN_RIM_HITS = 4
MIN_RIM_ARC_DEG = 10.0
"""A rim fit needs this many crater terrain hits spanning at least this angle seen from the centre: a shorter arc
of a wide crater is nearly straight, and leaves where along it the centre lies to the noise."""
MAX_RIM_RMS_M = 0.1
"""A rim fit whose hits stray from the circle by more than this is no fit (two craters' rims in view, say)."""


@dataclass(frozen=True)
class Teammate:
    """The latest estimate a teammate sent of itself (``radio.PoseEstimate``)."""

    rover_id: int
    estimate: radio.PoseEstimate


def point(hit: Hit) -> tuple[float, float]:
    """A hit as a rover-relative point: x to the right, z ahead (angles negative to the left)."""
    a = math.radians(hit.angle_deg)
    return hit.distance_m * math.sin(a), hit.distance_m * math.cos(a)


def lander_centre(hits: tuple[Hit, ...]) -> tuple[float, float] | None:
    """The lander's centre, rover-relative, from at least three lander hits (a circle fitted to them; the lander
    is the only thing of its kind, so every such hit is on it); None if too few or they fit no circle."""
    pts = [point(h) for h in hits if h.kind == "lander"]
    if len(pts) < 3:
        return None
    fit = _circle(pts)
    if fit is None:
        return None
    cx, cz, r = fit
    rms = math.sqrt(sum((math.hypot(x - cx, z - cz) - r) ** 2 for x, z in pts) / len(pts))
    nearest = min(math.hypot(x, z) for x, z in pts)
    if not (0.2 <= r <= 20.0) or rms > MAX_FIT_RMS_M or math.hypot(cx, cz) <= nearest:
        return None
    return cx, cz


def rover_centres(hits: tuple[Hit, ...], rover_radius: float, ray_step_deg: float) -> list[tuple[float, float]]:
    """The centre of each rover seen: runs of rover hits on neighbouring rays at about the same distance."""
    runs: list[list[Hit]] = []
    for hit in sorted((h for h in hits if h.kind == "rover"), key=lambda h: h.angle_deg):
        last = runs[-1][-1] if runs else None
        if (last is not None and hit.angle_deg - last.angle_deg <= 1.5 * ray_step_deg
                and abs(hit.distance_m - last.distance_m) <= rover_radius):
            runs[-1].append(hit)
        else:
            runs.append([hit])
    return [_known_circle([point(h) for h in run], rover_radius) for run in runs]


Distances = Callable[[list[tuple[float, float]], list[Teammate]], list[list[float]]]
"""Rovers seen and teammates -> the table of how far each one seen lies from each teammate, a row a rover seen."""


def match_teammates(centres: list[tuple[float, float]], teammates: list[Teammate], partners: list[int], now: float,
                    comm_range: float, distances: Distances) -> list[tuple[tuple[float, float], Teammate]]:
    """Pairs (rover seen, its estimate) that cannot well be another pairing; ``distances``: how far (Mahalanobis,
    squared) each rover seen lies from where each teammate's estimate and this rover's put it.

    The radio's partners are the rovers in range: so a single rover seen well within range, with a single rover
    partner that sent a fresh estimate, is that partner, wherever the estimates put the two (the filter's gate
    still checks). Otherwise a pair of a rover seen and a fresh estimate must lie within ``MATCH_GATE`` and every
    other pairing of either (the rover seen with another teammate, the teammate with another rover seen)
    ``AMBIGUITY`` farther: a likelihood some hundred times smaller. The other teammates include those whose
    estimates are stale but not yet forgotten (``FORGET_AFTER_S``), which are never matched themselves."""
    fresh = [t for t in teammates if now - t.estimate.stamp <= ESTIMATE_MAX_AGE_S]
    rovers_in_range = [p for p in partners if p != 0]
    if len(centres) == 1 and len(rovers_in_range) == 1 and math.hypot(*centres[0]) <= comm_range - IN_RANGE_MARGIN_M:
        return [(centres[0], t) for t in fresh if t.rover_id == rovers_in_range[0]]
    known = fresh + [t for t in teammates if ESTIMATE_MAX_AGE_S < now - t.estimate.stamp <= FORGET_AFTER_S]
    d = distances(centres, known)
    rows = [_Least(row) for row in d]
    columns = [_Least([row[j] for row in d]) for j in range(len(fresh))]
    pairs = []
    for k, centre in enumerate(centres):
        for j, mate in enumerate(fresh):
            best = d[k][j]
            if best > MATCH_GATE:
                continue
            if rows[k].all_but(j, best + AMBIGUITY) and columns[j].all_but(k, best + AMBIGUITY):
                pairs.append((centre, mate))
    return pairs


class _Least:
    """The two least numbers of a row (or column) of distances, and how many are NaN: whether all but one are at
    least a bound, in constant time. Listing the others for each candidate pair made matching grow with the cube
    of the rovers seen and the teammates heard (14 s a scan with 800 and 200 in a forged one)."""

    def __init__(self, values: list[float]) -> None:
        self.values = values
        self.nans = 0
        first: tuple[float, int] | None = None
        second: tuple[float, int] | None = None
        for i, v in enumerate(values):  # of equal values the first is the lesser, as in a sort of (value, index)
            if v != v:
                self.nans += 1
            elif first is None or v < first[0]:
                first, second = (v, i), first
            elif second is None or v < second[0]:
                second = (v, i)
        self.least = [pair for pair in (first, second) if pair is not None]

    def all_but(self, skip: int, floor: float) -> bool:
        """``all(v >= floor for i, v in enumerate(values) if i != skip)``: a NaN is never at least anything."""
        if self.nans - (self.values[skip] != self.values[skip]):
            return False
        others = [v for v, i in self.least if i != skip][:1]
        return not others or others[0] >= floor


def teammate_landmark(centre: tuple[float, float], mate: Teammate, now: float, top_speed: float) -> Landmark:
    """A teammate seen, as a landmark: its estimate, less sure by how far it may have walked since (when it said it
    was walking)."""
    e = mate.estimate
    return Landmark(centre, (e.x, e.z), teammate_spread(mate, now, top_speed), ROVER_SIGHTING_STD_M, shared=True)


def teammate_spread(mate: Teammate, now: float, top_speed: float) -> Matrix:
    """How unsure a teammate's place is (2 x 2): its estimate's covariance, grown by how far it may have walked
    since it sent it (when it said it was walking)."""
    e = mate.estimate
    walked = top_speed * max(0.0, now - e.stamp) if e.moving else 0.0
    return [[e.cov_xx + walked ** 2, e.cov_xz], [e.cov_xz, e.cov_zz + walked ** 2]]


def rim_centre(hits: tuple[Hit, ...], edge_radius: float) -> tuple[float, float] | None:
    """A crater's centre, rover-relative, from the crater terrain hits of its rim seen from outside: a circle of
    the radius at which its terrain begins (``edge_radius``, from the mission plan) fitted to them; None for too
    few hits, too short an arc, or a poor fit."""
    pts = [point(h) for h in hits if h.kind == "crater_terrain" and h.distance_m > 0.0]
    if len(pts) < MIN_RIM_HITS:
        return None
    centre = _fit_known_radius(pts, edge_radius)
    if centre is None:
        return None
    cx, cz = centre
    rms = math.sqrt(sum((math.hypot(x - cx, z - cz) - edge_radius) ** 2 for x, z in pts) / len(pts))
    bearings = [math.atan2(x - cx, z - cz) for x, z in pts]
    mid = math.atan2(sum(math.sin(b) for b in bearings), sum(math.cos(b) for b in bearings))
    spread = [abs((b - mid + math.pi) % (2 * math.pi) - math.pi) for b in bearings]
    arc = math.degrees(2 * max(spread))
    if rms > MAX_RIM_RMS_M or arc < MIN_RIM_ARC_DEG or math.hypot(cx, cz) <= edge_radius:
        return None
    return cx, cz


def rim_landmark(centre: tuple[float, float], rim: tuple[float, float, float]) -> Landmark:
    """A crater's rim seen: its centre, where the mission plan puts it (``Goal.rim``)."""
    std = max(RIM_SIGHTING_LEAST_M, RIM_SIGHTING_SHARE * rim[2])
    return Landmark(centre, (rim[0], rim[1]), [[0.0, 0.0], [0.0, 0.0]], std)


def _fit_known_radius(pts: list[tuple[float, float]], radius: float) -> tuple[float, float] | None:
    """Least squares (Gauss-Newton) centre of a circle of known radius through points on its near side, from the
    centre straight behind the nearest point; None if it does not settle."""
    cx, cz = _circle_start(pts, radius)
    for _ in range(20):
        step = _circle_step(pts, cx, cz, radius)
        if step is None:
            return None
        cx, cz = cx - step[0], cz - step[1]
        if math.hypot(*step) < 1e-6:
            return cx, cz
    return None


def lander_landmark(centre: tuple[float, float]) -> Landmark:
    """The lander seen: the origin of the frame every rover navigates in, known exactly."""
    return Landmark(centre, (0.0, 0.0), [[0.0, 0.0], [0.0, 0.0]], LANDER_SIGHTING_STD_M)


def _circle(pts: list[tuple[float, float]]) -> tuple[float, float, float] | None:
    """Least-squares circle (centre x, z and radius) through points: x^2 + z^2 + a x + b z + c = 0."""
    sums = [[0.0] * 3 for _ in range(3)]
    rhs = [0.0] * 3
    for x, z in pts:
        row, target = (x, z, 1.0), -(x * x + z * z)
        for i in range(3):
            rhs[i] += row[i] * target
            for j in range(3):
                sums[i][j] += row[i] * row[j]
    solved = _solve3(sums, rhs)
    if solved is None:
        return None
    a, b, c = solved
    r2 = a * a / 4 + b * b / 4 - c
    return (-a / 2, -b / 2, math.sqrt(r2)) if r2 > 0 else None


def _solve3(m: list[list[float]], v: list[float]) -> list[float] | None:
    """Cramer's rule for a 3 x 3 system; None if (nearly) singular."""
    def det(a: list[list[float]]) -> float:
        return (a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
                + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]))
    d = det(m)
    if abs(d) < 1e-12:
        return None
    out = []
    for k in range(3):
        swapped = [[v[i] if j == k else m[i][j] for j in range(3)] for i in range(3)]
        out.append(det(swapped) / d)
    return out


def _known_circle(pts: list[tuple[float, float]], radius: float) -> tuple[float, float]:
    """The centre of a circle of known radius whose near side the points lie on: a radius behind the nearest
    point, then refined (Gauss-Newton) when two points or more pin it down better."""
    cx, cz = start = _circle_start(pts, radius)
    if len(pts) < 2:
        return start
    for _ in range(5):
        step = _circle_step(pts, cx, cz, radius)
        if step is None:
            break
        cx, cz = cx - step[0], cz - step[1]
    return (cx, cz) if math.dist((cx, cz), start) <= radius else start


def _circle_start(pts: list[tuple[float, float]], radius: float) -> tuple[float, float]:
    """A radius straight behind the nearest point: where a circle's centre is, seen from its near side."""
    nx, nz = min(pts, key=lambda p: math.hypot(*p))
    d = max(math.hypot(nx, nz), 1e-9)  # a hit at no distance (rounded to the millimetre): no way to look
    return nx + radius * nx / d, nz + radius * nz / d


def _circle_step(pts: list[tuple[float, float]], cx: float, cz: float,
                 radius: float) -> tuple[float, float] | None:
    """One Gauss-Newton step of a known-radius circle's centre (to subtract); None when the points leave it
    unknown (the normal equations are singular). A point at the centre has no direction and is left out."""
    xx = xz = zz = rx = rz = 0.0  # J^T J (symmetric: g0 g1 is g1 g0 to the bit) and J^T r, summed point by point
    for x, z in pts:
        dist = math.hypot(x - cx, z - cz)
        if dist < 1e-9:
            continue
        g0, g1, res = (cx - x) / dist, (cz - z) / dist, dist - radius
        rx += g0 * res
        rz += g1 * res
        xx += g0 * g0
        xz += g0 * g1
        zz += g1 * g1
    det = xx * zz - xz * xz
    if abs(det) < 1e-12:
        return None
    return (zz * rx - xz * rz) / det, (xx * rz - xz * rx) / det
