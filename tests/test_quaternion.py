"""Unit quaternions on float tuples (components.rigid.quaternion)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from components.rigid import quaternion as quat

finite = st.floats(-10.0, 10.0, allow_nan=False)
vectors = st.tuples(finite, finite, finite)
axes = vectors.filter(lambda v: math.hypot(*v) > 1e-3)
angles = st.floats(-2 * math.pi, 2 * math.pi, allow_nan=False)


def matrix(q):
    """Rotation matrix of a unit quaternion, from the textbook formula (an independent reference)."""
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def test_quarter_turn_about_z_maps_x_to_y():
    """A +90 degree turn about z takes the x axis to the y axis (right-hand rule, body -> world)."""
    q = quat.from_axis_angle((0.0, 0.0, 2.0), math.pi / 2)
    assert np.allclose(quat.rotate(q, (1.0, 0.0, 0.0)), (0.0, 1.0, 0.0), atol=1e-15)


@given(axes, angles, vectors)
def test_rotate_matches_the_rotation_matrix(axis, angle, v):
    """rotate(q, v) equals R(q) v."""
    q = quat.from_axis_angle(axis, angle)
    assert np.allclose(quat.rotate(q, v), matrix(q) @ np.array(v), atol=1e-12)


@given(axes, angles, vectors)
def test_rotate_inv_undoes_rotate(axis, angle, v):
    """rotate_inv(q, rotate(q, v)) returns v."""
    q = quat.from_axis_angle(axis, angle)
    assert np.allclose(quat.rotate_inv(q, quat.rotate(q, v)), v, atol=1e-12)


@given(axes, angles, axes, angles, vectors)
def test_mul_composes_right_factor_first(a1, t1, a2, t2, v):
    """mul(a, b) rotates by b, then by a."""
    a, b = quat.from_axis_angle(a1, t1), quat.from_axis_angle(a2, t2)
    assert np.allclose(quat.rotate(quat.mul(a, b), v), quat.rotate(a, quat.rotate(b, v)), atol=1e-11)


@given(axes, angles)
def test_body_axis_is_the_rotated_z_axis(axis, angle):
    """body_axis(q) is R(q) e_z."""
    q = quat.from_axis_angle(axis, angle)
    assert np.allclose(quat.body_axis(q), quat.rotate(q, (0.0, 0.0, 1.0)), atol=1e-14)


@pytest.mark.parametrize("size", [0.0, 1e-12, 1e-5, 9.99e-5, 1.01e-4, 0.3, 3.0])
def test_rotation_vector_exponential_matches_axis_angle_across_the_series_switch(size):
    """exp(rv) equals the axis-angle quaternion of angle |rv|, on both sides of the small-angle series."""
    direction = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    q = quat.from_rotation_vector(tuple(size * direction))
    ref = quat.from_axis_angle(tuple(direction), size)
    assert np.allclose(q, ref, rtol=0, atol=2e-16)
    assert math.isclose(sum(c * c for c in q), 1.0, rel_tol=1e-15)


def test_normalize_rejects_the_zero_quaternion():
    """Normalising the zero quaternion is an error, not a NaN."""
    with pytest.raises(ValueError, match="zero quaternion"):
        quat.normalize((0.0, 0.0, 0.0, 0.0))


def test_axis_angle_rejects_a_zero_axis():
    """A rotation about the zero vector is an error."""
    with pytest.raises(ValueError, match="axis must be non-zero"):
        quat.from_axis_angle((0.0, 0.0, 0.0), 1.0)


def test_angle_between_measures_the_relative_rotation():
    """The angle from q to q turned by 0.3 rad is 0.3 rad, whatever the sign of the quaternions."""
    a = quat.from_axis_angle((1.0, 2.0, 3.0), 0.7)
    b = quat.mul(quat.from_axis_angle((0.0, 1.0, 0.0), 0.3), a)
    assert math.isclose(quat.angle_between(a, b), 0.3, rel_tol=1e-12)
    assert math.isclose(quat.angle_between(a, tuple(-c for c in b)), 0.3, rel_tol=1e-12)


@pytest.mark.parametrize("scale", [1e200, 1e-300, 1e-160, 1e154])
def test_an_axis_of_any_finite_length_gives_the_unit_axis_rotation(scale):
    """An axis of 1e200 squared to inf: the quaternion came out of length cos(15 deg), the tilt lost
    (a scene with tilt_axis [1e200, 0, 0] ran as if untilted); one of 1e-300 squared to 0 and was
    refused as zero."""
    unit = quat.from_axis_angle((0.6, -0.8, 0.0), math.radians(30.0))
    scaled = quat.from_axis_angle((0.6 * scale, -0.8 * scale, 0.0), math.radians(30.0))
    assert scaled == pytest.approx(unit, abs=1e-15)
    assert math.fsum(c * c for c in scaled) == pytest.approx(1.0, abs=1e-15)
    with pytest.raises(ValueError, match=r"non-zero and finite \(got \[inf, 0, 0\]\)"):
        quat.from_axis_angle((math.inf, 0.0, 0.0), 1.0)
    with pytest.raises(ValueError, match=r"non-zero and finite \(got \[1, nan, 0\]\)"):  # not only first
        quat.from_axis_angle((1.0, math.nan, 0.0), 1.0)
