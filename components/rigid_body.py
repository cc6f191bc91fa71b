"""RigidBody: a thin disk or a sphere moving under gravity, wrenches and contact impulses.

Ports:
- ``wrench`` (Wrench): the summed external force [N] and torque about the centre of mass [N m], world
  frame, held constant over the step (water forces, a push). Gravity is added by the body itself.
- ``added_mass`` (AddedMass): the water a submerged body carries along (from a WaterCoupler through a
  ``delay: 1`` edge), added to the body's mass and inertia over the step: the total force and torque
  then accelerate body and water together (:meth:`components.messages.AddedMass.carried`), and turn
  them together, Euler's equations with the water's moments added (:meth:`~components.messages.AddedMass.with_inertia`).
- ``impulse`` (Impulse, event): contact impulses and position corrections, applied once at the start
  of the step, before integrating (from SolidGround through a ``delay: 1`` edge).
- ``state`` (BodyState, out): the state at the end of the step, every field filled.

The physics lives in :mod:`components.rigid` as plain functions; this class holds the state, applies
the options and builds the messages. Per-step work is done on float tuples (a numpy call per
3-vector would cost more than the whole step).

Options:
- ``lock_attitude``: the orientation and angular velocity are held (the high-spin limit of the
  published skipping experiments: a disk spun at 65 rev/s hardly changes attitude during contact).
  Torques and angular impulses are ignored; a spin about the axis is kept as angular velocity (a
  held disk given an angular velocity across its axis is refused: its rim would move, the body not).
- ``scripted_tilt_deg``: the attitude follows keyframes [t, tilt_deg] (rotation about ``tilt_axis``,
  linearly interpolated, held outside), with the matching angular velocity (plus ``spin`` about the
  axis, which does not turn the symmetric shape); torques and angular impulses are ignored.
- ``scripted_velocity``: the horizontal velocity follows keyframes [t, vx, vy]; x and y are their
  exact integral, horizontal forces, impulses and corrections are ignored, z stays free (the
  proposal's objective 5: the water tested with pre-scripted orientation and horizontal velocity);
  water carried along (``added_mass``) takes its vertical row under the script's acceleration.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import sys
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from components.messages import AddedMass, BodyState, Impulse, Shape, Wrench
from components.rigid import quaternion as quat
from components.rigid.dynamics import RigidState, apply_impulse, kinetic_energy, potential_energy
from components.rigid.integrators import get_integrator, unknown_integrator
from components.rigid.script import Keyframes, keyframe_problems
from components.rigid.shapes import mass_properties, shape_volume
from components.rigid.vec import ZERO, Vec, add, as_vec, norm, scale
from cosim.component import Component, Port
from cosim.messages import Message
from cosim.params import param, require_valid
from cosim.timebase import NS_PER_S

Vec3Param = tuple[float, float, float]
# (the `noqa: RUF009` below: param() returns a dataclasses.field with an immutable default)

# RK4's step is bounded to keep the rotation stable (not accurate) while omega*dt stays below this
# [rad]: at the bound a disk spun at 1000 rad/s and kicked across its axis is 19 deg off after 1 s, at
# half of it 0.7 deg; the exact-drift integrators have no such bound.
RK4_MAX_ROTATION_PER_STEP = 0.5
# a held disk's angular velocity may lean off its axis by this share of itself: a spin typed to a few
# digits along a tilted axis ([-34.2, 0, 93.97] at 20 deg) is one
HELD_TURN_ACROSS = 1e-3


MAX_INERTIA_RATIO = 1e8
"""A body's largest moment of inertia over its smallest, at most. The spin about the axis is worked
out from the angular momentum, whose round-off across the axis (1e-16 of it) is this ratio larger
there: beyond about 1/sqrt(machine epsilon) it is no longer small, and a long rod's spin grows
without bound (a disk 1e20 m thick and 2.5 cm across failed at its fifth step)."""
MAX_THICKNESS_PER_RADIUS = math.sqrt(6.0 * (MAX_INERTIA_RATIO - 0.5))  # I_d / I_a = 1/2 + e^2 / (6 R^2)
HEADING_SPEED = 1e-6  # [m/s] a body let go slower than this horizontally has no heading of its own
BANK_NOTICE_DEG = 1.0  # [deg] a thrown disk banked more than this across its throw is said as the scene loads
GRAVITY_MAX = 1e4  # [m/s^2] a component of the body's gravity at most (the coupler's g has the same bound)
POSITION_MAX = 1e6  # [m] a start coordinate at most: 1000 km, the water's own bound (components.water.grid.LEVEL_MAX)
MAX_DENSITY = 1e6  # [kg/m^3] of any body, given or implied by its mass (osmium is 22,590)
DENSITY_RANGE = (1.0, 1e5)  # [kg/m^3] ordinary densities: a mass out of range with one is the size's doing


def _along_and_across(w: Vec, axis: Vec) -> tuple[float, float]:
    """The angular velocity ``w`` [rad/s] about the unit ``axis`` (signed) and across it (its size)."""
    along = w[0] * axis[0] + w[1] * axis[1] + w[2] * axis[2]
    return along, math.hypot(w[0] - along * axis[0], w[1] - along * axis[1], w[2] - along * axis[2])


def _about_the_axis(w: Vec, axis: Vec) -> Vec:
    """The part of the angular velocity ``w`` [rad/s] about the unit ``axis``: all a held disk may
    keep (a spin typed to a few digits along a tilted axis leaves a little across it, which would
    move the rim for the whole run while the body never turned). ``w`` itself when nothing to round
    off lies across it, so a spin given along the axis is kept bit for bit."""
    along, across = _along_and_across(w, axis)
    return w if across <= 1e-12 * math.hypot(*w) else scale(axis, along)


def _step_end(t: float, dt: float) -> float:
    """The time [s] a step from ``t`` over ``dt`` ends at, as the scheduler's clock has it (whole
    nanoseconds), not t + dt in floating point: 1.599 + 0.001 is 1.5999999999999999, and a scripted
    body at its 1.6 s keyframe was published still turning, at the rate of the segment before it."""
    return (round(t * NS_PER_S) + round(dt * NS_PER_S)) / NS_PER_S


@dataclass(frozen=True)
class RigidBodyParams:
    """Parameters of a RigidBody (SI units; angles in degrees in fields ending ``_deg``)."""

    shape: Literal["disk", "sphere"] = param("disk", doc="thin disk (axis along body z) or sphere")
    radius: float = param(0.05, unit="m", gt=0, doc="disk or sphere radius")
    thickness: float = param(0.005, unit="m", ge=0, doc="disk thickness (ignored for a sphere)")
    density: float = param(2700.0, unit="kg/m^3", gt=0, le=MAX_DENSITY,
                           doc="sets the mass unless mass is given (at most 1e6: osmium is 22,590)")
    mass: float | None = param(None, unit="kg", gt=0,
                               doc="overrides the density (at most the mass the density's bound, 1e6 kg/m^3, gives)")
    position: Vec3Param = param((0.0, 0.0, 0.1), unit="m",
                                doc="initial centre of mass (each coordinate within 1000 km of 0)")
    velocity: Vec3Param = param((0.0, 0.0, 0.0), unit="m/s", doc="initial velocity")
    angular_velocity: Vec3Param = param((0.0, 0.0, 0.0), unit="rad/s", doc="initial, world frame")
    spin: float = param(0.0, unit="rad/s",
                        doc="initial spin about the symmetry axis, added to angular_velocity")
    tilt_deg: float = param(0.0, unit="deg", doc="initial rotation about tilt_axis")
    tilt_axis: Vec3Param = param(
        (0.0, -1.0, 0.0), doc="world axis of the tilt; the default raises the +x edge (nose up along +x)")
    gravity: Vec3Param = param((0.0, 0.0, -9.81), unit="m/s^2",
                               doc="gravity on the body, world frame (each component at most 1e4)")
    integrator: str = param("verlet", doc="verlet | semi_implicit_euler | rk4")
    lock_attitude: bool = param(False, doc="hold orientation and angular velocity (high-spin limit)")
    scripted_tilt_deg: list[tuple[float, float]] = param(
        [], doc="keyframes [t [s], tilt [deg]] about tilt_axis, times from 0 and increasing, the tilt linear "
                "between them and held before the first and after the last; empty: free attitude")
    scripted_velocity: list[tuple[float, float, float]] = param(
        [], doc="keyframes [t [s], vx [m/s], vy [m/s]], times from 0 and increasing, the velocity linear "
                "between them and held before the first and after the last (x and y its integral); empty: "
                "free horizontal motion")

    def check(self) -> list[tuple[str, str]]:
        problems = []
        if self.scripted_velocity and (self.velocity[0] != 0.0 or self.velocity[1] != 0.0):
            # (they were dropped without a word: the script sets the horizontal velocity from t = 0)
            problems.append(("velocity", "its x and y are set by scripted_velocity; leave them 0 (z, the "
                                         f"vertical velocity, stays free) (got {list(self.velocity)})"))
        bad = unknown_integrator(self.integrator)
        if bad:
            problems.append(("integrator", bad))
        if self.shape == "disk" and not self.thickness > 0:
            problems.append(("thickness", f"a disk needs thickness > 0 m (got {self.thickness:g})"))
        if not any(self.tilt_axis):
            problems.append(("tilt_axis", "must be a non-zero vector (got [0, 0, 0])"))
        if self.scripted_tilt_deg and self.lock_attitude:
            problems.append(("lock_attitude", "cannot be combined with scripted_tilt_deg (choose one)"))
        if self.scripted_tilt_deg and self.tilt_deg != 0.0:
            problems.append(("tilt_deg", "give either tilt_deg or scripted_tilt_deg, not both"))
        if self.scripted_tilt_deg and any(self.angular_velocity):
            problems.append(("angular_velocity", "is set by scripted_tilt_deg (with spin); leave it 0"))
        problems += self._held_turn_problems()
        for name in ("scripted_tilt_deg", "scripted_velocity"):
            problems += [(name, p) for p in keyframe_problems(getattr(self, name))]
        if not all(abs(g) <= GRAVITY_MAX for g in self.gravity):  # (NaN too)
            problems.append(("gravity", f"each component at most {GRAVITY_MAX:g} m/s^2 in size, a thousand g "
                                        f"(got {list(self.gravity)!r})"))
        if not all(abs(x) <= POSITION_MAX for x in self.position):
            problems.append(("position", f"must lie within {POSITION_MAX / 1e3:g} km of the origin in each "
                                         f"coordinate, as the water may (got {list(self.position)!r})"))
        if not any(name == "thickness" for name, _ in problems):  # a flat disk has no volume: said above
            problems += self._mass_problems() or self._energy_problems()
        return problems

    def _held_turn_problems(self) -> list[tuple[str, str]]:
        """A held disk (lock_attitude) given an angular velocity across its axis: the attitude never
        turns, yet the rim would move at that rate (the water's friction reading v + omega x r, the
        published kinetic energy counting a turn that never happens). A spin about the axis is held,
        also one typed to a few digits (its part across the axis under a thousandth of it, which the
        body leaves out: _about_the_axis); a sphere looks the same turned any way, so any turn of it
        is a spin."""
        if not self.lock_attitude or self.shape != "disk" or not any(self.angular_velocity) or not any(self.tilt_axis):
            return []
        w = as_vec(self.angular_velocity)
        size = math.hypot(*w)
        if not math.isfinite(size * size):
            return []  # (an energy that overflows, or not a number: said by the value's own checks)
        try:
            n = quat.body_axis(quat.from_axis_angle(as_vec(self.tilt_axis), math.radians(self.tilt_deg)))
        except ValueError:
            return []  # (a NaN axis: said by the axis's own check)
        along, across = _along_and_across(w, n)
        if across <= HELD_TURN_ACROSS * size:
            return []
        return [("angular_velocity", f"turns the held disk across its axis at {across:.4g} rad/s, which "
                                     "lock_attitude never does (the rim would move as if it did): give only its "
                                     f"turn about the axis, as spin: {self.spin + along:.6g}, or leave the "
                                     "attitude free")]

    def shape_id(self) -> Shape:
        """The shape as the messages name it."""
        return Shape.DISK if self.shape == "disk" else Shape.SPHERE

    def _volume_and_mass(self) -> tuple[float, float]:
        """Volume [m^3] and mass [kg] (the given mass, else density x volume); inf where they overflow."""
        volume = shape_volume(self.shape_id(), self.radius, self.thickness)
        return volume, self.mass if self.mass is not None else self.density * volume

    def _mass_problems(self) -> list[tuple[str, str]]:
        """A body whose volume, mass or moment of inertia is not a positive, finite, normal float (a
        radius of 1e103 m, a thickness of 1e-310 m) would fail in its setup: refuse it here, naming the
        parameter that takes it out of range."""
        def out(value: float) -> bool:  # a subnormal float too: dividing by it overflows
            return not (math.isfinite(value) and value >= sys.float_info.min)

        r = self.radius
        volume, mass = self._volume_and_mass()
        if out(volume):
            name = "thickness" if self.shape == "disk" and not out(r * r) else "radius"
            return [(name, f"gives the body a volume of {volume:g} m^3, not a positive, finite, normal float "
                           f"(got {getattr(self, name)!r})")]
        source = "mass" if self.mass is not None else "density"  # the parameter the mass comes from
        if out(mass):
            if source == "density" and DENSITY_RANGE[0] <= self.density <= DENSITY_RANGE[1]:
                # an ordinary density: the size is what takes the mass out of range
                source = "thickness" if self.shape == "disk" and self.thickness > r else "radius"
            return [(source, f"gives the body a mass of {mass:g} kg, not a positive, finite, normal float "
                             f"(got {getattr(self, source)!r})")]
        if source == "mass" and mass > MAX_DENSITY * volume:
            # as dense as the density's own bound allows, no denser: 1e307 kg on a 5 cm disk passed,
            # and its contact with the ground failed the run with a non-finite force
            return [("mass", f"makes the body denser than {MAX_DENSITY:g} kg/m^3 (the density's bound; osmium is "
                             f"22,590): at most {MAX_DENSITY * volume:.4g} kg for its {volume:.4g} m^3 "
                             f"(got {self.mass!r})")]
        weight = mass * max(abs(g) for g in self.gravity)
        if not math.isfinite(weight):
            return [(source, f"gives the body a weight of {weight:g} N, not a finite float "
                             f"(got {getattr(self, source)!r})")]
        if out(mass * r * r):
            if source == "density" and DENSITY_RANGE[0] <= self.density <= DENSITY_RANGE[1]:
                source = "radius"  # an ordinary density: the size is what takes the moment out of range
            return [(source, f"gives the body a moment of inertia of {mass * r * r:g} kg m^2, not a positive, "
                             f"finite, normal float (got {getattr(self, source)!r})")]
        if self.shape == "disk" and self.thickness > MAX_THICKNESS_PER_RADIUS * r:
            return [("thickness", f"makes a rod {self.thickness / r:.3g} times as long as its radius, whose moments "
                                  f"of inertia are more than {MAX_INERTIA_RATIO:g} apart: round-off in its "
                                  f"angular momentum would swamp its spin; at most {MAX_THICKNESS_PER_RADIUS:.0f} "
                                  f"times the radius, {MAX_THICKNESS_PER_RADIUS * r:.4g} m here "
                                  f"(got {self.thickness!r})")]
        return []

    def _energy_problems(self) -> list[tuple[str, str]]:
        """A start whose kinetic energy overflows a float (a speed or spin of 1e150 and more) would
        fail at the first step with infinities: refuse it here, naming the parameter."""
        _, mass = self._volume_and_mass()
        # the farthest point from the centre: a moment of inertia is at most mass x its distance squared
        reach = math.hypot(self.radius, 0.5 * self.thickness) if self.shape == "disk" else self.radius
        # products, not powers: a float power that overflows raises where a product gives inf
        spin_rim = reach * abs(self.spin)
        turn_rim = reach * math.sqrt(sum(w * w for w in self.angular_velocity))
        terms = {"velocity": 0.5 * mass * sum(v * v for v in self.velocity),
                 "angular_velocity": 0.5 * mass * turn_rim * turn_rim, "spin": 0.5 * mass * spin_rim * spin_rim}
        if all(math.isfinite(e) for e in terms.values()):
            both = 0.5 * mass * (spin_rim + turn_rim) * (spin_rim + turn_rim)  # together, at most this
            if not math.isfinite(both):
                terms["spin" if spin_rim >= turn_rim else "angular_velocity"] = both
        if self.scripted_velocity:  # a scripted horizontal velocity: its fastest keyframe
            terms["scripted_velocity"] = 0.5 * mass * max(vx * vx + vy * vy for _, vx, vy in self.scripted_velocity)
        if len(self.scripted_tilt_deg) > 1 and not keyframe_problems(self.scripted_tilt_deg):
            # a scripted tilt: its fastest segment's turn about tilt_axis (90 deg in 1e-320 s turned at inf)
            rate = max(abs(math.radians(b - a)) / (tb - ta)
                       for (ta, a), (tb, b) in itertools.pairwise(self.scripted_tilt_deg))
            terms["scripted_tilt_deg"] = 0.5 * mass * (reach * rate) * (reach * rate)
        kinetic = [(name, f"makes the stone's kinetic energy overflow a float (got {getattr(self, name)!r})")
                   for name, energy in terms.items() if not math.isfinite(energy)]
        height = mass * sum(abs(g * x) for g, x in zip(self.gravity, self.position, strict=True))
        return kinetic + ([] if math.isfinite(height) else [
            ("position", f"makes the stone's potential energy overflow a float (got {self.position!r})")])


def _array(values: Vec | quat.Quat) -> np.ndarray:
    return np.array(values, dtype=np.float64)


class RigidBody(Component):
    """A thin disk or a sphere: Newton-Euler dynamics with gravity, held wrenches and impulses."""

    @property
    def start_only_params(self) -> frozenset[str]:  # type: ignore[override]
        """The body's state at t = 0: where it is, how it moves, its attitude and, unless a scripted
        tilt keeps using them, its spin and the axis it was tilted about."""
        scripted = bool(self.params.scripted_tilt_deg)
        return frozenset({"position", "velocity", "angular_velocity", "tilt_deg",
                          *(() if scripted else ("spin", "tilt_axis"))})

    Params = RigidBodyParams
    inputs = {
        "wrench": Port(Wrench, "external force and torque about the centre of mass, held over the step"),
        "added_mass": Port(AddedMass, "the water carried along, added to the body's inertia over the step"),
        "impulse": Port(Impulse, "contact impulses, applied once at the start of the step", event=True),
    }
    outputs = {"state": Port(BodyState, "state at the end of the step")}

    def setup(self) -> None:
        p: RigidBodyParams = self.params
        require_valid(p)
        self.shape = p.shape_id()
        self.body = mass_properties(self.shape, p.radius, p.thickness, density=p.density, mass=p.mass)
        self.integrate = get_integrator(p.integrator)
        self._answered = False
        self.gravity = as_vec(p.gravity)
        self.weight = scale(self.gravity, self.body.mass)
        self.tilt_axis = as_vec(p.tilt_axis)
        self.tilt_script = Keyframes(p.scripted_tilt_deg) if p.scripted_tilt_deg else None
        self.velocity_script = Keyframes(p.scripted_velocity) if p.scripted_velocity else None
        self.rotate = not (p.lock_attitude or self.tilt_script is not None)
        # whether RK4's turn per step bounds the step (max_stable_step, _integrated): found once, not a step
        self._rk4_turning = p.integrator == "rk4" and self.rotate
        # the scripted tilt's axis at length 1 (an axis of 1e200 squared to inf and turned at 0 rad/s)
        self._tilt_unit = quat.unit_axis(self.tilt_axis)
        inertia = _array(self.body.inertia)
        inertia.flags.writeable = False  # shared by every published message
        self._inertia = inertia
        self.state = self._initial_state()
        self._added_seen: Message | None = None  # the added mass last received, and whether it is any
        self._added_active = False
        self._with_water = self.body  # the body as it turns with the water it carries (its own moments: none)

    def notices(self) -> list[str]:
        """A disk tilted about an axis that is not across its throw meets the water banked: said, with
        the tilt_axis that would raise its front edge along the throw (the default axis raises the
        +x edge: a throw along -y with it comes down on its side). A held attitude spun: said what
        the spin then does."""
        p: RigidBodyParams = self.params
        said = []
        if p.lock_attitude and p.spin != 0.0:
            # the held attitude holds the spin too: the water's friction on the spinning faces takes
            # nothing from it and pushes the stone sideways with energy no throw gave it (the held
            # slate at 2000 rev/s left its first contact at 55 m/s from 8)
            said.append(f"spin {p.spin:g} rad/s with lock_attitude: the held spin never slows, so the water's friction "
                        "on the spinning faces drives the stone sideways with energy of the held spin's own; for "
                        "what a spin does to a throw, leave the attitude free")
        vx, vy = float(p.velocity[0]), float(p.velocity[1])
        speed = math.hypot(vx, vy)
        if p.shape != "disk" or p.tilt_deg == 0.0 or speed < HEADING_SPEED or p.scripted_tilt_deg:
            return said  # (a body let go with no horizontal speed of its own has no front edge)
        n = quat.body_axis(quat.from_axis_angle(self.tilt_axis, math.radians(p.tilt_deg)))  # the face's normal
        # the face rises towards -n's horizontal part: its pitch along the throw and its bank across it
        pitch = math.degrees(math.asin(max(-1.0, min(1.0, -(n[0] * vx + n[1] * vy) / speed))))
        bank = math.degrees(math.asin(max(-1.0, min(1.0, (n[0] * vy - n[1] * vx) / speed))))
        if abs(bank) <= BANK_NOTICE_DEG and pitch >= 0.0:
            return said
        ax, ay = vy / speed + 0.0, -vx / speed + 0.0  # (+ 0.0: no -0 in the text)
        banked = abs(bank) > BANK_NOTICE_DEG
        meets = "on its side" if banked else "front edge first"
        # not banked, it is tilted about the right axis the wrong way (its pitch changes sign with the angle)
        fix = f"tilt_axis [{ax:.4g}, {ay:.4g}, 0]" if banked else f"tilt_deg {-p.tilt_deg:g}"
        return [*said, f"tilt_deg {p.tilt_deg:g} about tilt_axis {list(p.tilt_axis)} leaves it {pitch + 0.0:.3g} deg "
                f"nose-up along its throw and banked {bank + 0.0:.3g} deg across it, so it meets the water {meets}; "
                f"to raise its front edge along the throw, give {fix}"]

    def check_start(self, inputs: dict[str, Message | None]) -> list[str]:
        """An added mass it starts with (a connection's initial value) must be one."""
        added = inputs.get("added_mass")
        problem = added.problem() if isinstance(added, AddedMass) else None
        return [] if problem is None else [f"its input 'added_mass' starts with {problem} (the initial value of "
                                           "the connection into it)"]

    def _initial_state(self) -> RigidState:
        p: RigidBodyParams = self.params
        tilt = p.tilt_deg if self.tilt_script is None else self.tilt_script.value(0.0)[0]
        q = quat.from_axis_angle(self.tilt_axis, math.radians(tilt))
        if self.tilt_script is None:
            w = add(as_vec(p.angular_velocity), scale(quat.body_axis(q), p.spin))
            if p.lock_attitude and p.shape == "disk":
                w = _about_the_axis(w, quat.body_axis(q))
        else:
            w = self._scripted_omega(0.0, q)
        v = as_vec(p.velocity)
        if self.velocity_script is not None:
            vx, vy = self.velocity_script.value(0.0)
            v = (vx, vy, v[2])
        return RigidState(as_vec(p.position), q, v, w)

    def _scripted_omega(self, t: float, q: quat.Quat) -> Vec:
        """Angular velocity of the scripted attitude: the tilt rate about tilt_axis plus the spin."""
        assert self.tilt_script is not None
        rate = math.radians(self.tilt_script.rate(t)[0])
        return add(scale(self._tilt_unit, rate), scale(quat.body_axis(q), self.params.spin))

    # --- stepping -------------------------------------------------------------------------------

    def _step_impl(self, t: float, dt: float, inputs: dict[str, Message | None]) -> dict[str, Message]:
        s = self.state
        start = s
        imp = inputs.get("impulse")
        self._answered = imp is not None  # a contact answers this step's end next (summary)
        if imp is not None:
            s = apply_impulse(self.body.mass, self.body.inertia, s, imp.linear.tolist(),  # type: ignore[attr-defined]
                              imp.angular.tolist(), imp.correction.tolist(), rotate=self.rotate)  # type: ignore[attr-defined]
        wrench = inputs.get("wrench")
        if wrench is None:
            forces = (self.weight, ZERO)
        else:
            f = wrench.force.tolist()  # type: ignore[attr-defined]
            w = self.weight
            forces = ((w[0] + f[0], w[1] + f[1], w[2] + f[2]), tuple(wrench.torque.tolist()))  # type: ignore[attr-defined]
        added = inputs.get("added_mass")
        if added is not self._added_seen:  # a new message (the latest is held: most steps it is not)
            problem = None if added is None else added.problem()  # type: ignore[attr-defined]
            if problem is not None:
                raise ValueError(f"input 'added_mass': {problem}")
            self._added_seen, self._added_active = added, added is not None and any(added.values())  # type: ignore[attr-defined]
            # the body turning with the water's moments added (AddedMass.with_inertia), once a message
            self._with_water = (dataclasses.replace(self.body, inertia=added.with_inertia(self.body.inertia))  # type: ignore[attr-defined]
                                if self._added_active else self.body)
        if self._added_active and self.velocity_script is not None:
            forces = (self._carried_under_script(added, s, forces[0], t, dt), forces[1])  # type: ignore[arg-type]
        elif self._added_active:
            # the water carried along: the force scaled along the axis and across it (AddedMass.carried)
            forces = (added.carried(self.body.mass, quat.body_axis(s.orientation), forces[0]), forces[1])  # type: ignore[attr-defined]
        s = self._integrated(s, forces, t, dt)
        end = _step_end(t, dt)
        if self.tilt_script is not None:
            q = quat.from_axis_angle(self.tilt_axis, math.radians(self.tilt_script.value(end)[0]))
            s = s._replace(orientation=q, angular_velocity=self._scripted_omega(end, q))
        if self.velocity_script is not None:
            x0, y0 = self.velocity_script.integral(t)
            x1, y1 = self.velocity_script.integral(end)
            vx, vy = self.velocity_script.value(end)
            pos, vel = s.position, s.velocity
            s = s._replace(position=(start.position[0] + (x1 - x0), start.position[1] + (y1 - y0), pos[2]),
                           velocity=(vx, vy, vel[2]))
        self.state = s
        return {"state": self.body_state()}

    def _carried_under_script(self, added: Any, s: RigidState, force: Vec, t: float, dt: float) -> Vec:
        """The force [N] that gives a body whose horizontal velocity is scripted, carrying the water
        ``added`` (AddedMass), its vertical acceleration: the script holds a_x and a_y (over the step,
        the change of its velocity over dt), so only the vertical row of (M + M_a) a = F is free,
        (M + M_a,zz) a_z = F_z - M_a,zx a_x - M_a,zy a_y, with M_a = radial + (axial - radial) n n^T.
        (The whole system solved as for a free body, then x and y overwritten, mixed the horizontal
        force into a_z: a disk tilted 45 deg carrying 5 M along its axis rose at 0.39 m/s after 0.1 s
        of a 1 N push the script held, and fell at 0.57 m/s where 0.28 is right.)"""
        n = quat.body_axis(s.orientation)
        (vx0, vy0), (vx1, vy1) = self.velocity_script.value(t), self.velocity_script.value(_step_end(t, dt))  # type: ignore[union-attr]
        ax, ay = (vx1 - vx0) / dt, (vy1 - vy0) / dt
        skew = added.axial - added.radial
        zz = added.radial + skew * n[2] * n[2]
        mass = self.body.mass
        az = (force[2] - skew * n[2] * (n[0] * ax + n[1] * ay)) / (mass + zz)
        return (force[0], force[1], mass * az)

    def _integrated(self, s: RigidState, forces: tuple[Vec, Vec], t: float, dt: float) -> RigidState:
        """``s`` integrated over ``dt`` [s] under ``forces`` (force, torque). RK4's turn per step is
        bounded (:meth:`max_stable_step`), which the scheduler judges on the state before the step; an
        impulse taken at the step's start can turn the body faster (a kick to 2000 rad/s took a 1 ms
        step whole, 2 rad in one step: its angular momentum 3.6% off): the step is then taken in the
        substeps that rate needs, judged as the scheduler judges them (:meth:`Component.restep`)."""
        if self._rk4_turning:
            rate = norm(s.angular_velocity)
            if rate * dt > RK4_MAX_ROTATION_PER_STEP:
                bound = RK4_MAX_ROTATION_PER_STEP / rate
                pieces = math.ceil(dt / bound)
                h = dt / pieces
                # (``dt`` may be one of the scheduler's substeps: the count said is the pieces taken)
                if self.restep(bound, step_taken=h) is not None:  # (None: driven by hand, taken as given)
                    for i in range(pieces):
                        s = self.integrate(self._with_water, s, forces, t + i * h, h, self.rotate)
                    return s
        return self.integrate(self._with_water, s, forces, t, dt, self.rotate)

    def body_state(self) -> BodyState:
        """The current state as a BodyState message (every field filled)."""
        body = self.body
        x, q, v, w = self.state
        if self.shape is Shape.DISK:
            n = quat.body_axis(q)
            attack = math.degrees(math.atan2(math.hypot(n[0], n[1]), abs(n[2])))
        else:
            attack = 0.0
        # the four vectors as views of one array: one array made a step instead of four
        packed = np.array((*x, *q, *v, *w), dtype=np.float64)
        return BodyState(
            packed[0:3], packed[3:7], packed[7:10], packed[10:13], self.shape, body.radius, body.thickness,
            body.mass, self._inertia, attack, norm(v),
            kinetic_energy(body.mass, body.inertia, self.state),
            potential_energy(body.mass, self.gravity, x), not self.rotate)

    def initial_outputs(self) -> dict[str, Message]:
        """What the body publishes at t = 0: its initial state."""
        return {"state": self.body_state()}

    # --- framework services ---------------------------------------------------------------------

    def get_state(self) -> dict[str, Any]:
        x, q, v, w = self.state
        return {"position": list(x), "orientation": list(q), "velocity": list(v), "angular_velocity": list(w)}

    def set_state(self, state: dict[str, Any]) -> None:
        q = tuple(float(c) for c in state["orientation"])
        w = as_vec(state["angular_velocity"])
        if self.params.lock_attitude and self.shape is Shape.DISK:
            # a held disk's turn is about its axis only (as at its start: _held_turn_problems); a free
            # disk's state restored held (a restart with --set lock_attitude=true) kept its wobble for
            # ever, the rim moving and the kinetic energy counting a turn the attitude never made
            along, across = _along_and_across(w, quat.body_axis(q))  # type: ignore[arg-type]
            if across > HELD_TURN_ACROSS * math.hypot(*w):
                raise ValueError(f"component {self.name!r} turns across its axis at {across:.4g} rad/s in this state "
                                 f"(about it at {along:.4g}), which a held disk (lock_attitude) never does; "
                                 "restart it with its attitude free, or run the scene held from t = 0")
        self.state = RigidState(as_vec(state["position"]), q, as_vec(state["velocity"]), w)  # type: ignore[arg-type]

    def max_stable_step(self) -> float:
        if not self._rk4_turning:
            return math.inf
        rate = norm(self.state.angular_velocity)
        return RK4_MAX_ROTATION_PER_STEP / rate if rate > 0 else math.inf

    def summary(self) -> list[str]:
        x, _, v, _ = self.state
        msg = self.body_state()
        # + 0.0: without gravity the potential energy is -0.0, which would print as "-0"
        # in a contact the state at a step's end is the one the contact answers at the next step's start
        # (a ground's impulse): a body resting on the ground has fallen for one step, g dt, there
        answer = " (its last step's end, before the contact's answer to it)" if self._answered else ""
        line = (f"{self.name}: at ({x[0]:.4g}, {x[1]:.4g}, {x[2]:.4g}) m, speed {norm(v):.4g} m/s, "
                f"kinetic {msg.kinetic_energy:.4g} J, potential {msg.potential_energy + 0.0:.4g} J{answer}")
        if self.params.spin != 0.0 and not self.params.lock_attitude:
            # a thrown stone's spin, which the water's friction takes away (a held attitude keeps it);
            # thrown at its spin at t = 0, about its axis then: ``spin`` plus what angular_velocity
            # adds along the axis, not ``spin`` alone
            start = self._initial_state()
            thrown = _about_axis(start.angular_velocity, start.orientation)
            now = _about_axis(msg.angular_velocity.tolist(), msg.orientation)
            line += f", spin {now / (2 * math.pi):.3g} rev/s (thrown at {thrown / (2 * math.pi):.3g})"
        return [line]


def _about_axis(omega, orientation) -> float:
    """The part [rad/s] of the angular velocity ``omega`` (3,) along the symmetry axis of a body at
    ``orientation`` (a unit quaternion (w, x, y, z))."""
    return sum(w * a for w, a in zip(omega, quat.body_axis(orientation), strict=True))


def gravity_mismatch(component: Component | None, size: float, key: str) -> str | None:
    """Why a component whose gravity is ``size`` [m/s^2] (its parameter ``key``) cannot serve the
    body ``component`` (a RigidBody: anything else is not judged): the body falls under another
    gravity, or not straight down; None when they agree."""
    gravity = getattr(getattr(component, "params", None), "gravity", None)
    if not isinstance(component, RigidBody) or gravity is None:
        return None
    gx, gy, gz = (float(g) for g in gravity)
    if gx == 0.0 and gy == 0.0 and math.isclose(-gz, size, rel_tol=1e-9, abs_tol=1e-12):
        return None
    if gx == 0.0 and gy == 0.0 and gz < 0.0:
        return (f"{key} {size:g} m/s^2 is not the gravity of its body {component.name} ({[gx, gy, gz]} m/s^2): "
                f"set {key} to {-gz:g}")
    return (f"{key} {size:g} m/s^2 needs its body {component.name} to fall straight down (along -z) under as "
            f"much gravity; its gravity is {[gx, gy, gz]} m/s^2")
