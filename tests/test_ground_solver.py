"""One contact resolution from an end-of-step state (components.contact.solver)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from components.contact.geometry import Plane, slope_plane
from components.contact.solver import Material, mechanical_energy, resolve_contact, time_since_contact
from components.messages import Shape
from components.rigid import quaternion as quat
from components.rigid.dynamics import RigidState, apply_impulse
from components.rigid.shapes import mass_properties

G = (0.0, 0.0, -9.81)
DT = 5e-4
FLOOR = Plane((0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
DISK = mass_properties(Shape.DISK, 0.05, 0.006, density=2700.0)
H = 0.5 * DISK.thickness  # height of a flat disk's centre when touching [m]


def flat(z, v, w=(0.0, 0.0, 0.0)):
    return RigidState((0.0, 0.0, z), quat.IDENTITY, v, w)


def test_time_since_contact_recovers_the_crossing():
    """A point that crossed 0.2 ms ago at -1 m/s under gravity is found to have crossed 0.2 ms ago."""
    tau, vc, a = 2e-4, -1.0, -9.81
    gap, un = vc * tau + 0.5 * a * tau * tau, vc + a * tau
    assert time_since_contact(gap, un, a, DT) == pytest.approx(tau, rel=1e-10)
    assert time_since_contact(gap, un, 0.0, DT) == pytest.approx(gap / un, rel=1e-15)


def test_time_since_contact_is_the_whole_step_for_a_resting_point_and_zero_when_touching():
    """Resting (already in contact at the step's start): dt; exactly touching: 0."""
    assert time_since_contact(-0.5 * 9.81 * DT * DT, -9.81 * DT, -9.81, DT) == pytest.approx(DT, rel=1e-6)
    assert time_since_contact(-1e-3, 0.0, 0.0, DT) == DT
    assert time_since_contact(0.0, -1.0, -9.81, DT) == 0.0


def test_apart_gives_no_contact():
    """A body above the plane gets no response."""
    assert resolve_contact(DISK, flat(H + 1e-6, (0.0, 0.0, -1.0)), FLOOR, Material(), G, DT) is None


def test_resting_contact_balances_weight_with_no_dissipation():
    """A flat disk that rested at the step's start: impulse M g dt (normal force M g), correction
    g dt^2 / 2 back onto the plane, no bounce, and no energy booked."""
    s = flat(H - 0.5 * 9.81 * DT * DT, (0.0, 0.0, -9.81 * DT))
    res = resolve_contact(DISK, s, FLOOR, Material(restitution=0.8), G, DT)
    assert res is not None and res.face and not res.bounced
    assert res.linear == pytest.approx((0.0, 0.0, DISK.mass * 9.81 * DT), rel=1e-12)
    assert res.correction == pytest.approx((0.0, 0.0, 0.5 * 9.81 * DT * DT), rel=1e-12)
    assert abs(res.dissipated) < 1e-15 * mechanical_energy(DISK, s, G) + 1e-18


def test_a_semi_implicit_euler_step_resting_on_the_plane_books_no_energy_either():
    """The same disk after a semi-implicit Euler step from rest, which falls g dt^2 (twice Verlet's):
    put back onto the plane, and nothing booked (it booked -M (g dt)^2 / 2 a step: a disk lying still
    made the ground's dissipation fall 3 mJ/s without end, below zero in a stone resting on a bed)."""
    s = flat(H - 9.81 * DT * DT, (0.0, 0.0, -9.81 * DT))
    res = resolve_contact(DISK, s, FLOOR, Material(restitution=0.8), G, DT)
    assert res is not None and not res.bounced
    assert res.correction == pytest.approx((0.0, 0.0, 9.81 * DT * DT), rel=1e-12)
    assert abs(res.dissipated) < 1e-15 * mechanical_energy(DISK, s, G) + 1e-18


def test_a_rim_point_lifts_a_semi_implicit_euler_steps_overshoot_uncharged():
    """A disk tilted 30 deg resting on its rim, one step from rest: under velocity Verlet it fell
    g dt^2 / 2 and its lift is capped at the energy its impulse took (solver, point 2); under
    semi-implicit Euler it fell g dt^2 with the same speed, the extra g dt^2 / 2 (the ground reads it
    off the body's states as the overshoot, dv dt / 2) being that integrator's own error. Lifted
    beyond the Verlet lift by exactly that, nothing booked under either (the cap alone left the
    Euler overshoot in the plane: a disk rolling on its rim sank g dt^2 / 2 a step and lost that
    step's M (g dt)^2 / 2 for ever)."""
    g, th = 9.81, math.radians(30.0)
    q = quat.from_axis_angle((1.0, 0.0, 0.0), th)
    touching = DISK.radius * math.sin(th) + H * math.cos(th)  # [m] the centre's height, rim on the floor
    v = (0.0, 0.0, -g * DT)
    verlet = resolve_contact(DISK, RigidState((0.0, 0.0, touching - 0.5 * g * DT * DT), q, v, (0.0, 0.0, 0.0)),
                             FLOOR, Material(restitution=0.0), G, DT)
    euler_state = RigidState((0.0, 0.0, touching - g * DT * DT), q, v, (0.0, 0.0, 0.0))
    euler = resolve_contact(DISK, euler_state, FLOOR, Material(restitution=0.0), G, DT, position_share=1.0,
                            overshoot=(0.0, 0.0, -0.5 * g * DT * DT))
    assert verlet is not None and euler is not None and not verlet.face and not euler.face
    assert 0.0 < verlet.correction[2] < 0.5 * g * DT * DT  # capped: the impulse turns the disk, taking a share
    assert euler.linear == verlet.linear
    assert euler.correction[2] - verlet.correction[2] == pytest.approx(0.5 * g * DT * DT, rel=1e-9)
    for res in (verlet, euler):
        assert abs(res.dissipated) < 1e-15 * mechanical_energy(DISK, euler_state, G)


def test_bounce_mid_step_lands_on_the_exact_rebound_trajectory():
    """A flat disk that hit the floor at 2 m/s 0.3 ms before the end of the step is put where the exact
    bounce (outgoing e 2 m/s) would be, with that velocity, and the loss 1/2 M v^2 (1 - e^2) is booked."""
    e, vc, tau, g = 0.6, -2.0, 3e-4, -9.81
    s = flat(H + vc * tau + 0.5 * g * tau * tau, (0.0, 0.0, vc + g * tau))
    res = resolve_contact(DISK, s, FLOOR, Material(restitution=e), G, DT)
    assert res is not None and res.bounced
    after = apply_impulse(DISK.mass, DISK.inertia, s, res.linear, res.angular, res.correction)
    assert after.position[2] == pytest.approx(H - e * vc * tau + 0.5 * g * tau * tau, rel=1e-12)
    assert after.velocity[2] == pytest.approx(-e * vc + g * tau, rel=1e-12)
    assert res.dissipated == pytest.approx(0.5 * DISK.mass * vc * vc * (1 - e * e), rel=1e-9)


def test_slow_arrival_is_plastic():
    """Below the bounce threshold (raised to 4 g dt) the contact is plastic: normal velocity 0 on the
    plane."""
    s = flat(H - 1e-9, (0.0, 0.0, -0.015))
    res = resolve_contact(DISK, s, FLOOR, Material(restitution=0.9, bounce_threshold=0.0), G, DT)
    assert res is not None and not res.bounced
    after = apply_impulse(DISK.mass, DISK.inertia, s, res.linear, res.angular, res.correction)
    assert after.velocity[2] == pytest.approx(0.0, abs=1e-15)
    assert after.position[2] == pytest.approx(H, abs=1e-15)


def test_sticking_on_a_slope_returns_to_the_step_start():
    """A disk at rest on a holding slope, after one free step, is put back exactly where it started
    with zero velocity: no creep."""
    phi = math.radians(20.0)
    plane = slope_plane((0.0, 0.0, 0.0), 20.0)
    q = quat.from_axis_angle((0.0, 1.0, 0.0), phi)
    start = tuple(H * c for c in plane.normal)
    s = RigidState(tuple(np.add(start, np.multiply(G, 0.5 * DT * DT))), q, tuple(np.multiply(G, DT)),
                   (0.0, 0.0, 0.0))
    res = resolve_contact(DISK, s, plane, Material(mu_static=0.5, mu_kinetic=0.4), G, DT)
    assert res is not None and not res.sliding and res.face
    after = apply_impulse(DISK.mass, DISK.inertia, s, res.linear, res.angular, res.correction)
    assert after.position == pytest.approx(start, abs=1e-17)
    assert after.velocity == pytest.approx((0.0, 0.0, 0.0), abs=1e-17)


def test_dissipated_energy_is_the_mechanical_energy_removed():
    """dissipated = (KE + PE before) - (KE + PE after the impulse and the correction)."""
    q = quat.from_axis_angle((1.0, 0.0, 0.0), 0.5)
    s = RigidState((0.0, 0.0, 0.0259), q, (1.0, 0.0, -2.0), (0.0, 5.0, 0.0))
    res = resolve_contact(DISK, s, FLOOR, Material(), G, DT)
    assert res is not None and not res.face
    after = apply_impulse(DISK.mass, DISK.inertia, s, res.linear, res.angular, res.correction)
    expected = mechanical_energy(DISK, s, G) - mechanical_energy(DISK, after, G)
    assert res.dissipated == pytest.approx(expected, rel=1e-12)
    assert res.dissipated > 0


def test_held_attitude_gets_no_angular_impulse():
    """With rotate=False the response is purely translational: J = -(1 + e) M v_n n at a rim corner."""
    q = quat.from_axis_angle((1.0, 0.0, 0.0), 0.5)
    z = 0.05 * math.sin(0.5) + H * math.cos(0.5) - 1e-12
    s = RigidState((0.0, 0.0, z), q, (0.0, 0.0, -2.0), (0.0, 0.0, 300.0))
    res = resolve_contact(DISK, s, FLOOR, Material(restitution=0.5, mu_static=0.0, mu_kinetic=0.0), G, DT,
                          rotate=False)
    assert res is not None and res.angular == (0.0, 0.0, 0.0)
    assert res.linear == pytest.approx((0.0, 0.0, 1.5 * DISK.mass * 2.0), rel=1e-9)


small = st.floats(-5.0, 5.0, allow_nan=False)


@settings(max_examples=200, deadline=None)
@given(axis=st.tuples(small, small, small).filter(lambda v: math.hypot(*v) > 0.1),
       angle=st.floats(0.0, math.pi), depth=st.floats(0.0, 1e-4), v=st.tuples(small, small, small),
       w=st.tuples(small, small, small).map(lambda x: tuple(10 * c for c in x)),
       mu=st.floats(0.0, 0.999 * math.sqrt(5.0) / 2), e=st.floats(0.0, 1.0), sliding=st.booleans())
def test_contact_solve_always_returns_a_finite_non_negative_normal_force(axis, angle, depth, v, w, mu, e,
                                                                         sliding):
    """For any disk state touching the floor and mu below sqrt(5)/2 the resolution is finite, with a
    non-negative normal impulse and no Painlevé fallback."""
    q = quat.from_axis_angle(axis, angle)
    a = quat.body_axis(q)
    sin_tilt = math.sqrt(max(0.0, 1.0 - a[2] * a[2]))
    z = DISK.radius * sin_tilt + H * abs(a[2]) - depth
    s = RigidState((0.0, 0.0, z), q, v, w)
    res = resolve_contact(DISK, s, FLOOR, Material(e, mu, mu), G, DT, was_sliding=sliding)
    if res is None:
        return
    assert math.isfinite(res.normal) and res.normal >= 0.0
    assert all(math.isfinite(c) for c in res.linear + res.angular + res.correction)
    assert math.isfinite(res.dissipated)
    assert not res.painleve


def test_a_bounce_whose_friction_would_add_energy_with_its_lift_is_plastic():
    """Kane's paradox judged on the whole response: the impulse's kinetic energy and the bounce's lift,
    J tau / M, against gravity. A tilted disk's rim met at e = 1 with mu 1 (logged from a drop): the
    kinetic energy alone fell, but the lift's potential energy made the response add 0.47 mJ (the
    frictional share J_t . u_t / 2), which the kinetic-energy test let through."""
    state = RigidState((0.0, -0.039607225435414055, 0.002449268215932908),
                       (-0.020391925686612286, 0.9997920630645113, 0.0, 0.0),
                       (0.0, -0.10522097939609797, -0.1480643704708038), (27.989761327379043, 0.0, 0.0))
    floor = slope_plane((0.0, 0.0, 0.0), 0.0)
    res = resolve_contact(DISK, state, floor, Material(1.0, 1.0, 0.8), G, 0.002)
    after = apply_impulse(DISK.mass, DISK.inertia, state, res.linear, res.angular, res.correction)
    gained = mechanical_energy(DISK, after, G) - mechanical_energy(DISK, state, G)
    assert not res.bounced and gained <= 0.0 and res.dissipated == pytest.approx(-gained, rel=1e-9)


def test_an_elastic_frictionless_bounce_stays_a_bounce_and_books_nothing():
    """The whole-response test does not take an elastic bounce's exact balance for a gain: a flat disk
    met at 1 m/s, e = 1, no friction, bounces and dissipates nothing beyond round-off."""
    tau = 2e-4
    vc = -1.0
    state = flat(H + vc * tau + 0.5 * G[2] * tau * tau, (0.3, 0.0, vc + G[2] * tau))
    res = resolve_contact(DISK, state, FLOOR, Material(1.0, 0.0, 0.0), G, DT)
    assert res.bounced and abs(res.dissipated) < 1e-12
