"""Contact impulses: the corner impulse formula, Coulomb friction, Painlevé's bound and face contact
(components.contact.impulse)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from components.contact.geometry import Plane, contact_geometry
from components.contact.impulse import (
    TORSION_ARM,
    contact_matrix,
    corner_impulse,
    face_impulse,
    point_impulse,
)
from components.messages import Shape
from components.rigid import quaternion as quat
from components.rigid.dynamics import inertia_solve
from components.rigid.shapes import mass_properties

FLOOR = Plane((0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
N = (0.0, 0.0, 1.0)
DISK = mass_properties(Shape.DISK, 0.05, 0.006, density=2700.0)
THIN = mass_properties(Shape.DISK, 0.05, 1e-9, density=2.7e9)  # thickness -> 0, mass ~ 0.02 kg
PAINLEVE_DISK = math.sqrt(5.0) / 2.0


def rim_contact(body, q):
    """Offset of the lowest point and the body axis of a disk at orientation q on the floor."""
    g = contact_geometry(body.shape, body.radius, body.thickness, (0.0, 0.0, 0.0), q, FLOOR, 0.0)
    return g.r_low, quat.body_axis(q)


@pytest.mark.parametrize("tilt_deg", [10.0, 30.0, 45.0, 70.0])
def test_thin_disk_rim_effective_mass_matches_physics_md(tilt_deg):
    """Thin disk on its rim tilted by theta about a diameter: K_nn = (1 + 4 cos^2 theta) / M."""
    th = math.radians(tilt_deg)
    r, axis = rim_contact(THIN, quat.from_axis_angle((1.0, 0.0, 0.0), th))
    k = contact_matrix(THIN.mass, THIN.inertia, axis, r)
    assert k[8] == pytest.approx((1 + 4 * math.cos(th) ** 2) / THIN.mass, rel=1e-7)


def test_contact_matrix_of_a_held_attitude_is_the_inverse_mass():
    """With the attitude held, K = I / M whatever the lever."""
    r, axis = rim_contact(DISK, quat.from_axis_angle((1.0, 0.0, 0.0), 0.5))
    k = contact_matrix(DISK.mass, DISK.inertia, axis, r, rotate=False)
    assert np.allclose(np.reshape(k, (3, 3)), np.eye(3) / DISK.mass, rtol=0, atol=0)


def test_corner_impulse_reverses_the_normal_velocity_by_e():
    """After P n at r the contact point's normal velocity is -e times its value before."""
    q = quat.from_axis_angle((1.0, 0.2, 0.0), 0.6)
    r, axis = rim_contact(DISK, q)
    v, w = (0.4, 0.1, -2.0), (1.0, -3.0, 20.0)
    p = corner_impulse(DISK.mass, DISK.inertia, axis, r, N, v, w, 0.7)
    dw = inertia_solve(DISK.inertia, axis, tuple(np.cross(r, N) * p))
    u_before = np.add(v, np.cross(w, r))
    u_after = np.add(v, np.multiply(N, p / DISK.mass)) + np.cross(np.add(w, dw), r)
    assert u_after[2] == pytest.approx(-0.7 * u_before[2], rel=1e-12)
    assert corner_impulse(DISK.mass, DISK.inertia, axis, r, N, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0), 0.7) == 0.0


def test_frictionless_point_impulse_is_the_corner_impulse():
    """With mu = 0 the Coulomb solver returns exactly the corner impulse P n."""
    q = quat.from_axis_angle((1.0, 0.2, 0.0), 0.6)
    r, axis = rim_contact(DISK, q)
    v, w = (0.4, 0.1, -2.0), (1.0, -3.0, 20.0)
    p = corner_impulse(DISK.mass, DISK.inertia, axis, r, N, v, w, 0.5)
    u = tuple(np.add(v, np.cross(w, r)))
    res = point_impulse(contact_matrix(DISK.mass, DISK.inertia, axis, r), r, u, N, -0.5 * u[2], 0.0, 0.0)
    assert res.linear == pytest.approx((0.0, 0.0, p), rel=1e-12, abs=1e-15 * p)
    assert res.angular == pytest.approx(tuple(np.cross(r, (0.0, 0.0, p))), rel=1e-12, abs=1e-15 * p)


def test_sticking_impulse_stops_the_contact_point():
    """Inside the friction cone the impulse brings the contact-point velocity exactly to the target."""
    q = quat.from_axis_angle((1.0, 0.0, 0.0), 0.4)
    r, axis = rim_contact(DISK, q)
    k = contact_matrix(DISK.mass, DISK.inertia, axis, r)
    u = (0.01, 0.0, -1.0)
    res = point_impulse(k, r, u, N, 0.0, 1.2, 1.0)
    assert not res.sliding
    du = np.reshape(k, (3, 3)) @ res.linear
    assert np.add(u, du) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    assert res.friction <= 1.2 * res.normal
    # the tilted rim couples normal and in-plane tangential motion: stopping it needs |J_t| = 0.9 J_n
    assert point_impulse(k, r, u, N, 0.0, 0.8, 0.6).sliding


def test_sliding_impulse_lies_on_the_cone_against_the_slip():
    """Outside the cone the friction impulse is mu_k J_n, opposite to the slip velocity."""
    q = quat.from_axis_angle((1.0, 0.0, 0.0), 0.4)
    r, axis = rim_contact(DISK, q)
    k = contact_matrix(DISK.mass, DISK.inertia, axis, r)
    u = (3.0, 0.0, -1.0)
    res = point_impulse(k, r, u, N, 0.5, 0.3, 0.25)
    assert res.sliding and not res.painleve
    jt = np.array([res.linear[0], res.linear[1], 0.0])
    assert np.linalg.norm(jt) == pytest.approx(0.25 * res.normal, rel=1e-12)
    assert jt @ np.array([3.0, 0.0, 0.0]) < 0
    u_after = np.add(u, np.reshape(k, (3, 3)) @ res.linear)
    assert u_after[2] == pytest.approx(0.5, rel=1e-12)


unit_vectors = st.tuples(*[st.floats(-1, 1)] * 3).filter(lambda v: 0.1 < math.hypot(*v))


@settings(max_examples=300, deadline=None)
@given(axis=unit_vectors, angle=st.floats(0.01, math.pi - 0.01), slip=st.floats(0, 2 * math.pi),
       speed=st.floats(0.0, 10.0), approach=st.floats(0.01, 10.0), spin=unit_vectors,
       mu=st.floats(0.0, 0.999 * PAINLEVE_DISK), body=st.sampled_from([THIN, DISK]))
def test_below_painleves_bound_the_normal_impulse_is_finite_and_non_negative(
        axis, angle, slip, speed, approach, spin, mu, body):
    """For mu below sqrt(5)/2 a disk's rim impact has a consistent solution: finite, non-negative
    normal impulse, friction kept (no Painlevé fallback)."""
    q = quat.from_axis_angle(axis, angle)
    r, a = rim_contact(body, q)
    k = contact_matrix(body.mass, body.inertia, a, r)
    u = (speed * math.cos(slip), speed * math.sin(slip), -approach)
    res = point_impulse(k, r, u, N, 0.0, mu, mu)
    assert math.isfinite(res.normal) and res.normal >= 0.0
    assert all(math.isfinite(c) for c in res.linear + res.angular)
    assert not res.painleve


def test_above_painleves_bound_friction_is_dropped_not_the_normal_force():
    """A thin disk at 45 degrees slipping with mu = 2 has no consistent sliding impulse
    (1 + 4 cos^2 - 4 mu sin cos < 0) in the slip direction that pulls the rim down: when sticking is
    refused there, the solver keeps a finite, positive normal impulse, drops the friction and says so;
    the other slip direction is well posed."""
    r, axis = rim_contact(THIN, quat.from_axis_angle((1.0, 0.0, 0.0), math.pi / 4))
    k = contact_matrix(THIN.mass, THIN.inertia, axis, r)
    ill = point_impulse(k, r, (0.0, -10.0, -0.1), N, 0.0, 1.0, 2.0)
    assert ill.painleve and not ill.sliding
    assert math.isfinite(ill.normal) and ill.normal > 0.0
    assert ill.friction == 0.0 and ill.linear[1] == 0.0
    well = point_impulse(k, r, (0.0, 10.0, -0.1), N, 0.0, 1.0, 2.0)
    assert well.sliding and not well.painleve and well.normal > 0.0
    # with equal coefficients the sticking solution exists exactly where sliding is ill posed
    assert not point_impulse(k, r, (0.0, -10.0, -0.1), N, 0.0, 2.0, 2.0).painleve


def test_face_impulse_of_a_flat_landing_cancels_tilt_rates_and_normal_velocity():
    """A flat disk landing with tilt rates and no slip: normal impulse M du_n, tilt rates set to zero,
    no friction, spin kept when torsional friction is not needed."""
    r = (0.0, 0.0, -0.5 * DISK.thickness)
    v, w = (0.0, 0.0, -1.0), (0.3, -0.2, 0.0)
    res = face_impulse(DISK.mass, DISK.inertia, N, DISK.radius, r, v, w, N, 0.0, 0.0, 0.5, 0.4)
    assert res is not None and not res.sliding
    assert res.linear == pytest.approx((0.0, 0.0, DISK.mass * 1.0), rel=1e-14, abs=1e-15)
    w_after = np.add(w, inertia_solve(DISK.inertia, N, res.angular))
    assert w_after == pytest.approx((0.0, 0.0, 0.0), abs=1e-14)


def test_face_impulse_slows_a_spin_by_torsional_friction():
    """A spinning flat disk under normal impulse J_n loses spin 2/3 mu_k R J_n / I_a per impulse."""
    r = (0.0, 0.0, -0.5 * DISK.thickness)
    res = face_impulse(DISK.mass, DISK.inertia, N, DISK.radius, r, (0.0, 0.0, -0.01), (0.0, 0.0, 50.0), N,
                       0.0, 0.0, 0.5, 0.4)
    assert res is not None and res.sliding
    jn = DISK.mass * 0.01
    assert res.angular[2] == pytest.approx(-TORSION_ARM * 0.4 * DISK.radius * jn, rel=1e-12)


def test_face_impulse_gives_way_when_the_face_cannot_hold():
    """No compression (moving away) or a couple beyond the face's reach hands over to the rim."""
    r = (0.0, 0.0, -0.5 * DISK.thickness)
    assert face_impulse(DISK.mass, DISK.inertia, N, DISK.radius, r, (0.0, 0.0, 0.5), (0.0, 0.0, 0.0), N,
                        0.0, 0.0, 0.5, 0.4) is None
    assert face_impulse(DISK.mass, DISK.inertia, N, DISK.radius, r, (0.0, 0.0, -1e-3), (50.0, 0.0, 0.0), N,
                        0.0, 0.0, 0.5, 0.4) is None
