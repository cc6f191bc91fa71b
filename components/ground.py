"""SolidGround: a rigid plane of any slope with restitution and static/kinetic Coulomb friction.

Ports:
- ``body`` (BodyState, required): the body's state at the end of its step (a direct edge
  ``stone.state -> ground.body``, so the ground runs after the body within a tick);
- ``impulse`` (Impulse, out): published only while in contact; the body applies it once at the start
  of its next step (a ``delay: 1`` edge into the body's event port ``impulse``);
- ``contact`` (GroundContact, out): every step; normal and friction forces are this step's impulses
  divided by dt, ``dissipated_energy`` is cumulative.

Scene wiring::

    connections:
      - stone.state -> ground.body
      - {from: ground.impulse, to: stone.impulse, delay: 1,
         initial: {linear: [0, 0, 0], angular: [0, 0, 0], correction: [0, 0, 0]}}

Why impulses and not penalty forces: a stiff spring needs a step far below the body's, while an
impulse computed on the very state it is applied to (the body publishes state S_k at the end of step
k; the response reaches it at the start of step k+1, still in state S_k) is stable at any step and
exact for bounces (see :mod:`components.contact.solver` for the reconstruction of the step). It is
accurate while a step moves the body by little of its size: a step in which the body, resting,
falls through more than half its height is refused when the scene loads (:meth:`SolidGround.check_step`).
Resting contact is a sequence of small impulses balancing gravity, with a position correction
removing the step's penetration; sticking cancels the tangential drift the same way (no creep). A disk
lying flat is one face contact, not a rocking pair of rim points.

Energy books: a correction moves the body without a force, so its energy is booked against the
forces the body is under: gravity, and any other force (the buoyancy and drag of a water coupler,
which books its own work along every move of the body, the correction's jump included). The ground
is not wired to that wrench; it reads the force off the body's states instead: the body's velocity
at the end of a step less the velocity it began it with (the last state plus this ground's impulse)
is dt/M times the whole held force, gravity and wrench together (exact for every integrator the
body has: each holds the force over its step). That is the force of the step that led to the state
being answered; the body will move under the next step's. So the books close to the sum of the
force's change over one step times the correction, |W_k - W_(k-1)| |c_k|: nothing for a body resting
under water (and its dissipation is then 0 J a step, as it must be), 9.0e-5 J over the three bounces
of scenarios/float_sphere.yaml's granite ball, whose drag changes fast as it lands (the water told of
the ground's answer turns to resisting the rebound at once) and whose underside,
pressed into the bed, leaves the water. The first step begins at the body's state at t = 0
(:meth:`SolidGround.start_inputs`); only after a restart from an older checkpoint, with no step seen
before, is gravity alone assumed, as on a dry floor.

The force so read includes the water the body carries along (its added mass, by which the body
scales the held force): the other side of these books is the work of the held forces along the
body's move, which must not count the velocity change of this ground's impulse, applied at the
start of the body's step. A coupler not told of this ground's answer (its input ``ground``) books
the added mass from the body's published velocities across that step, counting M_a (J/M) . dx / dt
as the water's work; told, it takes the step from the velocity the impulse leaves (the torque's
work likewise from the angular velocity), and meets the water with that state (docs/validation.md,
section 7, says what the books still miss when a body carrying water strikes the bed). Under
semi-implicit Euler each step of the body loses M |dv|^2 / 2 (dv the step's velocity change) that no
component books: the integrator's own error, whose share along the normal a plastic correction gives
back unbooked (components.contact.solver, point 4).

Assumptions: the ground steps at the body's rate (same ``every``, checked as the scene loads), since
dt is read as the body's step; one plane per SolidGround (a floor and a ramp are two grounds feeding
the same impulse port, which sums them; while both hold the body, each reads the other's impulse as part of the held
force, and neither's books are exact then). Two planes that hold a body at once (a V, a corner) are
not solved together: each cancels the whole approach it sees, the body takes both impulses and
leaves both planes at the next step, so it chatters on and off them, and each ground reports a
force on alternate steps (a sphere resting in a 30 deg V: 0.94 N every other step from each plane,
where a steady hold is M g / (2 cos 30 deg) = 0.51 N at every step); ``gravity`` must match the body's (it is the
acceleration the ground reconstructs the step with and books the potential energy of its
corrections against; a RigidBody's is checked when the scene loads, any other body's at the first
contact, from its published potential energy). A body whose attitude is locked or scripted says so in its state
(``BodyState.attitude_locked``) and gets no angular response.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from components.contact.geometry import slope_plane
from components.contact.solver import Material, resolve_contact
from components.messages import BodyState, GroundContact, Impulse, Shape
from components.rigid.dynamics import RigidState
from components.rigid.shapes import MassProperties
from components.rigid.vec import as_vec
from components.rigid_body import POSITION_MAX, RigidBody
from cosim.component import Component, Port
from cosim.messages import Message
from cosim.params import param, require_valid

GRAVITY_MISMATCH = 1e-9  # relative potential-energy difference that reveals another gravity field
_NO_CHANGE = (0.0, 0.0, 0.0)  # [m/s] the velocity change of a step answered with no impulse
RESTING_SPEED = 1e-9  # [m/s] a body the last answer leaves slower than this is said to rest on the ground

Vec3Param = tuple[float, float, float]
# (the `noqa: RUF009` below: param() returns a dataclasses.field with an immutable default)


@dataclass(frozen=True)
class SolidGroundParams:
    """Parameters of a SolidGround plane (SI units; angles in degrees)."""

    point: Vec3Param = param((0.0, 0.0, 0.0), unit="m", doc="a point of the plane (a bottom: [0, 0, -depth]; "
                             "each coordinate within 1000 km of 0)")
    slope_deg: float = param(0.0, unit="deg", ge=0, lt=90, doc="angle of the plane from horizontal")
    downhill_deg: float = param(0.0, unit="deg", doc="azimuth of the downhill direction, from +x towards +y")
    restitution: float = param(0.5, ge=0, le=1, doc="normal coefficient of restitution e")
    mu_static: float = param(0.5, ge=0, doc="static friction coefficient")
    mu_kinetic: float = param(0.4, ge=0, doc="kinetic friction coefficient (<= mu_static)")
    bounce_threshold: float = param(0.02, unit="m/s", ge=0,
                                    doc="slower impacts are plastic (raised to at least 4 |g| dt)")
    face_tolerance: float = param(1e-5, unit="m", ge=0,
                                  doc="a disk whose bottom rim heights spread by at most this lies flat "
                                      "(raised to at least 2 |g| dt^2)")
    gravity: Vec3Param = param((0.0, 0.0, -9.81), unit="m/s^2", doc="must match the body's gravity")

    def check(self) -> list[tuple[str, str]]:
        problems = []
        if self.mu_kinetic > self.mu_static:
            problems.append(("mu_kinetic", f"must be <= mu_static ({self.mu_static:g}) (got {self.mu_kinetic:g})"))
        if not all(abs(x) <= POSITION_MAX for x in self.point):  # (1e308 overflowed the plane's arithmetic)
            problems.append(("point", f"must lie within {POSITION_MAX / 1e3:g} km of the origin in each coordinate, "
                                      f"as a body may (got {list(self.point)!r})"))
        return problems


class SolidGround(Component):
    """A plane with restitution and Coulomb friction, answering body states with contact impulses."""

    Params = SolidGroundParams
    inputs = {"body": Port(BodyState, "the body's state at the end of its step", required=True)}
    outputs = {
        "impulse": Port(Impulse, "contact impulse and position correction (only while in contact)"),
        "contact": Port(GroundContact, "forces, friction regime and cumulative dissipated energy"),
    }

    def setup(self) -> None:
        p: SolidGroundParams = self.params
        require_valid(p)  # (built in code, a restitution of 2 was taken)
        self.plane = slope_plane(as_vec(p.point), p.slope_deg, p.downhill_deg)
        self.material = Material(p.restitution, p.mu_static, p.mu_kinetic, p.bounce_threshold,
                                 p.face_tolerance)
        self.gravity = as_vec(p.gravity)
        self.dissipated = 0.0
        self.sliding = False
        self.in_contact = False
        self.impacts = 0
        self.contacts: int | None = 0  # spells in contact, as plot counts them (None: from an older checkpoint)
        self.painleve = 0
        self._body_key: tuple | None = None
        self._body: MassProperties | None = None
        self._gravity_checked = False
        # the velocity [m/s] the body begins its next step with: that of the last state answered (a
        # (3,) array, read only when needed) plus this ground's impulse / M (0 when none was sent)
        self._begins: tuple[np.ndarray, Vec3Param] | None = None
        # and the position [m] it begins it from: the last state's plus this ground's correction
        self._begins_from: tuple[np.ndarray, Vec3Param] | None = None
        self._slip: Vec3Param = _NO_CHANGE  # the slip the last sliding response acted against (unit)
        # for the viewer (visuals) only: the rectangle of the plane's own axes its body's path has
        # covered, ((a_min, b_min), (a_max, b_max)) [m]
        self._drawn_over: tuple[tuple[float, float], tuple[float, float]] | None = None

    def _mass_properties(self, msg: BodyState) -> MassProperties:
        key = (int(msg.shape), msg.radius, msg.thickness, msg.mass, tuple(msg.inertia.tolist()))
        if key != self._body_key:
            self._body = MassProperties(Shape(msg.shape), msg.radius, msg.thickness, msg.mass,
                                        key[4])  # type: ignore[arg-type]
            self._body_key = key
        return self._body  # type: ignore[return-value]

    def _check_gravity(self, msg: BodyState, x: tuple[float, float, float]) -> None:
        """Fail early when the body falls in another gravity field than the ground assumes: its
        published potential energy -M g.x tells (checked once, where the position makes it tell)."""
        g = self.gravity
        scale = msg.mass * math.hypot(*g) * math.hypot(*x)
        if scale == 0.0:
            return
        expected = -msg.mass * (g[0] * x[0] + g[1] * x[1] + g[2] * x[2])
        if abs(expected - msg.potential_energy) > GRAVITY_MISMATCH * scale:
            raise ValueError(
                f"gravity {list(g)} m/s^2 does not match the body's: its potential energy "
                f"{msg.potential_energy:.6g} J at {[round(c, 6) for c in x]} m would be {expected:.6g} J; "
                "give the ground the body's gravity")
        self._gravity_checked = True

    def _apart(self, msg: BodyState | None = None) -> dict[str, Message]:
        self.in_contact = False
        self.sliding = False
        self._slip = _NO_CHANGE
        self._begins = None if msg is None else (msg.velocity, _NO_CHANGE)
        self._begins_from = None if msg is None else (msg.position, _NO_CHANGE)
        return {"contact": GroundContact(False, 0.0, 0.0, False, self.dissipated)}

    def _begun_with(self) -> Vec3Param | None:
        """The velocity [m/s] the body began the step that just ended with; None when not known."""
        if self._begins is None:
            return None
        v, dv = self._begins
        v0, v1, v2 = v.tolist()
        return (v0 + dv[0], v1 + dv[1], v2 + dv[2])

    def _position_share(self, position: Vec3Param, begun: Vec3Param | None, dv: Vec3Param | None,
                        dt: float) -> float:
        """The share of the step's velocity change ``dv`` [m/s] (from ``begun``, the velocity the step
        began with; None when not known) that the body's integrator put into its move
        (components.contact.solver, point 3): (dx - v_begun dt) . dv / (|dv|^2 dt), 1/2 for velocity
        Verlet and RK4, 1 for semi-implicit Euler under a force held over the step; 1/2 when the
        step's start is not known or the velocity did not change. Read to within 1e-6 of 1/2 or 1 it
        is taken as that (round-off), and it is kept within [1/2, 1]."""
        if begun is None or dv is None or self._begins_from is None or not dt > 0.0:
            return 0.5
        start = self._begun_from()
        held = [position[i] - start[i] - begun[i] * dt for i in range(3)]
        change = sum(d * d for d in dv)
        if not change > 0.0:
            return 0.5
        share = sum(h * d for h, d in zip(held, dv, strict=True)) / (change * dt)
        for exact in (0.5, 1.0):
            if abs(share - exact) <= 1e-6:
                return exact
        return min(1.0, max(0.5, share))

    @staticmethod
    def _overshoot(share: float, dv: Vec3Param | None, dt: float) -> Vec3Param | None:
        """How far [m] the body's integrator moved it over the step whose velocity change was ``dv``
        [m/s] beyond a velocity Verlet step with the same change: (share - 1/2) dv dt (dv dt / 2 for
        semi-implicit Euler, nothing for Verlet and RK4, whose share is read as exactly 1/2; None when
        the step's start is not known)."""
        if dv is None:
            return None
        if share == 0.5:
            return (0.0, 0.0, 0.0)
        k = (share - 0.5) * dt
        return (k * dv[0], k * dv[1], k * dv[2])

    def _other_force(self, mass: float, dv: Vec3Param | None, dt: float) -> Vec3Param:
        """The force [N] on the body besides gravity and this ground over the step whose velocity change
        was ``dv`` [m/s]: M dv / dt - M g (zero when the step's start is not known)."""
        if dv is None or not dt > 0.0:
            return (0.0, 0.0, 0.0)
        k, g = mass / dt, self.gravity
        return (k * dv[0] - mass * g[0], k * dv[1] - mass * g[1], k * dv[2] - mass * g[2])

    def _step_impl(self, t: float, dt: float, inputs: dict[str, Message | None]) -> dict[str, Message]:
        msg = inputs.get("body")
        if msg is None:
            return self._apart()
        assert isinstance(msg, BodyState)
        x = tuple(msg.position.tolist())
        reach = self._mass_properties(msg).bounding_radius
        if self.plane.height(x) > reach:  # the bounding sphere is clear: no contact possible
            return self._apart(msg)
        if not self._gravity_checked:
            self._check_gravity(msg, x)
        v = tuple(msg.velocity.tolist())
        state = RigidState(x, tuple(msg.orientation.tolist()), v,  # type: ignore[arg-type]
                           tuple(msg.angular_velocity.tolist()))
        body = self._mass_properties(msg)
        # the step that led here: the velocity it began with and its change (None when not known)
        begun = self._begun_with()
        dv = None if begun is None else (v[0] - begun[0], v[1] - begun[1], v[2] - begun[2])
        share = self._position_share(x, begun, dv, dt)  # type: ignore[arg-type]
        res = resolve_contact(body, state, self.plane, self.material, self.gravity, dt, self.sliding,
                              not msg.attitude_locked, other_force=self._other_force(body.mass, dv, dt),
                              slip_before=self._slip, position_share=share,
                              overshoot=self._overshoot(share, dv, dt))  # type: ignore[arg-type]
        if res is None:
            return self._apart(msg)
        inv_m = 1.0 / body.mass
        self._begins = (msg.velocity, (res.linear[0] * inv_m, res.linear[1] * inv_m, res.linear[2] * inv_m))
        self._begins_from = (msg.position, res.correction)
        self._slip = res.slip
        if not self.in_contact and self.contacts is not None:
            self.contacts += 1
        self.in_contact = True
        self.sliding = res.sliding
        self.impacts += res.bounced
        self.painleve += res.painleve
        self.dissipated += res.dissipated
        return {
            "impulse": Impulse(np.array(res.linear), np.array(res.angular), np.array(res.correction)),
            "contact": GroundContact(True, res.normal / dt, res.friction / dt, res.sliding, self.dissipated),
        }

    def visuals(self, port: str, msg: Message) -> list[Any]:
        """The plane, drawn as a slab under it (:func:`components.visuals.ground_slab`) over the path
        its body has taken so far, GROUND_MARGIN and the body's radius beyond it on every side: a plane
        has no edge of its own, and two grounds side by side (a floor and a ramp) stay apart where
        their bodies are. Viewer items only: the physics never reads it."""
        if port != "contact" or self._begins_from is None or self._body is None:
            return []
        from components.visuals import GROUND_MARGIN, ground_slab, plane_axes

        normal, point = self.plane.normal, self.plane.point
        axes = plane_axes(normal)
        _, u, w = axes
        # (the body's last state: where its next step begins, less this ground's correction)
        offset = np.asarray(self._begins_from[0], dtype=float) - np.asarray(point, dtype=float)
        a, b = float(offset @ u), float(offset @ w)
        box = self._drawn_over
        self._drawn_over = box = ((a, b), (a, b)) if box is None else (
            (min(box[0][0], a), min(box[0][1], b)), (max(box[1][0], a), max(box[1][1], b)))
        reach = GROUND_MARGIN + self._body.bounding_radius
        (a0, b0), (a1, b1) = box
        return ground_slab(self.name, normal, point, axes, (a0 - reach, b0 - reach), (a1 + reach, b1 + reach))

    def start_inputs(self, inputs: dict[str, Message | None]) -> None:
        """The body's state at t = 0 is where its first step begins (no impulse reaches it before), so
        the first answer reconstructs that step as every later one does (the other forces, the share of
        the move, the integrator's overshoot) instead of assuming gravity alone: a disk set rolling on
        its rim under semi-implicit Euler kept the first step's overshoot, M (g dt)^2 / 2 of energy
        lost and g dt^2 / 2 of sinking, for ever."""
        msg = inputs.get("body")
        if isinstance(msg, BodyState):
            self._begins = (msg.velocity, _NO_CHANGE)
            self._begins_from = (msg.position, _NO_CHANGE)

    def check_start(self, inputs: dict[str, Message | None]) -> list[str]:
        """A body that starts inside the ground by more than its own size is a mistake in the scene
        (a contact would throw it out with an enormous impulse, or never resolve)."""
        msg = inputs.get("body")
        if not isinstance(msg, BodyState):
            return []
        x = tuple(msg.position.tolist())
        reach = self._mass_properties(msg).bounding_radius
        depth = reach - self.plane.height(x)  # of the bounding sphere's lowest point below the plane
        if depth > 2.0 * reach:
            return [f"the body starts {-self.plane.height(x):.4g} m inside the ground (its centre at "
                    f"{[round(c, 6) for c in x]} m, {self.plane.height(x):.4g} m from the plane through "
                    f"{list(self.plane.point)} m); start it above the ground"]
        return []

    def answers(self) -> dict[str, str]:
        """The impulse goes back to the body whose state it reads, once for each state (the scene is
        refused unless the two step at one rate)."""
        return {"impulse": "body"}

    def check_start_sources(self, inputs: dict[str, Message | None], sources: dict[str, Component]) -> list[str]:
        """Its gravity must be its body's (it reconstructs the body's step with it, and books the
        energy of its corrections against it): a RigidBody feeding it with another is refused at load.
        It was found at the first contact, failing the run there."""
        body = sources.get("body")
        theirs = getattr(getattr(body, "params", None), "gravity", None)
        if not isinstance(body, RigidBody) or theirs is None:
            return []
        mine = [float(g) for g in self.params.gravity]
        theirs = [float(g) for g in theirs]
        if all(math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12) for a, b in zip(mine, theirs, strict=True)):
            return []
        return [f"gravity {mine} m/s^2 is not the gravity of its body {body.name} ({theirs} m/s^2): set gravity to "
                f"{theirs}"]

    def check_step(self, step: float, inputs: dict[str, Message | None]) -> list[str]:
        """A step in which the body, resting, falls through more than half its height is refused: the
        ground answers once per body step, on the state the step ended in, so the body would end every
        step that deep inside the plane and a disk's rim contacts would go wrong (a tilted disk
        dropped at 50 ms steps slid 1 m and never settled). No substepping of the ground helps, only a
        shorter step of the pair. Height: a disk's thickness, a sphere's diameter."""
        msg = inputs.get("body")
        g = math.hypot(*self.gravity)
        if not isinstance(msg, BodyState) or g == 0.0:
            return []
        body = self._mass_properties(msg)
        height = 2.0 * body.radius if body.shape is Shape.SPHERE else body.thickness
        fall = 0.5 * g * step * step  # [m] in one step from rest
        if fall > 0.5 * height:
            return [f"its step {step:.6g} s lets the body fall {fall * 1e3:.3g} mm in one step from rest, more "
                    f"than half its height ({height * 1e3:.3g} mm); use a base step or 'every' giving at "
                    f"most {math.sqrt(height / g):.3g} s"]
        return []

    def initial_outputs(self) -> dict[str, Message]:
        """At t = 0: no impulse yet, not in contact."""
        return {"impulse": Impulse.zero(), "contact": GroundContact(False, 0.0, 0.0, False, 0.0)}

    def get_state(self) -> dict[str, Any]:
        begun = self._begun_with()
        return {"dissipated_energy": self.dissipated, "sliding": self.sliding, "in_contact": self.in_contact,
                "impacts": self.impacts, "contacts": self.contacts, "painleve": self.painleve,
                "next_step_begins_at": None if begun is None else list(begun),
                "next_step_begins_from": None if self._begins_from is None else self._begun_from(),
                "slip": list(self._slip)}

    def _begun_from(self) -> list[float]:
        """The position [m] the body began the step that just ended from (the last state's plus this
        ground's correction)."""
        assert self._begins_from is not None
        x, c = self._begins_from
        return [a + b for a, b in zip(x.tolist(), c, strict=True)]

    def set_state(self, state: dict[str, Any]) -> None:
        self.dissipated = float(state["dissipated_energy"])
        self.sliding = bool(state["sliding"])
        self.in_contact = bool(state["in_contact"])
        self.impacts = int(state["impacts"])
        contacts = state.get("contacts")  # (absent from older checkpoints: not known then)
        self.contacts = None if contacts is None else int(contacts)
        self.painleve = int(state["painleve"])
        begun = state.get("next_step_begins_at")  # (absent from older checkpoints: gravity alone then)
        self._begins = None if begun is None else (np.array(begun, dtype=np.float64), _NO_CHANGE)
        # (absent from older checkpoints: the step's share of a velocity change taken as Verlet's, and
        # a slip not known)
        begun_from = state.get("next_step_begins_from")
        self._begins_from = None if begun_from is None else (np.array(begun_from, dtype=np.float64), _NO_CHANGE)
        self._slip = tuple(float(c) for c in state.get("slip", _NO_CHANGE))

    def summary(self) -> list[str]:
        bounces = "1 bounce" if self.impacts == 1 else f"{self.impacts} bounces"
        if self.contacts is not None:
            # a contact (a spell of touching, what plot counts) may end without a bounce (a slow, plastic
            # touchdown) or hold several (a rocking disk's rim impacts)
            bounces += f" in {self.contacts} contact" + ("" if self.contacts == 1 else "s")
        contact = ""
        if self.in_contact:
            begun = self._begun_with()  # the velocity the body begins its next step with, answered
            if begun is None:  # (a restart from an older checkpoint, before its first step)
                contact = ", body in contact"
            elif (after := math.hypot(*begun)) <= RESTING_SPEED:
                contact = ", body at rest on it"
            else:
                contact = f", body in contact, moving at {after:.4g} m/s once answered"
        lines = [f"{self.name}: {bounces}, {self.dissipated:.4g} J dissipated{contact}"]
        if self.painleve:
            lines.append(f"{self.name}: friction dropped in {self.painleve} impulses (Painlevé: "
                         f"mu_kinetic {self.params.mu_kinetic:g} above the consistent bound)")
        return lines
