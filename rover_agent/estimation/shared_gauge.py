"""Where a sighting of a shared landmark (another rover, placed by its own estimate) puts this rover, and how far
that lies from this rover's estimate in their uncertainty: ``SharedGauge``.

Matching rovers seen to teammates heard weighs every pair of the two (``sightings.match_teammates``): in a crowd
that is thousands of pairs a second for each agent, so the gauge takes its estimate's part once, each place
seen's part once, and works each pair in plain floats, with no matrix built. Its operations, and their order, are
those of the pose filter's update (``Localisation._observe_shared`` takes its residual and covariance from
``implied``): a lockstep run's bit-for-bit repeat rests on that.
"""

from __future__ import annotations

import math

from rover_agent.estimation.matrices import Matrix
from shared.pose import Pose

Terms = tuple[float, float, float, float, float]
"""What a place seen contributes to every pair: where it lies turned into the lander frame (ox, oz), and the
covariance the sensor and this rover's heading give it (xx, xz, zz)."""


class SharedGauge:
    """Sightings of shared landmarks against the estimate ``pose`` (give or take ``cov``, 3 x 3), each place seen
    with a sensor error of ``sensor_std`` on each axis."""

    def __init__(self, pose: Pose, cov: Matrix, sensor_std: float) -> None:
        hr = math.radians(pose.heading)
        self._sin, self._cos = math.sin(hr), math.cos(hr)
        self._x, self._z = pose.x, pose.z
        self._sensor, self._turn = sensor_std ** 2, cov[2][2]
        self._pxx = (cov[0][0], cov[0][1], cov[1][0], cov[1][1])
        self._terms: dict[tuple[float, float], Terms] = {}

    def implied(self, seen: tuple[float, float], at: tuple[float, float],
                cov: Matrix) -> tuple[list[float], Matrix]:
        """Where a landmark at ``at`` (give or take ``cov``) seen at ``seen`` puts this rover, less where it thinks
        it is, and that sighting's covariance (the landmark's, the sensor's and the heading's)."""
        y0, y1, r00, r01, r10, r11 = self._pair(seen, at, cov)
        return [y0, y1], [[r00, r01], [r10, r11]]

    def __call__(self, seen: tuple[float, float], at: tuple[float, float], cov: Matrix) -> float:
        """The Mahalanobis distance (squared) of that sighting from the estimate; infinite where the two
        uncertainties together leave it unmeasured (their sum is singular)."""
        return self.table([seen], [(at, cov)])[0][0]

    def table(self, seen: list[tuple[float, float]],
              landmarks: list[tuple[tuple[float, float], Matrix]]) -> list[list[float]]:
        """The distance of each landmark (where it is, give or take what) from each place ``seen``, a row a place:
        ``_pair`` and the distance written out in one loop, as a crowd's thousands of pairs a second need."""
        p00, p01, p10, p11 = self._pxx
        x, z, inf = self._x, self._z, math.inf
        rows = []
        for place in seen:
            ox, oz, mxx, mxz, mzz = self._terms.get(place) or self._seen(place)
            row = []
            for (ax, az), ((c00, c01), (c10, c11)) in landmarks:
                y0, y1 = ax - ox - x, az - oz - z
                s00, s01, s10, s11 = p00 + (c00 + mxx), p01 + (c01 + mxz), p10 + (c10 + mxz), p11 + (c11 + mzz)
                det = s00 * s11 - s01 * s10
                if not det > 1e-18:
                    row.append(inf)
                    continue
                i00, i01, i10, i11 = s11 / det, -s01 / det, -s10 / det, s00 / det
                row.append(y0 * (i00 * y0 + i01 * y1) + y1 * (i10 * y0 + i11 * y1))
            rows.append(row)
        return rows

    def _pair(self, seen: tuple[float, float], at: tuple[float, float],
              cov: Matrix) -> tuple[float, float, float, float, float, float]:
        ox, oz, mxx, mxz, mzz = self._terms.get(seen) or self._seen(seen)
        return (at[0] - ox - self._x, at[1] - oz - self._z,
                cov[0][0] + mxx, cov[0][1] + mxz, cov[1][0] + mxz, cov[1][1] + mzz)

    def _seen(self, seen: tuple[float, float]) -> Terms:
        sx, sz = seen
        ox, oz = sz * self._sin + sx * self._cos, sz * self._cos - sx * self._sin
        sensor, turn = self._sensor, self._turn
        terms = self._terms[seen] = (ox, oz, sensor + turn * oz * oz, -turn * oz * ox, sensor + turn * ox * ox)
        return terms
