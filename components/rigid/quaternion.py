"""Unit quaternions (w, x, y, z) on plain float tuples.

Convention (as in :mod:`components.messages`): a quaternion q rotates body-frame vectors into the world
frame, v_world = q v_body q*. Composition: ``mul(a, b)`` applies b first, then a.
"""

from __future__ import annotations

import math

from components.rigid.vec import Vec

Quat = tuple[float, float, float, float]
"""A quaternion (w, x, y, z)."""

IDENTITY: Quat = (1.0, 0.0, 0.0, 0.0)

# Below this rotation angle [rad] the exponential map uses its Taylor series: sin(a/2)/a loses no
# accuracy there and the division by a tiny angle is avoided.
SMALL_ANGLE = 1e-4


def mul(a: Quat, b: Quat) -> Quat:
    """Hamilton product a b."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


def conj(q: Quat) -> Quat:
    """The conjugate (the inverse of a unit quaternion)."""
    return (q[0], -q[1], -q[2], -q[3])


def normalize(q: Quat) -> Quat:
    """q / |q|; raises ValueError for the zero quaternion."""
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if n == 0.0:
        raise ValueError("cannot normalise the zero quaternion")
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def from_axis_angle(axis: Vec, angle: float) -> Quat:
    """Rotation by ``angle`` [rad] about ``axis`` (any non-zero, finite length; right-hand rule).

    An axis whose squares overflow or underflow is first scaled by its largest component: one of
    1e200 squared to inf and gave a quaternion of length cos(angle / 2), the tilt lost; one of
    1e-320 squared to 0 and was refused as zero."""
    x, y, z, n = _measured(axis)
    s = math.sin(0.5 * angle) / n
    return (math.cos(0.5 * angle), x * s, y * s, z * s)


def unit_axis(axis: Vec) -> Vec:
    """``axis`` (any non-zero, finite length) scaled to length 1, its squares kept in range as
    :func:`from_axis_angle` keeps them."""
    x, y, z, n = _measured(axis)
    return (x / n, y / n, z / n)


def _measured(axis: Vec) -> tuple[float, float, float, float]:
    """``axis`` as (x, y, z, its length), first scaled by its largest component when its squares
    would overflow or underflow; a ValueError for a zero, infinite or NaN axis."""
    x, y, z = axis[0], axis[1], axis[2]
    n = math.sqrt(x * x + y * y + z * z)
    if not TINY_AXIS < n < math.inf:  # (a NaN anywhere makes n NaN: here, refused below)
        m = max(abs(x), abs(y), abs(z))
        if not 0.0 < m < math.inf or not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
            raise ValueError(f"rotation axis must be non-zero and finite (got [{x:g}, {y:g}, {z:g}])")
        x, y, z = x / m, y / m, z / m
        n = math.sqrt(x * x + y * y + z * z)
    return x, y, z, n


TINY_AXIS = 1e-150  # [-] an axis shorter than this is scaled up first: its squares lose digits below 1e-300


def from_rotation_vector(rv: Vec) -> Quat:
    """exp of a rotation vector: rotation by |rv| [rad] about rv/|rv| (identity for zero)."""
    a2 = rv[0] * rv[0] + rv[1] * rv[1] + rv[2] * rv[2]
    a = math.sqrt(a2)
    if a < SMALL_ANGLE:
        s = 0.5 - a2 / 48.0  # sin(a/2)/a to O(a^4), below round-off at this size
        c = 1.0 - a2 / 8.0 + a2 * a2 / 384.0
    elif a == math.inf:  # a turn past 1.3e154 rad (an infinite torque): no attitude, said as the state's
        return (math.nan, math.nan, math.nan, math.nan)  # (math.sin(inf) raised a bare "math domain error")
    else:
        s = math.sin(0.5 * a) / a
        c = math.cos(0.5 * a)
    return (c, rv[0] * s, rv[1] * s, rv[2] * s)


def rotate(q: Quat, v: Vec) -> Vec:
    """q v q*: a body-frame vector in the world frame (q need not be normalised to 1e-16)."""
    w, x, y, z = q
    # t = 2 q_v x v;  v' = v + w t + q_v x t
    tx = 2.0 * (y * v[2] - z * v[1])
    ty = 2.0 * (z * v[0] - x * v[2])
    tz = 2.0 * (x * v[1] - y * v[0])
    return (v[0] + w * tx + (y * tz - z * ty),
            v[1] + w * ty + (z * tx - x * tz),
            v[2] + w * tz + (x * ty - y * tx))


def rotate_inv(q: Quat, v: Vec) -> Vec:
    """q* v q: a world-frame vector in the body frame."""
    return rotate((q[0], -q[1], -q[2], -q[3]), v)


def body_axis(q: Quat) -> Vec:
    """The body z axis (a disk's symmetry axis) in the world frame."""
    w, x, y, z = q
    return (2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y))


def angle_between(a: Quat, b: Quat) -> float:
    """Rotation angle [rad] taking orientation a to orientation b (0..pi), accurate near 0."""
    d = mul(conj(a), b)
    return 2.0 * math.atan2(math.sqrt(d[1] * d[1] + d[2] * d[2] + d[3] * d[3]), abs(d[0]))
