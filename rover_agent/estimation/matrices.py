"""The few matrix operations the rover's pose filter needs, on plain lists of floats: its matrices are 3 x 3 and
2 x 2, and a flight computer needs no numeric stack for them (``pose_filter``). Each keeps the order of its
floating-point operations, on which a lockstep run's bit-for-bit repeat rests."""

from __future__ import annotations

import math

Matrix = list[list[float]]


def zeros(n: int, m: int | None = None) -> Matrix:
    return [[0.0] * (n if m is None else m) for _ in range(n)]


def mul(a: Matrix, b: Matrix) -> Matrix:
    return [[sum(a[i][k] * b[k][j] for k in range(len(b))) for j in range(len(b[0]))] for i in range(len(a))]


def transpose(a: Matrix) -> Matrix:
    return [list(row) for row in zip(*a, strict=True)]


def add(a: Matrix, b: Matrix, scale: float = 1.0) -> Matrix:
    return [[x + scale * y for x, y in zip(ra, rb, strict=True)] for ra, rb in zip(a, b, strict=True)]


def scaled(a: Matrix, s: float) -> Matrix:
    return [[s * x for x in row] for row in a]


def inverse2(a: Matrix) -> Matrix | None:
    det = a[0][0] * a[1][1] - a[0][1] * a[1][0]
    if not det > 1e-18:
        return None
    return [[a[1][1] / det, -a[0][1] / det], [-a[1][0] / det, a[0][0] / det]]


def symmetric(a: Matrix) -> Matrix:
    n = len(a)
    return [[(a[i][j] + a[j][i]) / 2 for j in range(n)] for i in range(n)]


def sandwich(a: Matrix, b: Matrix) -> Matrix:
    """A B A^T: a covariance ``b`` carried through the linear map ``a``."""
    return mul(mul(a, b), transpose(a))


def positive_definite(a: Matrix) -> bool:
    """Whether a symmetric 2 x 2 matrix is finite and positive definite: what a sighting's noise must be, or an
    update with it can make variances negative (a teammate's covariance that is none, say)."""
    return all(math.isfinite(v) for row in a for v in row) and a[0][0] > 0.0 and a[0][0] * a[1][1] > a[0][1] * a[0][1]


def quadratic(y: list[float], m: Matrix) -> float:
    return y[0] * (m[0][0] * y[0] + m[0][1] * y[1]) + y[1] * (m[1][0] * y[0] + m[1][1] * y[1])
