"""Time integrators for one rigid body, by name: ``verlet`` (default), ``semi_implicit_euler``, ``rk4``.

Each integrator is ``step(body, state, forces, t, dt, rotate=True) -> RigidState`` where ``forces`` is
either a function ``(t, state) -> (force, torque)`` or a constant ``(force, torque)`` pair, both in
the world frame, force [N] on the centre of mass (gravity included) and torque [N m] about it.
``rotate=False`` holds the orientation and angular velocity (a locked attitude).

- ``verlet``: velocity Verlet for the translation; for the rotation the matching symplectic
  splitting "half kick of the angular momentum, exact torque-free drift
  (:func:`~components.rigid.dynamics.free_rotation`), half kick" (Dullweber, Leimkuhler & McLachlan
  1997). Second order. Velocity-dependent forces are handled consistently: the end-of-step force is
  evaluated at the new position with the predicted velocity v + a dt (and the predicted angular
  velocity), which keeps second order; with constant forces it is exact (free fall, projectiles),
  and torque-free rotation is exact at any step.
- ``semi_implicit_euler``: kick then drift (velocity first, then position with the new velocity;
  angular momentum first, then the exact drift). First order, symplectic.
- ``rk4``: classical Runge-Kutta on (x, v, q, omega_body) with Euler's equations in the body frame
  (:func:`~components.rigid.dynamics.euler_rhs`). Fourth order; the quaternion is normalised after the
  step.
"""

from __future__ import annotations

from collections.abc import Callable

from components.rigid import quaternion as quat
from components.rigid.dynamics import RigidState, euler_rhs, free_rotation, inertia_apply, inertia_solve
from components.rigid.shapes import MassProperties
from components.rigid.vec import Vec

ForceFn = Callable[[float, RigidState], tuple[Vec, Vec]]
Forces = ForceFn | tuple[Vec, Vec]
Integrator = Callable[..., RigidState]


def verlet(body: MassProperties, state: RigidState, forces: Forces, t: float, dt: float,
           rotate: bool = True) -> RigidState:
    """Velocity Verlet step (translation) with a kick-drift-kick splitting for the rotation."""
    x, q, v, w = state
    constant = not callable(forces)
    f0, t0 = forces if constant else forces(t, state)  # type: ignore[misc, operator]
    inv_m = 1.0 / body.mass
    a0 = (f0[0] * inv_m, f0[1] * inv_m, f0[2] * inv_m)
    h = 0.5 * dt
    hh = h * dt
    x1 = (x[0] + v[0] * dt + a0[0] * hh, x[1] + v[1] * dt + a0[1] * hh, x[2] + v[2] * dt + a0[2] * hh)
    inertia = body.inertia
    if rotate:
        axis = quat.body_axis(q)
        m0 = inertia_apply(inertia, axis, w)
        m_half = (m0[0] + h * t0[0], m0[1] + h * t0[1], m0[2] + h * t0[2])
        q1 = free_rotation(inertia, q, m_half, dt)
        axis1 = quat.body_axis(q1)
    else:
        q1 = q
    if constant:
        f1, t1 = f0, t0
    else:
        v_pred = (v[0] + a0[0] * dt, v[1] + a0[1] * dt, v[2] + a0[2] * dt)
        if rotate:
            w_pred = inertia_solve(inertia, axis1, (m_half[0] + h * t0[0], m_half[1] + h * t0[1],
                                                    m_half[2] + h * t0[2]))
        else:
            w_pred = w
        f1, t1 = forces(t + dt, RigidState(x1, q1, v_pred, w_pred))  # type: ignore[operator]
    v1 = (v[0] + h * (a0[0] + f1[0] * inv_m), v[1] + h * (a0[1] + f1[1] * inv_m),
          v[2] + h * (a0[2] + f1[2] * inv_m))
    if rotate:
        w1 = inertia_solve(inertia, axis1, (m_half[0] + h * t1[0], m_half[1] + h * t1[1],
                                            m_half[2] + h * t1[2]))
    else:
        w1 = w
    return RigidState(x1, q1, v1, w1)


def semi_implicit_euler(body: MassProperties, state: RigidState, forces: Forces, t: float, dt: float,
                        rotate: bool = True) -> RigidState:
    """Semi-implicit (symplectic) Euler: kick with the start-of-step force, then drift."""
    x, q, v, w = state
    f0, t0 = forces if not callable(forces) else forces(t, state)  # type: ignore[misc]
    inv_m = 1.0 / body.mass
    v1 = (v[0] + f0[0] * inv_m * dt, v[1] + f0[1] * inv_m * dt, v[2] + f0[2] * inv_m * dt)
    x1 = (x[0] + v1[0] * dt, x[1] + v1[1] * dt, x[2] + v1[2] * dt)
    if not rotate:
        return RigidState(x1, q, v1, w)
    inertia = body.inertia
    m0 = inertia_apply(inertia, quat.body_axis(q), w)
    m1 = (m0[0] + t0[0] * dt, m0[1] + t0[1] * dt, m0[2] + t0[2] * dt)
    q1 = free_rotation(inertia, q, m1, dt)
    return RigidState(x1, q1, v1, inertia_solve(inertia, quat.body_axis(q1), m1))


def rk4(body: MassProperties, state: RigidState, forces: Forces, t: float, dt: float,
        rotate: bool = True) -> RigidState:
    """Classical fourth-order Runge-Kutta on (x, v, q, omega_body) with Euler's equations."""
    inv_m = 1.0 / body.mass
    inertia = body.inertia
    constant = not callable(forces)

    def deriv(tt: float, x: Vec, v: Vec, q: quat.Quat, wb: Vec) -> tuple[Vec, Vec, quat.Quat, Vec]:
        qn = quat.normalize(q)
        if constant:
            f, tau = forces  # type: ignore[misc]
        else:
            f, tau = forces(tt, RigidState(x, qn, v, quat.rotate(qn, wb)))  # type: ignore[operator]
        dv = (f[0] * inv_m, f[1] * inv_m, f[2] * inv_m)
        if not rotate:
            return v, dv, (0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        dq = quat.mul(q, (0.0, 0.5 * wb[0], 0.5 * wb[1], 0.5 * wb[2]))
        return v, dv, dq, euler_rhs(inertia, wb, quat.rotate_inv(qn, tau))

    def shift(y: tuple, k: tuple, c: float) -> tuple:
        return tuple(tuple(a + c * b for a, b in zip(ya, ka, strict=True))
                     for ya, ka in zip(y, k, strict=True))

    y0 = (state.position, state.velocity, state.orientation,
          quat.rotate_inv(state.orientation, state.angular_velocity))
    k1 = deriv(t, *y0)
    k2 = deriv(t + 0.5 * dt, *shift(y0, k1, 0.5 * dt))
    k3 = deriv(t + 0.5 * dt, *shift(y0, k2, 0.5 * dt))
    k4 = deriv(t + dt, *shift(y0, k3, dt))
    c = dt / 6.0
    y1 = tuple(tuple(a + c * (b1 + 2.0 * b2 + 2.0 * b3 + b4)
                     for a, b1, b2, b3, b4 in zip(*parts, strict=True))
               for parts in zip(y0, k1, k2, k3, k4, strict=True))
    x1, v1, q1, wb1 = y1
    if not rotate:
        return RigidState(x1, state.orientation, v1, state.angular_velocity)  # type: ignore[arg-type]
    q1 = quat.normalize(q1)  # type: ignore[arg-type]
    return RigidState(x1, q1, v1, quat.rotate(q1, wb1))  # type: ignore[arg-type]


INTEGRATORS: dict[str, Integrator] = {
    "verlet": verlet,
    "semi_implicit_euler": semi_implicit_euler,
    "rk4": rk4,
}
"""Integrators by name (the ``integrator`` parameter of RigidBody)."""

ORDERS: dict[str, int] = {"verlet": 2, "semi_implicit_euler": 1, "rk4": 4}
"""Nominal order of accuracy of each integrator."""


def unknown_integrator(name: object) -> str | None:
    """The problem with an integrator name, or None if it is known."""
    if name in INTEGRATORS:
        return None
    return f"unknown integrator {name!r} (choices: {', '.join(INTEGRATORS)})"


def get_integrator(name: str) -> Integrator:
    """The integrator registered under ``name``; a ValueError lists the choices otherwise."""
    problem = unknown_integrator(name)
    if problem is not None:
        raise ValueError(problem)
    return INTEGRATORS[name]
