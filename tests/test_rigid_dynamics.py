"""Rigid-body dynamics: world inertia, Euler's equations, exact torque-free rotation, impulses, energy
(components.rigid.dynamics)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from components.messages import Shape
from components.rigid import dynamics as dyn
from components.rigid import quaternion as quat
from components.rigid.shapes import mass_properties

DISK = mass_properties(Shape.DISK, 0.05, 0.006, density=2700.0)
SPHERE = mass_properties(Shape.SPHERE, 0.03, density=2700.0)

finite = st.floats(-20.0, 20.0, allow_nan=False)
vectors = st.tuples(finite, finite, finite)
orientations = st.tuples(vectors.filter(lambda v: math.hypot(*v) > 1e-3),
                         st.floats(-3.2, 3.2)).map(lambda a: quat.from_axis_angle(*a))


def world_inertia(inertia, q):
    r = np.array([quat.rotate(q, e) for e in np.eye(3)]).T
    return r @ np.diag(inertia) @ r.T


@given(orientations, vectors)
def test_closed_form_world_inertia_matches_r_i_rt(q, h):
    """I_world h and I_world^-1 h of the axisymmetric closed form equal R diag(I) R^T h and its inverse."""
    axis = quat.body_axis(q)
    full = world_inertia(DISK.inertia, q)
    assert np.allclose(dyn.inertia_apply(DISK.inertia, axis, h), full @ h, rtol=1e-12, atol=1e-18)
    solved = dyn.inertia_solve(DISK.inertia, axis, h)
    assert np.allclose(solved, np.linalg.solve(full, h), rtol=1e-10, atol=1e-9)


def test_euler_rhs_has_no_gyroscopic_term_for_a_pure_spin():
    """A spin about the symmetry axis alone needs no torque: d omega/dt = 0."""
    assert dyn.euler_rhs(DISK.inertia, (0.0, 0.0, 400.0), (0.0, 0.0, 0.0)) == (0.0, 0.0, 0.0)


@given(vectors, vectors)
def test_euler_rhs_is_euler_equations(w, torque):
    """d omega/dt = I^-1 (torque - omega x I omega), body frame."""
    i = np.array(DISK.inertia)
    expected = (np.array(torque) - np.cross(w, i * np.array(w))) / i
    assert np.allclose(dyn.euler_rhs(DISK.inertia, w, torque), expected, rtol=1e-12, atol=1e-9)


def reference_rotation(inertia, q0, w0_world, t_end):
    """Euler's equations plus quaternion kinematics integrated by DOP853 at tight tolerance."""
    wb0 = quat.rotate_inv(q0, w0_world)

    def rhs(_, y):
        q, wb = tuple(y[:4]), tuple(y[4:])
        dq = quat.mul(q, (0.0, 0.5 * wb[0], 0.5 * wb[1], 0.5 * wb[2]))
        return [*dq, *dyn.euler_rhs(inertia, wb, (0.0, 0.0, 0.0))]

    sol = solve_ivp(rhs, (0.0, t_end), [*q0, *wb0], method="DOP853", rtol=1e-13, atol=1e-13)
    return quat.normalize(tuple(sol.y[:4, -1]))


@pytest.mark.parametrize("body", [DISK, SPHERE], ids=["disk", "sphere"])
def test_free_rotation_matches_eulers_equations_in_one_long_step(body):
    """The closed-form torque-free motion agrees with an accurate integration of Euler's equations,
    even over 0.37 s (tens of turns) in a single step."""
    q0 = quat.from_axis_angle((1.0, 0.2, 0.0), 0.4)
    w0 = (3.0, -2.0, 60.0)
    momentum = dyn.angular_momentum(body.inertia, q0, w0)
    q1 = dyn.free_rotation(body.inertia, q0, momentum, 0.37)
    assert quat.angle_between(q1, reference_rotation(body.inertia, q0, w0, 0.37)) < 1e-9


def test_free_rotation_precesses_the_disk_axis_at_l_over_i_diameter():
    """A torque-free symmetric disk's axis precesses about L at |L| / I_d (within 1e-9 relative), and
    in the body frame omega turns at (I_a - I_d) omega_3 / I_d."""
    q = quat.from_axis_angle((1.0, 0.0, 0.0), 0.3)
    w = quat.rotate(q, (2.0, 0.0, 40.0))
    momentum = dyn.angular_momentum(DISK.inertia, q, w)
    l_hat = np.array(momentum) / np.linalg.norm(momentum)
    dt, steps = 5e-4, 2000
    azimuths, body_phase = [], []
    ref = np.cross(l_hat, [0.0, 1.0, 0.0])
    ref /= np.linalg.norm(ref)
    for _ in range(steps):
        q = dyn.free_rotation(DISK.inertia, q, momentum, dt)
        n = np.array(quat.body_axis(q))
        perp = n - (n @ l_hat) * l_hat
        azimuths.append(math.atan2(np.cross(ref, perp) @ l_hat, ref @ perp))
        wb = quat.rotate_inv(q, dyn.omega_from_momentum(DISK.inertia, q, momentum))
        body_phase.append(math.atan2(wb[1], wb[0]))
    t = dt * np.arange(1, steps + 1)
    rate = np.polyfit(t, np.unwrap(azimuths), 1)[0]
    assert rate == pytest.approx(np.linalg.norm(momentum) / DISK.inertia[0], rel=1e-9)
    body_rate = np.polyfit(t, np.unwrap(body_phase), 1)[0]
    i_d, _, i_a = DISK.inertia
    assert body_rate == pytest.approx(-(i_d - i_a) * 40.0 / i_d, rel=1e-9)


def test_apply_impulse_changes_momenta_by_the_impulse():
    """v += J/M, omega += I_world^-1 H, x += correction; held attitude ignores H."""
    q = quat.from_axis_angle((0.0, 1.0, 0.0), 0.5)
    s = dyn.RigidState((0.0, 0.0, 1.0), q, (1.0, 0.0, 0.0), (0.0, 0.0, 3.0))
    after = dyn.apply_impulse(DISK.mass, DISK.inertia, s, (0.0, 0.0, 0.2), (0.001, 0.0, 0.0),
                              (0.0, 0.0, 1e-3))
    assert after.velocity == pytest.approx((1.0, 0.0, 0.2 / DISK.mass))
    assert after.position == (0.0, 0.0, 1.001)
    expected_l = np.add(dyn.angular_momentum(DISK.inertia, q, s.angular_velocity), (0.001, 0.0, 0.0))
    after_l = dyn.angular_momentum(DISK.inertia, q, after.angular_velocity)
    assert after_l == pytest.approx(expected_l, rel=1e-12)
    held = dyn.apply_impulse(DISK.mass, DISK.inertia, s, (0.0, 0.0, 0.0), (0.001, 0.0, 0.0), (0.0, 0.0, 0.0),
                             rotate=False)
    assert held.angular_velocity == s.angular_velocity


def test_kinetic_and_potential_energy():
    """KE = M v^2/2 + omega.I omega/2, PE = -M g.x (zero at z = 0)."""
    q = quat.from_axis_angle((1.0, 1.0, 0.0), 0.7)
    s = dyn.RigidState((0.0, 0.0, 2.0), q, (3.0, 0.0, 4.0), (1.0, 2.0, 3.0))
    w = np.array(s.angular_velocity)
    expected = 0.5 * DISK.mass * 25.0 + 0.5 * w @ world_inertia(DISK.inertia, q) @ w
    assert dyn.kinetic_energy(DISK.mass, DISK.inertia, s) == pytest.approx(expected, rel=1e-14)
    potential = dyn.potential_energy(DISK.mass, (0.0, 0.0, -9.81), s.position)
    assert potential == pytest.approx(DISK.mass * 9.81 * 2.0)


def test_point_velocity_is_v_plus_omega_cross_r():
    """The velocity of a body point is v + omega x r."""
    s = dyn.RigidState((0.0, 0.0, 0.0), quat.IDENTITY, (1.0, 0.0, 0.0), (0.0, 0.0, 2.0))
    assert dyn.point_velocity(s, (0.5, 0.0, 0.0)) == (1.0, 1.0, 0.0)
