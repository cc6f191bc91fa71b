"""The water a submerged body carries along as it accelerates: its added mass.

A body accelerating through water sets the water around it moving, and the force that takes is
-M_a a (potential flow; M_a the added-mass tensor, a the body's acceleration relative to still
water). For an axisymmetric body M_a is diagonal in the body's frame. The values here are the
potential-flow ones of the bodies the coupler knows (Lamb, *Hydrodynamics*, sections 92 and 108;
Newman, *Marine Hydrodynamics*, section 4.13):

- a thin disk of radius R: 8/3 rho R^3 along its axis and 16/45 rho R^5 about a diameter; moving
  edgewise or turning about its axis it moves no water (its thickness, a few per cent of its
  diameter for a skipping stone, is left out);
- a sphere of radius R: half the mass of the water it displaces, 2/3 pi rho R^3, in every
  direction, and nothing for turning.

These hold for a body wholly under water. A body at the surface is a planing or a floating one: the
water piled up ahead of a planing face carries the steady part of its added mass's force, v_n dm_a/dt
(it is in the lift coefficient, docs/validation.md section 1; not the inertia m_a dv_n/dt of the
wetted face's water, which the measured law leaves out: docs/validation.md, "How long a contact
lasts"), and a floating one radiates waves. So the added mass
comes in with the submerged share, 1 minus the planing share (the body's top going under the
surface over the closure depth, :meth:`WaterCoupler._immersion`), as the planing lift goes out.

The coupler publishes M_a (:class:`AddedMass`) and the body adds it to its own inertia, so that
the force needs no acceleration from the step before: held over a step, -M_a a lags behind a and
is unstable once M_a exceeds the body's mass (a 6 mm slate's axial added mass is 2.7 times its own).
:class:`AddedMassBook` counts the work of that force on the body into the coupler's energy books.
"""

from __future__ import annotations

import math
from typing import Any

from components.messages import AddedMass, BodyState, Shape
from components.rigid.quaternion import body_axis

ZERO = AddedMass.zero()


def full_added_mass(shape: Shape, radius: float, rho: float) -> AddedMass:
    """The added mass of the body wholly under water of density ``rho`` [kg/m^3]."""
    r = float(radius)
    if shape == Shape.DISK:
        return AddedMass(8.0 / 3.0 * rho * r**3, 0.0, 0.0, 16.0 / 45.0 * rho * r**5)
    linear = 2.0 / 3.0 * math.pi * rho * r**3
    return AddedMass(linear, linear, 0.0, 0.0)


def scaled(full: AddedMass, share: float) -> AddedMass:
    """``full`` times the submerged ``share`` [0, 1] (the zero message itself at 0)."""
    if share <= 0.0:
        return ZERO
    if share >= 1.0:
        return full
    return AddedMass(full.axial * share, full.radial * share, full.axial_inertia * share,
                     full.diameter_inertia * share)


class AddedMassBook:
    """Minus the work the added-mass force did on the body over its last step [J]: the energy the
    body gave to the water it set moving (negative when that water gave it back).

    The body took the added mass the coupler published a step earlier, from the state the coupler
    saw then; the force was -M_a dv/dt, held over the step, so its work is exact from the two
    states: M_a (v - v_prev) / dt . (x - x_prev), split along the body's axis (as it was at the
    step's start, where the body split its force) and across it. The turning's is the change of the
    water's own kinetic energy, 1/2 omega . J(n) omega at the step's end less at its start, each with
    the body's axis n of its state: the torque -d(J omega)/dt of an added inertia J that turns with
    the body does work -d(1/2 omega . J omega)/dt, the part of the change of J along the turning
    included (the turning axis's J held at the start, a disk spun at 100 rad/s and tumbling at
    30 rad/s 20 cm under water booked 2.05e-4 J too little over 0.1 s at 0.5 ms steps, of a kinetic
    energy of 0.017 J; the error halved with the step).
    """

    def __init__(self) -> None:
        self.added: AddedMass = ZERO  # the added mass of the last step, the one the body holds
        self.state: tuple[list[float], ...] | None = None  # (position, velocity, omega, axis) then

    def settle(self, body: BodyState, dt: float) -> float:
        """The energy given to the water over the step [s] that led to ``body``."""
        added, before = self.added, self.state
        if before is None or added is ZERO or not dt > 0.0:
            return 0.0
        x0, v0, w0, n0 = before
        x1, v1, w1 = body.position.tolist(), body.velocity.tolist(), body.angular_velocity.tolist()
        dv = [b - a for a, b in zip(v0, v1, strict=True)]
        dx = [b - a for a, b in zip(x0, x1, strict=True)]
        work = _split_dot(n0, dv, dx, added.axial, added.radial) / dt
        if added.axial_inertia or added.diameter_inertia:
            n1 = list(body_axis(tuple(body.orientation.tolist())))
            work += 0.5 * (_split_dot(n1, w1, w1, added.axial_inertia, added.diameter_inertia)
                           - _split_dot(n0, w0, w0, added.axial_inertia, added.diameter_inertia))
        return work

    def hold(self, body: BodyState, published: AddedMass) -> None:
        """Remember this step's state and the added mass the body will take from it (no state
        while there is none: :meth:`settle` then has nothing to count)."""
        self.added = published
        if published is ZERO:
            self.state = None
            return
        self.state = (body.position.tolist(), body.velocity.tolist(), body.angular_velocity.tolist(),
                      list(body_axis(tuple(body.orientation.tolist()))))

    def get_state(self) -> dict[str, Any]:
        return {"added_mass": list(self.added.values()),
                "added_mass_from": None if self.state is None else [list(v) for v in self.state]}

    def set_state(self, state: dict[str, Any]) -> None:
        values = [float(v) for v in state.get("added_mass", [0.0] * 4)]
        self.added = ZERO if not any(values) else AddedMass(*values)
        before = state.get("added_mass_from")
        self.state = None if before is None else tuple([float(x) for x in v] for v in before)


def _split_dot(n: list[float], a: list[float], b: list[float], along: float, across: float) -> float:
    """a . M b for M = along n n^T + across (1 - n n^T), n a unit vector."""
    an = a[0] * n[0] + a[1] * n[1] + a[2] * n[2]
    bn = b[0] * n[0] + b[1] * n[1] + b[2] * n[2]
    ab = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    return along * an * bn + across * (ab - an * bn)
