"""3-vector helpers on plain tuples of floats.

The body and ground step thousands of times per simulated second on 3-vectors; a numpy call costs
about a microsecond of overhead each, plain float arithmetic a few tens of nanoseconds, so the
per-step physics works on tuples and converts to numpy only at the message boundary.
"""

from __future__ import annotations

import math

Vec = tuple[float, float, float]
"""A 3-vector (x, y, z)."""

ZERO: Vec = (0.0, 0.0, 0.0)
EZ: Vec = (0.0, 0.0, 1.0)


def add(a: Vec, b: Vec) -> Vec:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def scale(a: Vec, s: float) -> Vec:
    return (a[0] * s, a[1] * s, a[2] * s)


def axpy(s: float, a: Vec, b: Vec) -> Vec:
    """s * a + b."""
    return (s * a[0] + b[0], s * a[1] + b[1], s * a[2] + b[2])


def dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def norm(a: Vec) -> float:
    return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])


def unit(a: Vec) -> Vec:
    """a / |a|; raises ValueError for the zero vector."""
    n = norm(a)
    if n == 0.0:
        raise ValueError("cannot normalise the zero vector")
    return (a[0] / n, a[1] / n, a[2] / n)


def as_vec(values: object) -> Vec:
    """Three floats from any sequence (a list, tuple or numpy array)."""
    x, y, z = values  # type: ignore[misc]
    return (float(x), float(y), float(z))


Mat3 = tuple[float, float, float, float, float, float, float, float, float]
"""A 3x3 matrix, row-major."""


def mat_vec(m: Mat3, v: Vec) -> Vec:
    return (m[0] * v[0] + m[1] * v[1] + m[2] * v[2],
            m[3] * v[0] + m[4] * v[1] + m[5] * v[2],
            m[6] * v[0] + m[7] * v[1] + m[8] * v[2])


def solve3(m: Mat3, b: Vec) -> Vec:
    """Solve m x = b by Cramer's rule (m small and well conditioned: contact matrices)."""
    a, b_, c, d, e, f, g, h, i = m
    co0 = e * i - f * h
    co1 = f * g - d * i
    co2 = d * h - e * g
    det = a * co0 + b_ * co1 + c * co2
    if det == 0.0:
        raise ZeroDivisionError("singular 3x3 system")
    inv = (co0, c * h - b_ * i, b_ * f - c * e,
           co1, a * i - c * g, c * d - a * f,
           co2, b_ * g - a * h, a * e - b_ * d)
    x = mat_vec(inv, b)
    return (x[0] / det, x[1] / det, x[2] / det)
