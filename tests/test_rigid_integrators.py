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


@pytest.mark.parametrize("name", list(INTEGRATORS))
def test_torque_free_disk_conserves_energy_and_momentum_and_precesses_at_the_analytic_rate(name):
    """A wobbling, spinning disk over 10 s at the scenes' step: energy and angular momentum drift below
    1e-6 relative, and the axis precesses about L at |L| / I_d within 0.5%."""
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
    assert abs(dyn.kinetic_energy(DISK.mass, DISK.inertia, s) / energy - 1) < 1e-6
    assert np.linalg.norm(final_l - momentum) / np.linalg.norm(momentum) < 1e-6
    rate = np.polyfit(times, np.unwrap(azimuths), 1)[0]
    assert rate == pytest.approx(np.linalg.norm(momentum) / DISK.inertia[0], rel=5e-3)


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
