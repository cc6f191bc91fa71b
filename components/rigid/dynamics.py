"""Rigid-body dynamics of an axisymmetric body: state, inertia in the world frame, Euler's equations,
the exact torque-free rotation, impulses and energies. Plain functions on float tuples.

Every body here has principal moments (I_d, I_d, I_a) about body (x, y, z) (see
:mod:`components.rigid.shapes`). That symmetry gives closed forms used throughout, with n the body
z axis in the world frame:

    I_world h   = I_d h + (I_a - I_d) (h.n) n
    I_world^-1 h = h / I_d + (1/I_a - 1/I_d) (h.n) n

and an exact torque-free motion (the symmetric top): with L the (constant) world angular momentum,
the body turns about L at rate |L| / I_d while spinning about its own axis at rate
(1/I_a - 1/I_d) (L.n); the two rotations commute, so one step of any length is exact
(:func:`free_rotation`). The Verlet and semi-implicit integrators use it as their drift, so
torque-free rotation conserves energy and angular momentum to round-off at any step.
"""

from __future__ import annotations

from typing import NamedTuple

from components.rigid import quaternion as quat
from components.rigid.quaternion import Quat
from components.rigid.vec import Vec, cross, dot


class RigidState(NamedTuple):
    """Dynamic state of a body, world frame.

    position: (3,) centre of mass [m]; orientation: (4,) unit quaternion (w, x, y, z) body->world;
    velocity: (3,) [m/s]; angular_velocity: (3,) world frame [rad/s].
    """

    position: Vec
    orientation: Quat
    velocity: Vec
    angular_velocity: Vec


def inertia_apply(inertia: Vec, axis: Vec, h: Vec) -> Vec:
    """I_world h [kg m^2 * unit of h] for principal moments (I_d, I_d, I_a) and body axis ``axis``."""
    i_d = inertia[0]
    k = (inertia[2] - i_d) * (h[0] * axis[0] + h[1] * axis[1] + h[2] * axis[2])
    return (i_d * h[0] + k * axis[0], i_d * h[1] + k * axis[1], i_d * h[2] + k * axis[2])


def inertia_solve(inertia: Vec, axis: Vec, h: Vec) -> Vec:
    """I_world^-1 h for principal moments (I_d, I_d, I_a) and body axis ``axis`` (world)."""
    inv_d = 1.0 / inertia[0]
    k = (1.0 / inertia[2] - inv_d) * (h[0] * axis[0] + h[1] * axis[1] + h[2] * axis[2])
    return (inv_d * h[0] + k * axis[0], inv_d * h[1] + k * axis[1], inv_d * h[2] + k * axis[2])


def angular_momentum(inertia: Vec, q: Quat, omega: Vec) -> Vec:
    """World angular momentum L = I_world omega [kg m^2/s] about the centre of mass."""
    return inertia_apply(inertia, quat.body_axis(q), omega)


def omega_from_momentum(inertia: Vec, q: Quat, momentum: Vec) -> Vec:
    """World angular velocity [rad/s] from the world angular momentum at orientation q."""
    return inertia_solve(inertia, quat.body_axis(q), momentum)


def free_rotation(inertia: Vec, q: Quat, momentum: Vec, dt: float) -> Quat:
    """Orientation after a torque-free interval dt [s] with world angular momentum ``momentum``: exact.

    q(t) = exp(t L / I_d) q(0) exp(t (1/I_a - 1/I_d) (L.n) e_z): a turn about L (world frame, applied
    on the left) and a spin about the body axis (body frame, on the right), which commute.
    """
    i_d, i_a = inertia[0], inertia[2]
    n = quat.body_axis(q)
    spin = (1.0 / i_a - 1.0 / i_d) * dot(momentum, n) * dt
    c = dt / i_d
    turn = quat.from_rotation_vector((momentum[0] * c, momentum[1] * c, momentum[2] * c))
    q = quat.mul(turn, q)
    if spin != 0.0:
        q = quat.mul(q, quat.from_rotation_vector((0.0, 0.0, spin)))
    return quat.normalize(q)


def euler_rhs(inertia: Vec, omega_body: Vec, torque_body: Vec) -> Vec:
    """Euler's equations, body frame: d omega/dt = I^-1 (torque - omega x (I omega)) [rad/s^2].

    The gyroscopic term omega x (I omega) vanishes for a spin about the symmetry axis alone.
    """
    i0, i1, i2 = inertia
    w0, w1, w2 = omega_body
    h0, h1, h2 = i0 * w0, i1 * w1, i2 * w2
    return ((torque_body[0] - (w1 * h2 - w2 * h1)) / i0,
            (torque_body[1] - (w2 * h0 - w0 * h2)) / i1,
            (torque_body[2] - (w0 * h1 - w1 * h0)) / i2)


def kinetic_energy(mass: float, inertia: Vec, state: RigidState) -> float:
    """Translational plus rotational kinetic energy [J]."""
    v, w = state.velocity, state.angular_velocity
    iw = angular_momentum(inertia, state.orientation, w)
    return 0.5 * mass * dot(v, v) + 0.5 * dot(w, iw)


def potential_energy(mass: float, gravity: Vec, position: Vec) -> float:
    """Gravitational potential energy -M g.x [J] (zero at the origin: at z = 0 for g along -z)."""
    return -mass * dot(gravity, position)


def apply_impulse(mass: float, inertia: Vec, state: RigidState, linear: Vec, angular: Vec,
                  correction: Vec, *, rotate: bool = True) -> RigidState:
    """State after an instantaneous impulse: v += J/M, omega += I_world^-1 H, x += correction.

    linear J [N s] and angular H [N m s] (about the centre of mass) in the world frame; ``rotate``
    false ignores H (a body whose attitude is held).
    """
    x, q, v, w = state
    inv_m = 1.0 / mass
    v = (v[0] + linear[0] * inv_m, v[1] + linear[1] * inv_m, v[2] + linear[2] * inv_m)
    x = (x[0] + correction[0], x[1] + correction[1], x[2] + correction[2])
    if rotate and (angular[0] != 0.0 or angular[1] != 0.0 or angular[2] != 0.0):
        dw = inertia_solve(inertia, quat.body_axis(q), angular)
        w = (w[0] + dw[0], w[1] + dw[1], w[2] + dw[2])
    return RigidState(x, q, v, w)


def point_velocity(state: RigidState, r: Vec) -> Vec:
    """Velocity [m/s] of the body point at offset r [m] (world) from the centre of mass: v + w x r."""
    v = state.velocity
    wr = cross(state.angular_velocity, r)
    return (v[0] + wr[0], v[1] + wr[1], v[2] + wr[2])
