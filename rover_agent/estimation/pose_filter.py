"""Localisation without ground truth (report 7.2.1-7.2.2): an extended Kalman filter over the rover's
pose (x, z, heading) in the lander frame.

Dead reckoning alone (``shared.pose``) drifts: the ground slips every move by a share of its length and every
move or rotate turns the heading a little (``NavigationParams.slip_std``, ``heading_noise_std_deg``), and the rover
senses neither. So beside the dead-reckoned pose the filter keeps how unsure of it the rover is, a covariance grown
by each action exactly as the rover's own noise parameters say, and corrects the pose whenever perception shows a
thing whose place it knows (``observe``): the lander, the origin of the frame, known exactly; or another rover,
known as well as that rover's own estimate, heard over the radio. A known landmark's update is iterated (a
sighting is nonlinear in the heading, and far from where the rover thought it stood a single linearisation
misleads: ``Localisation._observe_known``). Another rover's estimate may share errors with
this one (they may have corrected each other before), so it is fused by covariance intersection, which stays
consistent whatever the correlation, rather than by a plain Kalman update, which would grow overconfident.

With zero noise parameters the covariance stays exactly zero and ``observe`` changes nothing, so a noise-free
mission runs exactly as plain dead reckoning does. Pure logic on plain floats (a flight computer needs no numeric
stack for 3 x 3 matrices); the agent feeds it (``estimator``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rover_agent.estimation.matrices import (
    Matrix,
    add,
    inverse2,
    mul,
    positive_definite,
    quadratic,
    sandwich,
    scaled,
    symmetric,
    transpose,
    zeros,
)
from rover_agent.estimation.shared_gauge import SharedGauge
from schemas.params import NavigationParams
from shared.pose import Pose

CI_WEIGHTS = tuple(i / 20 for i in range(1, 20))
"""The weights covariance intersection may give this rover's own estimate (the rest goes to the sighting): never
all or nothing, so neither side is ever ignored outright."""
GATE_999 = 13.82
"""Chi-square, 2 degrees of freedom, 99.9%: a sighting farther than this from what the estimate predicts, in its
own uncertainty, is a wrong match or a bad fit, not this rover's drift."""
MAX_ITERATIONS = 10
SETTLED = 1e-9
"""A sighting's iterated update (``Localisation._observe_known``) stops once a step moves the estimate less than
this (metres, radians) or after this many steps: it settles in three or four."""


@dataclass(frozen=True)
class NoiseModel:
    """What the rover knows of its own navigation errors: its ``NavigationParams``, the same figures the world
    draws its slips and turns from. ``slip_std``: 1-sigma slip on each axis, a share of a move's length;
    ``heading_std_rad``: 1-sigma heading error each completed move or rotate adds."""

    slip_std: float = 0.0
    heading_std_rad: float = 0.0

    @classmethod
    def of(cls, params: NavigationParams) -> NoiseModel:
        return cls(params.slip_std, math.radians(params.heading_noise_std_deg))

    @property
    def silent(self) -> bool:
        return self.slip_std == 0.0 and self.heading_std_rad == 0.0


@dataclass(frozen=True)
class Landmark:
    """Something perception shows at ``seen`` (rover-relative metres: x right, z ahead) whose place in the lander
    frame is ``at``, give or take ``cov`` (2 x 2, square metres; zero for the lander). ``sensor_std``: 1-sigma error
    of ``seen`` on each axis. ``shared``: its place comes from an estimate that may share errors with this rover's
    (another rover's), so it is fused by covariance intersection."""

    seen: tuple[float, float]
    at: tuple[float, float]
    cov: Matrix
    sensor_std: float
    shared: bool = False


class Localisation:
    """The pose estimate and its covariance (x and z in metres, heading in radians: rows and columns x, z, h).

    Actions are applied from the pose they started at (``start``), as dead reckoning did, so an estimate updated
    between an action's start and its end (the agent does not) would not be moved twice."""

    def __init__(self, pose: Pose, noise: NoiseModel, cov: Matrix | None = None) -> None:
        self.pose = pose
        self.noise = noise
        self.cov = [list(row) for row in cov] if cov is not None else zeros(3)

    @property
    def exact(self) -> bool:
        """Nothing to correct: the rover knows no noise, or has not moved since it was told where it stands."""
        return not any(map(any, self.cov))  # a float is false only when it is 0.0 (NaN is true)

    @property
    def position_std(self) -> float:
        """1-sigma position error, metres (the root of the position covariance's trace)."""
        return math.sqrt(max(0.0, self.cov[0][0] + self.cov[1][1]))

    # ---- prediction: what each action does to the estimate ----

    def moved(self, start: Pose, rel_x: float, rel_z: float) -> None:
        """A completed move: on its goal facing along it (dead reckoning), give or take a slip in proportion to its
        length on each axis and a turn of the heading."""
        end = start.after_move(rel_x, rel_z)
        slip = self.noise.slip_std * math.hypot(rel_x, rel_z)
        self.cov = self._carried(start, end, slip, self.noise.heading_std_rad)
        self.pose = end

    def rotated(self, start: Pose, degrees: float) -> None:
        """A completed rotate: the heading turns as asked, give or take its error; the position stays."""
        self.pose = start.after_rotate(degrees)
        self.cov = add(self.cov, [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, self.noise.heading_std_rad ** 2]])

    def stopped_early(self, start: Pose, rel_x: float, rel_z: float, angle_deg: float) -> None:
        """A move that ended early: its CancelResult measures where the rover stopped relative to where it started,
        slip and all, and a move turns the heading only on arriving: the error is only the start's, carried along."""
        end = start.after_partial(rel_x, rel_z, angle_deg)
        self.cov = self._carried(start, end, 0.0, 0.0)
        self.pose = end

    def part_way(self, start: Pose, rel_x: float, rel_z: float, walked_m: float) -> tuple[Pose, Matrix]:
        """Where a move under way has got to after ``walked_m`` along it, and how unsure that is (the slip grows
        along the way), without changing the estimate: what the rover tells others while it walks."""
        length = math.hypot(rel_x, rel_z)
        share = min(1.0, max(0.0, walked_m / length)) if length > 1e-9 else 0.0
        here = start.after_partial(rel_x * share, rel_z * share, 0.0)
        return here, self._carried(start, here, self.noise.slip_std * length * share, 0.0)

    def predicted_std(self, to: tuple[float, float], step_m: float) -> float:
        """The 1-sigma position error the estimate would have after walking straight from here to ``to`` in moves
        of ``step_m`` (a turn to face it first), as this rover's own noise says: what drift will do to a goal."""
        ahead = Localisation(self.pose, self.noise, self.cov)
        turn = (math.degrees(math.atan2(to[0] - self.pose.x, to[1] - self.pose.z)) - self.pose.heading) % 360.0
        ahead.rotated(ahead.pose, turn)
        left = math.hypot(to[0] - self.pose.x, to[1] - self.pose.z)
        whole = left // step_m  # in closed form: a goal may be any distance off (a MissionDirection's is unbounded)
        if whole > 0:
            ahead._walked_straight(whole, step_m)
        rest = min(step_m, max(0.0, left - whole * step_m))
        if rest > 1e-9:
            ahead.moved(ahead.pose, 0.0, rest)
        if not all(math.isfinite(v) for row in ahead.cov for v in row):
            return math.inf
        return ahead.position_std

    def _walked_straight(self, n: float, step_m: float) -> None:
        """``n`` moves of ``step_m`` straight ahead, as ``n`` calls of ``moved`` would leave the estimate: the sums
        of their F P F^T + Q in closed form (the heading's variance grows by one move's each move, and each swings
        the rest of the way), so the cost does not grow with the way's length."""
        start = self.pose
        one = start.after_move(0.0, step_m)
        u = (one.z - start.z, start.x - one.x)  # F's heading column for one move: (dz, -dx)
        p, a = self.cov, self.cov[2][2]
        c = (p[0][2], p[1][2])
        q, h = (self.noise.slip_std * step_m) ** 2, self.noise.heading_std_rad ** 2
        swing = a * n * n + h * (n - 1) * n * (2 * n - 1) / 6  # sum over the moves of 2 P_ph(k) / u + P_hh(k)
        turned = n * a + h * n * (n - 1) / 2  # sum over the moves of P_hh(k)
        cov = zeros(3)
        for i in range(2):
            for j in range(2):
                cov[i][j] = p[i][j] + n * (u[i] * c[j] + c[i] * u[j]) + swing * u[i] * u[j] + (n * q if i == j else 0.0)
            cov[i][2] = cov[2][i] = c[i] + u[i] * turned
        cov[2][2] = a + n * h
        self.cov = symmetric(cov)
        self.pose = start.after_move(0.0, n * step_m)

    def _carried(self, start: Pose, end: Pose, slip: float, turn: float) -> Matrix:
        """F P F^T + Q: a heading error at the start swings the displacement (end - start) about the start."""
        dx, dz = end.x - start.x, end.z - start.z
        f = [[1.0, 0.0, dz], [0.0, 1.0, -dx], [0.0, 0.0, 1.0]]
        carried = sandwich(f, self.cov)
        q = [[slip ** 2, 0.0, 0.0], [0.0, slip ** 2, 0.0], [0.0, 0.0, turn ** 2]]
        return symmetric(add(carried, q))

    # ---- correction: a landmark seen ----

    def observe(self, landmark: Landmark, gate: float | None = GATE_999) -> bool:
        """Correct the estimate with a landmark seen; False when nothing changed (an exact estimate, a degenerate
        geometry, or a sighting outside ``gate``, a Mahalanobis distance squared; None: no gate)."""
        if self.exact:
            return False
        before = self.pose, self.cov
        changed = self._observe_shared(landmark, gate) if landmark.shared else self._observe_known(landmark, gate)
        if changed and not self._sane():  # overflow, or round-off gone wrong: keep what was known before
            self.pose, self.cov = before
            return False
        return changed

    def _observe_known(self, landmark: Landmark, gate: float | None) -> bool:
        """An iterated update (Gauss-Newton on the sighting, linearised again at each new estimate until it
        settles). A sighting's Jacobian in the heading is the landmark's offset as the estimate predicts it, and the
        first sighting of the lander after a long walk can find the rover metres from where it thought, at a range
        unlike the predicted one: linearised there once, the update takes the position from the sighting as if the
        heading turned a shorter offset, and states a pose far from the truth as sure."""
        prior = self.pose
        if not positive_definite(symmetric(_predicted(prior, landmark)[2])):  # at any heading, or none
            return False
        if gate is not None and not self.mahalanobis(landmark) <= gate:
            return False
        estimate, update = prior, None
        for _ in range(MAX_ITERATIONS):
            h, jac, r = _predicted(estimate, landmark)
            pht = mul(self.cov, transpose(jac))
            back = _difference(prior, estimate)  # the prior less the point of linearisation
            y = [landmark.seen[i] - h[i] - sum(jac[i][k] * back[k] for k in range(3)) for i in range(2)]
            update = _kalman(self.cov, pht, mul(jac, pht), r, y)
            if update is None:
                return False
            moved = _shifted(prior, update[1])
            step = _difference(moved, estimate)
            estimate = moved
            if max(abs(step[0]), abs(step[1]), abs(step[2])) < SETTLED:
                break
        self.cov, self.pose = update[0], estimate
        return True

    def observe_heading(self, heading_deg: float, std_deg: float) -> bool:
        """Correct the estimate with an absolute heading reading (a sun sensor's) of 1-sigma ``std_deg``: the
        heading is the error that grows lateral drift with every metre walked, and its covariance with the position
        (a heading off has swung the walk so far aside) corrects the position along with it. False when nothing
        changed (an exact heading, or a reading with no noise on a heading the rover is sure of)."""
        if self.cov[2][2] <= 0.0 or not math.isfinite(heading_deg):
            return False
        y = math.radians((heading_deg - self.pose.heading + 180.0) % 360.0 - 180.0)
        s = self.cov[2][2] + math.radians(std_deg) ** 2
        k = [self.cov[i][2] / s for i in range(3)]
        before = self.pose, self.cov
        self.cov = symmetric([[self.cov[i][j] - k[i] * self.cov[2][j] for j in range(3)] for i in range(3)])
        self.pose = _shifted(self.pose, [k[i] * y for i in range(3)])
        if not self._sane():
            self.pose, self.cov = before
            return False
        return True

    def _sane(self) -> bool:
        """A pose and covariance that are numbers, with no negative variance."""
        values = [self.pose.x, self.pose.z, self.pose.heading, *(v for row in self.cov for v in row)]
        return all(math.isfinite(v) for v in values) and all(self.cov[i][i] >= 0.0 for i in range(3))

    def _observe_shared(self, landmark: Landmark, gate: float | None) -> bool:
        """A landmark whose place is an estimate that may share errors with this one (another rover's).

        Seen from here, it says where this rover stands: its place less what was seen, turned by this rover's
        heading (whose uncertainty joins the sighting's). The position is fused by covariance intersection,
        consistent whatever the correlation: the Kalman update with the position covariance over w and the
        sighting's over 1 - w. The heading follows through its correlation with the position, and keeps its own
        uncertainty apart from that (intersection on the whole state would scale the heading's, which a sighting
        of a position does not observe, up by 1 / w each time, without bound)."""
        y, r = self._implied_position(landmark)
        pxx = [row[:2] for row in self.cov[:2]]
        s_inv = inverse2(add(pxx, r))
        if s_inv is None or not positive_definite(r) or (gate is not None and not quadratic(y, s_inv) <= gate):
            return False
        w = _intersection_weight(pxx, r)
        pht = [row[:2] for row in self.cov]  # P H^T with H = [I 0]: the sighting sees the position
        update = _kalman(self.cov, pht, pxx, scaled(r, w / (1.0 - w)), y)
        if update is None:
            return False
        cov, x = update
        root = 1.0 / math.sqrt(w)  # D P D, D = diag(root, root, 1): the position block as intersection leaves it
        scale = (root, root, 1.0)
        self.cov = [[cov[i][j] * scale[i] * scale[j] for j in range(3)] for i in range(3)]
        self.pose = _shifted(self.pose, x)
        return True

    def _implied_position(self, landmark: Landmark) -> tuple[list[float], Matrix]:
        """Where a shared landmark seen puts this rover, less where it thinks it is, and that sighting's covariance
        (the landmark's, the sensor's and this rover's heading's, which turns what was seen)."""
        return self.shared_gauge(landmark.sensor_std).implied(landmark.seen, landmark.at, landmark.cov)

    def shared_gauge(self, sensor_std: float) -> SharedGauge:
        """``mahalanobis`` of shared landmarks seen with ``sensor_std``, for many at once (``SharedGauge``)."""
        return SharedGauge(self.pose, self.cov, sensor_std)

    def may_pass(self, landmark: Landmark, seen_within: float, gate: float = GATE_999) -> bool:
        """Whether a sighting of a landmark of known place (not ``shared``), seen no farther than ``seen_within``
        from the rover, could pass ``gate``: its innovation is at least the predicted range less that, and its
        Mahalanobis distance at least the innovation's square over the largest eigenvalue of its covariance. So a
        caller need not make a sighting (fit a rim, say) that observe would turn away."""
        h, s = self._predicted_sighting(landmark)
        half_trace = (s[0][0] + s[1][1]) / 2
        largest = half_trace + math.sqrt(max(half_trace ** 2 - (s[0][0] * s[1][1] - s[0][1] * s[1][0]), 0.0))
        least = math.hypot(h[0], h[1]) - seen_within
        return not (least > 0.0 and least * least > gate * largest * (1 + 1e-6))

    def mahalanobis(self, landmark: Landmark) -> float:
        """How far a sighting lies from what the estimate predicts, in their uncertainty (squared)."""
        if landmark.shared:
            return self.shared_gauge(landmark.sensor_std)(landmark.seen, landmark.at, landmark.cov)
        h, s = self._predicted_sighting(landmark)
        s_inv = inverse2(s)
        return math.inf if s_inv is None else quadratic([landmark.seen[0] - h[0], landmark.seen[1] - h[1]], s_inv)

    def _predicted_sighting(self, landmark: Landmark) -> tuple[list[float], Matrix]:
        """Where a landmark of known place should appear from the estimate, and the covariance of a sighting's
        difference from that (the estimate's uncertainty carried into the sighting, and the sighting's own)."""
        h, jac, r = _predicted(self.pose, landmark)
        return h, add(sandwich(jac, self.cov), r)


def _predicted(pose: Pose, landmark: Landmark) -> tuple[list[float], Matrix, Matrix]:
    """Where the landmark should appear (rover-relative) from ``pose``, the Jacobian of that in (x, z, h), and the
    noise of the sighting: the sensor's and the landmark's own uncertainty seen from the rover."""
    hr = math.radians(pose.heading)
    c, s = math.cos(hr), math.sin(hr)
    dx, dz = landmark.at[0] - pose.x, landmark.at[1] - pose.z
    u, v = dx * c - dz * s, dx * s + dz * c
    jac = [[-c, s, -v], [-s, -c, u]]
    rot = [[c, -s], [s, c]]
    sensor = landmark.sensor_std ** 2
    r = add(sandwich(rot, landmark.cov), [[sensor, 0.0], [0.0, sensor]])
    return [u, v], jac, r


def _shifted(pose: Pose, x: list[float]) -> Pose:
    """``pose`` moved by ``x`` (metres, metres, radians)."""
    return Pose(pose.x + x[0], pose.z + x[1], (pose.heading + math.degrees(x[2])) % 360.0)


def _difference(a: Pose, b: Pose) -> list[float]:
    """``a`` less ``b`` as a state vector (metres, metres, radians; the heading's the shorter way round)."""
    return [a.x - b.x, a.z - b.z, math.radians((a.heading - b.heading + 180.0) % 360.0 - 180.0)]


def _intersection_weight(p: Matrix, r: Matrix) -> float:
    """Covariance intersection of two estimates of a position, covariances ``p`` (this rover's) and ``r`` (the
    sighting's): the weight w in [``CI_WEIGHTS[0]``, ``CI_WEIGHTS[-1]``] for which (w p^-1 + (1 - w) r^-1)^-1 is
    smallest (determinant). det(w A + (1 - w) B) is a quadratic in w, so its largest value on the interval is at an
    end or at the vertex; a singular ``p`` (no uncertainty yet along some direction) is judged on the grid."""
    lo, hi = CI_WEIGHTS[0], CI_WEIGHTS[-1]
    a, b = inverse2(p), inverse2(r)
    if a is None or b is None:
        return _intersection_weight_on_grid(p, r)
    d = add(a, b, -1.0)  # det(B + w D) = det B + w (b11 d22 + b22 d11 - b12 d21 - b21 d12) + w^2 det D
    linear = b[0][0] * d[1][1] + b[1][1] * d[0][0] - b[0][1] * d[1][0] - b[1][0] * d[0][1]
    square = d[0][0] * d[1][1] - d[0][1] * d[1][0]
    candidates = [lo, hi]
    if square < 0:
        candidates.append(min(hi, max(lo, -linear / (2 * square))))
    return max(candidates, key=lambda w: linear * w + square * w * w)


def _intersection_weight_on_grid(p: Matrix, r: Matrix) -> float:
    best, best_w = math.inf, 0.5
    for w in CI_WEIGHTS:
        update = _kalman(scaled(p, 1.0 / w), scaled(p, 1.0 / w), scaled(p, 1.0 / w), scaled(r, 1.0 / (1.0 - w)),
                         [0.0, 0.0])
        if update is not None:
            c = update[0]
            if (volume := c[0][0] * c[1][1] - c[0][1] * c[1][0]) < best:
                best, best_w = volume, w
    return best_w


def _kalman(p: Matrix, pht: Matrix, hph: Matrix, r: Matrix, y: list[float]) -> tuple[Matrix, list[float]] | None:
    """One Kalman update from P, P H^T and H P H^T: the correction and P - K S K^T (kept symmetric)."""
    s_inv = inverse2(add(hph, r))
    if s_inv is None:
        return None
    k = mul(pht, s_inv)
    x = [k[i][0] * y[0] + k[i][1] * y[1] for i in range(len(k))]
    cov = add(p, mul(k, transpose(pht)), -1.0)
    return symmetric(cov), x
