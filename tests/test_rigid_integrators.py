"""The integrator registry against exact solutions (components.rigid.integrators)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from components.messages import Shape
from components.rigid import dynamics as dyn
from components.rigid import quaternion as quat
from components.rigid.integrators import INTEGRATORS, ORDERS, get_integrator, unknown_integrator
from components.rigid.shapes import mass_properties

DISK = mass_properties(Shape.DISK, 0.05, 0.006, density=2700.0)
G = (0.0, 0.0, -9.81)
DT = 5e-4  # the base step of the scenes [s]


def weight(body):
    return (body.mass * G[0], body.mass * G[1], body.mass * G[2]), (0.0, 0.0, 0.0)


@pytest.mark.parametrize("constant", [True, False], ids=["constant", "callable"])
def test_verlet_projectile_is_exact_to_round_off(constant):
    """Under velocity Verlet with constant gravity, 4000 steps land on x0 + v0 t + g t^2/2 and v0 + g t
    to round-off (the error stays within one ulp of the trajectory's scale per step), whether the
    force is given as a constant or a function."""
    s = dyn.RigidState((0.0, 0.0, 1.0), quat.IDENTITY, (7.0, -1.0, 12.0), (0.0, 0.0, 0.0))
    x0, v0 = np.array(s.position), np.array(s.velocity)
    forces = weight(DISK) if constant else (lambda t, st: weight(DISK))
    n = 4000
    for k in range(n):
        s = INTEGRATORS["verlet"](DISK, s, forces, k * DT, DT)
    t = n * DT
    g = np.array(G)
    round_off = n * np.finfo(float).eps
    scale = np.abs(x0) + np.abs(v0) * t + np.abs(g) * t * t
    assert np.all(np.abs(np.subtract(s.position, x0 + v0 * t + 0.5 * g * t * t)) <= round_off * scale)
    assert np.all(np.abs(np.subtract(s.velocity, v0 + g * t)) <= round_off * (np.abs(v0) + np.abs(g) * t))


def test_verlet_free_fall_from_rest_hits_the_exact_time_and_speed():
    """Dropped from 1 m, after 0.4 s the height is 1 - g 0.16/2 and the speed g 0.4, to 1e-14."""
    s = dyn.RigidState((0.0, 0.0, 1.0), quat.IDENTITY, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    for k in range(800):
        s = INTEGRATORS["verlet"](DISK, s, weight(DISK), k * DT, DT)
    assert s.position[2] == pytest.approx(1.0 - 0.5 * 9.81 * 0.16, rel=1e-14)
    assert s.velocity[2] == pytest.approx(-9.81 * 0.4, rel=1e-14)


def test_semi_implicit_euler_falls_behind_the_exact_fall_by_exactly_g_t_dt_over_2():
    """The semi-implicit (symplectic) Euler step moves with the velocity at the step's end: in free
    fall its height is the exact one less g t dt / 2 (sum of k g dt^2 over the steps), its speed exact,
    to round-off, at every step size: a first-order position error of known size, not merely of
    first order."""
    for dt in (1e-3, 5e-4, 2.5e-4):
        s = dyn.RigidState((0.0, 0.0, 1.0), quat.IDENTITY, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        n = round(0.4 / dt)
        for k in range(n):
            s = INTEGRATORS["semi_implicit_euler"](DISK, s, weight(DISK), k * dt, dt)
        t = n * dt
        assert s.position[2] == pytest.approx(1.0 - 0.5 * 9.81 * t * t - 0.5 * 9.81 * t * dt, rel=1e-13)
        assert s.velocity[2] == pytest.approx(-9.81 * t, rel=1e-13)


# --- a smooth problem with position-, velocity- and orientation-dependent loads ----------------------

SPRING, DAMPING = 40.0, 0.3   # [N/m], [N s/m]
ARM = (0.01, 0.0, 0.005)      # body-frame point [m] where a constant load acts (a heavy-top torque)
LOAD = (0.0, 0.0, -1.0)       # [N]
SPIN_DRAG = 1e-5              # [N m s] torque against the angular velocity
T_END = 1.0                   # [s]
S0 = dyn.RigidState((0.1, 0.0, -0.05), quat.from_axis_angle((1.0, 0.3, 0.0), 0.5), (0.0, 0.5, 0.2),
                    (1.0, -2.0, 15.0))


def smooth_forces(t, s):
    x, q, v, w = s
    force = tuple(-SPRING * x[i] - DAMPING * v[i] for i in range(3))
    torque = np.cross(quat.rotate(q, ARM), LOAD) - SPIN_DRAG * np.array(w)
    return force, tuple(torque)


def reference_end_state():
    """Newton-Euler equations integrated by scipy's DOP853 at tight tolerance."""
    def rhs(t, y):
        q = tuple(y[6:10])
        wb = tuple(y[10:])
        qn = quat.normalize(q)
        f, tau = smooth_forces(t, dyn.RigidState(tuple(y[:3]), qn, tuple(y[3:6]), quat.rotate(qn, wb)))
        dq = quat.mul(q, (0.0, 0.5 * wb[0], 0.5 * wb[1], 0.5 * wb[2]))
        dw = dyn.euler_rhs(DISK.inertia, wb, quat.rotate_inv(qn, tau))
        return [*y[3:6], *(np.array(f) / DISK.mass), *dq, *dw]

    q0 = S0.orientation
    y0 = [*S0.position, *S0.velocity, *q0, *quat.rotate_inv(q0, S0.angular_velocity)]
    y = solve_ivp(rhs, (0.0, T_END), y0, method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
    q = quat.normalize(tuple(y[6:10]))
    return dyn.RigidState(tuple(y[:3]), q, tuple(y[3:6]), quat.rotate(q, tuple(y[10:])))


REFERENCE = reference_end_state()


def end_error(name, steps):
    s, dt = S0, T_END / steps
    for k in range(steps):
        s = INTEGRATORS[name](DISK, s, smooth_forces, k * dt, dt)
    return max(np.abs(np.subtract(s.position, REFERENCE.position)).max(),
               np.abs(np.subtract(s.velocity, REFERENCE.velocity)).max(),
               quat.angle_between(s.orientation, REFERENCE.orientation),
               np.abs(np.subtract(s.angular_velocity, REFERENCE.angular_velocity)).max() * T_END)


@pytest.mark.parametrize(("name", "steps"), [("semi_implicit_euler", 3200), ("verlet", 200), ("rk4", 200)])
def test_measured_order_matches_the_nominal_order(name, steps):
    """On a smooth problem (damped spring, orientation-dependent torque, velocity-dependent force and
    torque), halving the step divides the error by 2^order: measured order within 0.2 of nominal."""
    measured = math.log2(end_error(name, steps) / end_error(name, 2 * steps))
    assert abs(measured - ORDERS[name]) < 0.2, f"{name}: measured order {measured:.3f}"


# how far each integrator keeps a torque-free disk's energy, momentum and precession rate over 10 s
# (relative): the exact-drift ones to round-off (measured 6e-16, 1.2e-15, 4e-15), RK4 to its own
# error (2.4e-10, 1.6e-10, 3.5e-9), each bound ten times or more what it keeps, so that a loss of
# exactness fails
TORQUE_FREE_TOLERANCE = {"semi_implicit_euler": 1e-13, "verlet": 1e-13, "rk4": 5e-8}


@pytest.mark.parametrize("name", list(INTEGRATORS))
def test_torque_free_disk_conserves_energy_and_momentum_and_precesses_at_the_analytic_rate(name):
    """A wobbling, spinning disk over 10 s at the scenes' step: energy and angular momentum kept, the
    axis precessing about L at |L| / I_d, and the quaternion of unit length, each to the integrator's
    own accuracy (TORQUE_FREE_TOLERANCE)."""
    q = quat.from_axis_angle((1.0, 0.0, 0.0), 0.3)
    s = dyn.RigidState((0.0, 0.0, 0.0), q, (0.0, 0.0, 0.0), quat.rotate(q, (3.0, 0.0, 60.0)))
    momentum = np.array(dyn.angular_momentum(DISK.inertia, s.orientation, s.angular_velocity))
    energy = dyn.kinetic_energy(DISK.mass, DISK.inertia, s)
    l_hat = momentum / np.linalg.norm(momentum)
    ref = np.cross(l_hat, [0.0, 1.0, 0.0])
    ref /= np.linalg.norm(ref)
    step = INTEGRATORS[name]
    no_load = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    times, azimuths = [], []
    for k in range(20_000):
        s = step(DISK, s, no_load, k * DT, DT)
        if k % 10 == 9:
            n = np.array(quat.body_axis(s.orientation))
            perp = n - (n @ l_hat) * l_hat
            times.append((k + 1) * DT)
            azimuths.append(math.atan2(np.cross(ref, perp) @ l_hat, ref @ perp))
    final_l = np.array(dyn.angular_momentum(DISK.inertia, s.orientation, s.angular_velocity))
    tol = TORQUE_FREE_TOLERANCE[name]
    assert abs(dyn.kinetic_energy(DISK.mass, DISK.inertia, s) / energy - 1) < tol
    assert np.linalg.norm(final_l - momentum) / np.linalg.norm(momentum) < tol
    rate = np.polyfit(times, np.unwrap(azimuths), 1)[0]
    assert rate == pytest.approx(np.linalg.norm(momentum) / DISK.inertia[0], rel=tol)
    assert abs(math.sqrt(sum(c * c for c in s.orientation)) - 1.0) < 1e-14


@pytest.mark.parametrize("name", list(INTEGRATORS))
def test_held_attitude_keeps_orientation_and_angular_velocity(name):
    """rotate=False holds orientation and angular velocity under any torque, while translating."""
    q = quat.from_axis_angle((0.0, 1.0, 0.0), 0.3)
    s = dyn.RigidState((0.0, 0.0, 0.0), q, (1.0, 0.0, 0.0), (0.0, 0.0, 400.0))
    out = INTEGRATORS[name](DISK, s, ((0.0, 0.0, -1.0), (1.0, 2.0, 3.0)), 0.0, DT, False)
    assert out.orientation == q
    assert out.angular_velocity == (0.0, 0.0, 400.0)
    assert out.position[0] == pytest.approx(DT)


def test_unknown_integrator_lists_the_choices():
    """An unknown integrator name is an error listing every registered name."""
    with pytest.raises(ValueError,
                       match=r"unknown integrator 'leapfrog' \(choices: verlet, semi_implicit_euler, rk4\)"):
        get_integrator("leapfrog")
    assert unknown_integrator("rk4") is None
    assert get_integrator("rk4") is INTEGRATORS["rk4"]


def _steady_precession_rate(name, dt, body=DISK, tilt_deg=30.0, spin=400.0, rate=2.0, t_end=2.0):
    """The precession rate [rad/s] of a heavy top's axis about the vertical, fitted over ``t_end``:
    the disk tilted by ``tilt_deg`` from the vertical, spun at ``spin`` about its axis and turned at
    ``rate`` about the vertical, under the torque k z x n whose k makes that an exact steady
    precession: k = rate (I_a omega_3 - I_d rate cos(tilt)) (Euler's equations, the symmetric top)."""
    i_d, i_a = body.inertia[0], body.inertia[2]
    tilt = math.radians(tilt_deg)
    q = quat.from_axis_angle((0.0, -1.0, 0.0), tilt)
    n0 = np.array(quat.body_axis(q))
    w0 = rate * np.array([0.0, 0.0, 1.0]) + spin * n0
    k = rate * (i_a * (w0 @ n0) - i_d * rate * math.cos(tilt))

    def torque(t, s):
        n = quat.body_axis(s.orientation)
        return (0.0, 0.0, 0.0), (-k * n[1], k * n[0], 0.0)  # k (z x n)

    s = dyn.RigidState((0.0, 0.0, 0.0), q, (0.0, 0.0, 0.0), tuple(w0))
    steps = round(t_end / dt)
    azimuths = []
    for i in range(steps):
        s = INTEGRATORS[name](body, s, torque, i * dt, dt)
        n = quat.body_axis(s.orientation)
        azimuths.append(math.atan2(n[1], n[0]))
    return np.polyfit(dt * np.arange(1, steps + 1), np.unwrap(azimuths), 1)[0]


@pytest.mark.parametrize("name", list(INTEGRATORS))
def test_a_heavy_top_precesses_at_the_exact_steady_rate_converging_at_the_integrators_order(name):
    """A spinning disk under the torque of an exact steady precession at 2 rad/s (the symmetric heavy
    top: k = Omega (I_a omega_3 - I_d Omega cos theta), not the fast top's tau / (I_a omega) = 1.996)
    turns at 2 rad/s: within 1e-4 at 0.5 ms, the error falling by at least 2^order x 0.8 from 1 ms
    (the rate's error is second order for the semi-implicit Euler step too: measured 1.17e-4, 2.9e-5
    for it and Verlet, 1.0e-4, 6.4e-6 for RK4)."""
    coarse = abs(_steady_precession_rate(name, 1e-3) / 2.0 - 1.0)
    fine = abs(_steady_precession_rate(name, 5e-4) / 2.0 - 1.0)
    assert fine < 1e-4
    assert coarse / fine > 0.8 * 2 ** max(2, ORDERS[name])
