"""One contact resolution between a body and a plane, from the body's end-of-step state.

The exchange this serves (see :mod:`components.ground`): the body publishes its state at the end of
step k; the ground answers with an impulse and a position correction that the body applies at the
start of step k+1, to that very state. So the response is computed on the state it is applied to and
acts as if at the end of step k; the lag is only in *when* the contact was detected (somewhere inside
step k). The resolution makes up for that by reconstructing the step, along the normal, with the
normal acceleration a_n = g.n held:

1. tau in [0, dt], the time since the lowest point crossed the plane:
   gap - u_n tau + a_n tau^2 / 2 = 0 (tau = dt when it was already in contact at the step's start).
2. The normal velocity at the crossing, u_c = u_n - a_n tau, decides the regime:
   - *bounce* (-u_c above the bounce threshold, e > 0): the impact happened tau ago, with outgoing
     normal velocity -e u_c; the target normal velocity is what that leaves after tau of flight,
     -e u_c + a_n tau, and the correction J/M tau moves the centre onto the trajectory it would have
     followed since the impact. For a translating body this is the exact bounce: heights fall as e^2
     whatever the step. (The attitude's share of that tau is not corrected: an Impulse carries no
     rotation. Lifting the rim point itself out by translation instead would raise the centre further
     than the impulse did and, at every rim impact of a rocking disk, pump in potential energy that
     can exceed what the impact dissipates: a disk that never settles.)
   - *plastic* (slow arrival, resting, sliding): target normal velocity 0 and the lowest point put
     back on the plane. In resting contact tau = dt, so each step the impulse is M |a_n| dt (the
     normal force M |a_n|) and the correction |a_n| dt^2 / 2: no jitter. A point already separating
     is left to leave by itself (no correction).
   - No response adds energy: a bounce that would, its impulse's kinetic energy and its lift's
     potential energy together (Kane's paradox: a rim held by friction), is plastic instead, and a
     disk's rim point is lifted only as far as the energy its impulse took pays for, beyond what
     the body's integrator moved it into the plane past a velocity Verlet step (the ``overshoot``:
     semi-implicit Euler's step falls g dt^2, Verlet's g dt^2 / 2), which is that integrator's own
     error, lifted without being booked (point 4). What a rocking disk's rims leave in the plane so
     is lifted out once it rests on its face, and the potential energy the rim steps booked as
     dissipated is given back, booked as negative dissipation: the one response that adds energy,
     what the ground took before (a 6 mm disk settling from 70 deg at 0.5 ms steps sank 0.39 mm on
     its rims and gets 0.46 mJ back; it rests on the plane, and its books close).
3. The tangential correction is the friction impulse's own displacement: J_t/M * tau for an impact
   tau ago, J_t/M * tau * s for a force acting over the last tau, s the share of a step's velocity
   change that the body's integrator puts into that step's move (``position_share``: 1/2 for velocity
   Verlet and RK4, which move by v0 dt + a dt^2 / 2 under a force held over the step, 1 for
   semi-implicit Euler, which moves by its end velocity, v0 dt + a dt^2; the ground measures it on the
   body's states). A sticking body therefore ends each step where it began: no creep. (With 1/2 for
   every integrator a disk held by static friction on a 20 deg slope crept downhill at g sin 20 dt / 2
   under semi-implicit Euler, 1.7 mm in 2 s at 0.5 ms steps, while reported sticking.) The energy is
   booked at Verlet's share, as the normal fall's is (point 4): the rest is that integrator's own error.
4. The dissipated energy is the body's mechanical energy before minus after the response (impulse
   and correction), so kinetic + potential + dissipated stays constant to round-off when gravity is
   the only other force. Any other force on the body (buoyancy, drag: a coupler's wrench) is booked
   by its source as its work along every move of the body, the correction's jump included: the
   correction is charged against it too, F_other . c, or a body resting on a bed under water, lifted
   each step against its weight less its buoyancy, would be charged its buoyancy's share as negative
   dissipation (the ground's books fell by B |c| a step, 3.4e-6 J for a granite ball 6 cm across).
   The kinetic energy is differenced alone and the potential energy of the jump added as
   (M g + F_other) . c, exactly the same sum, so that a resting step, which dissipates nothing,
   books nothing but round-off of its own small kinetic energy (not of the potential energy's).
   What a plastic response's correction undoes of the integrator's own move beyond a velocity Verlet
   step (a resting face's or a rim point's extra fall under semi-implicit Euler, the tangential share
   of point 3) is not booked: that energy the integrator lost (M |dv|^2 / 2 a step, dv the step's
   velocity change), not the contact, and the correction gives it back.
5. Static or kinetic friction: a point that slid at the last response sticks only if mu_k can stop it
   (it is still sliding), unless its slip has turned round since (``slip_before``): then it stopped
   within the step, and from there static friction holds it. (Judged by mu_k, a disk pushed up a
   24 deg slope, tan 24 between mu_k = 0.4 and mu_s = 0.5, stopped within a step and then slid
   back down for ever at g (sin 24 - mu_k cos 24), as it did for some starting speeds and not
   others.)

The bounce threshold is raised to at least BOUNCE_STEPS |g| dt so a body resting on a plane never
bounces on the velocity it gains in one step.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from typing import NamedTuple

from components.contact.geometry import ContactGeometry, Plane, contact_geometry
from components.contact.impulse import NO_IMPULSE, ImpulseResult, contact_matrix, face_impulse, point_impulse
from components.messages import Shape
from components.rigid import quaternion as quat
from components.rigid.dynamics import RigidState, apply_impulse, kinetic_energy, potential_energy
from components.rigid.shapes import MassProperties
from components.rigid.vec import ZERO, Vec, cross, dot, norm

BOUNCE_STEPS = 4.0  # the bounce threshold is at least this many steps' worth of gravity [|g| dt]
ROCK_STEPS = 2.0  # a disk whose rims spread by at most this times |g| dt^2 lies flat (face_tolerance)
ROUND_OFF = 8.0 * sys.float_info.epsilon  # relative round-off of a response's energy terms, with margin


@dataclass(frozen=True)
class Material:
    """Contact properties of a ground plane.

    restitution: e (0..1); mu_static, mu_kinetic: Coulomb coefficients (mu_kinetic <= mu_static);
    bounce_threshold [m/s]: below this approach speed an impact is plastic (e = 0);
    face_tolerance [m]: a disk whose bottom rim heights spread by at most this lies flat (face contact).
    """

    restitution: float = 0.5
    mu_static: float = 0.5
    mu_kinetic: float = 0.4
    bounce_threshold: float = 0.02
    face_tolerance: float = 1e-5


class ContactResult(NamedTuple):
    """The ground's response to one body state (world frame).

    linear: (3,) impulse [N s]; angular: (3,) angular impulse about the centre of mass [N m s];
    correction: (3,) position correction [m]; normal, friction: impulse sizes [N s]; sliding: kinetic
    friction acted; bounced: the impact rebounded; face: face contact; painleve: friction dropped
    (no consistent sliding solution); tau: time since the contact began within the step [s];
    dissipated: mechanical energy removed by this response [J], the work of the body's other forces
    along the correction included (negative if it added energy); slip: (3,) unit direction of the
    contact point's tangential velocity before a sliding response (zero when it stuck).
    """

    linear: Vec
    angular: Vec
    correction: Vec
    normal: float
    friction: float
    sliding: bool
    bounced: bool
    face: bool
    painleve: bool
    tau: float
    dissipated: float
    slip: Vec = ZERO


def time_since_contact(gap: float, un: float, a_n: float, dt: float) -> float:
    """tau in [0, dt] [s]: how long ago a point now at height ``gap`` (<= 0) [m] with normal velocity
    ``un`` [m/s] under normal acceleration ``a_n`` [m/s^2] crossed the plane; dt if not in this step.

    Smallest tau >= 0 with gap - un tau + a_n tau^2 / 2 = 0 (the point's height tau earlier).
    """
    if gap >= 0.0:
        return 0.0
    a, b, c = 0.5 * a_n, -un, gap
    roots: tuple[float, ...] = ()
    if a == 0.0:
        if b != 0.0:
            roots = (-c / b,)
    else:
        disc = b * b - 4.0 * a * c
        if disc >= 0.0:
            q = -0.5 * (b + math.copysign(math.sqrt(disc), b))
            if q != 0.0:
                roots = (q / a, c / q)
    return min((r for r in roots if 0.0 <= r <= dt), default=dt)


def face_tolerance(material: Material, gravity: Vec, dt: float) -> float:
    """How far [m] a disk's bottom rim heights may spread for it to lie flat: the material's
    tolerance, or what one step's rocking leaves, ROCK_STEPS |g| dt^2, if more. A disk settling onto
    its face rocks from rim to rim; each plastic rim impact keeps -0.6 of its rate of tilt
    ((I - M R^2) / (I + M R^2) for a thin disk's I = M R^2 / 4) and each step's weight about the
    rim adds g dt / (1.25 R). At steps coarser than about 0.7 ms (at the default 10 um) that
    settles into a rock of one step each way, about 1 rad/s and a rim spread of 0.1 mm at 2.5 ms,
    that never ends (the disk reported moving at 3 g dt for ever); taken as lying flat, it rests."""
    return max(material.face_tolerance, ROCK_STEPS * norm(gravity) * dt * dt)


def mechanical_energy(body: MassProperties, state: RigidState, gravity: Vec) -> float:
    """Kinetic plus gravitational potential energy [J]."""
    kinetic = kinetic_energy(body.mass, body.inertia, state)
    return kinetic + potential_energy(body.mass, gravity, state.position)


def _impulse(body: MassProperties, state: RigidState, geometry: ContactGeometry, n: Vec, w: Vec, face: bool,
             target_un: float, tilt_restitution: float, mu_stick: float, mu_slide: float,
             rotate: bool) -> tuple[ImpulseResult, bool]:
    """The impulse reaching ``target_un`` [m/s] at the face centre (a face contact the face can hold)
    or at the lowest point, and whether it is a face contact."""
    v, axis = state.velocity, quat.body_axis(state.orientation)
    res: ImpulseResult | None = None
    r = geometry.r_ref if face else geometry.r_low
    if face:
        res = face_impulse(body.mass, body.inertia, axis, body.radius, r, v, w, n, target_un,
                           tilt_restitution, mu_stick, mu_slide)
        if res is None:  # the face cannot hold it: the lowest rim point takes the contact
            face, r = False, geometry.r_low
    if res is None:
        wr = cross(w, r)
        u = (v[0] + wr[0], v[1] + wr[1], v[2] + wr[2])
        k = contact_matrix(body.mass, body.inertia, axis, r, rotate)
        res = point_impulse(k, r, u, n, target_un, mu_stick, mu_slide)
    if not rotate and res is not NO_IMPULSE:
        res = res._replace(angular=ZERO)
    return res, face


def _round_off(k_before: float, k_after: float, force: float, position: Vec, jump: float) -> float:
    """How far [J] round-off alone can take a response's energy terms: the two kinetic energies [J],
    and a force of ``force`` [N] over a jump [m] of a body at ``position`` [m], whose coordinates
    carry their last bit (ulp(|x|) of each move is a rounding, worth |F| ulp(|x|))."""
    reach = max(abs(position[0]), abs(position[1]), abs(position[2])) + jump
    return ROUND_OFF * (k_before + k_after + force * reach)


def _kinetic_energy_after(body: MassProperties, state: RigidState, res: ImpulseResult, rotate: bool) -> float:
    """The kinetic energy [J] once the impulse ``res`` is applied to ``state``."""
    after = apply_impulse(body.mass, body.inertia, state, res.linear, res.angular, ZERO, rotate=rotate)
    return kinetic_energy(body.mass, body.inertia, after)


def _bounce_gains(body: MassProperties, state: RigidState, res: ImpulseResult, rotate: bool, k_before: float,
                  force: Vec, tau: float, position: Vec) -> bool:
    """Whether a bounce's response would add mechanical energy: its impulse's kinetic energy change
    plus its correction's, J tau / M, against gravity and the other forces (``force`` [N]).

    The correction lifts the centre onto the path it has followed since the impact, tau [s] ago:
    without friction its potential energy cancels the kinetic energy the impulse gives over the
    elastic bounce (J_n a_n tau), so the kinetic energy alone says nothing. With a rim point held by
    friction what is left is J_t . u_t / 2, which can be positive: judged on the kinetic energy alone,
    a tilted disk bouncing at e = 1 with mu 1 gained 0.47 mJ in one response (4.7 mJ over a drop)."""
    k_after = _kinetic_energy_after(body, state, res, rotate)
    s = tau / body.mass
    lift = s * dot(force, res.linear)  # the correction's work against the forces, (M g + F) . c
    jump = s * norm(res.linear)
    return k_after - lift - k_before > _round_off(k_before, k_after, norm(force), position, jump)


def _beyond_verlet(fall: float, un: float, dt: float, overshoot: Vec | None, n: Vec) -> float:
    """How far [m] a face resting on the plane through the step, now ``fall`` [m] into it and moving
    at ``un`` [m/s] along the normal ``n``, fell in this step beyond a velocity Verlet step's
    -u_n dt / 2: the ``overshoot`` (3,) [m] measured off the body's states, when known; else read off
    its speed, at most a semi-implicit Euler step's extra -u_n dt / 2 (a face sunk further came onto
    the plane so), and 0 where that is only the rounding of a Verlet step's own fall."""
    if overshoot is not None:
        return min(fall, max(0.0, -dot(overshoot, n)))
    beyond = min(fall + 0.5 * un * dt, -0.5 * un * dt)
    return beyond if beyond > 0.25 * fall else 0.0


def resolve_contact(body: MassProperties, state: RigidState, plane: Plane, material: Material,
                    gravity: Vec, dt: float, was_sliding: bool = False, rotate: bool = True,
                    geometry: ContactGeometry | None = None, other_force: Vec = ZERO,
                    slip_before: Vec = ZERO, position_share: float = 0.5,
                    overshoot: Vec | None = None) -> ContactResult | None:
    """The impulse, correction and dissipated energy for ``state`` against ``plane``; None if apart.

    ``dt`` [s] is the step that led to ``state``; ``was_sliding`` selects the coefficient deciding
    sticking (mu_kinetic after sliding, mu_static otherwise), and ``slip_before`` (3,) (the last
    response's ``slip``; zero when not known) turns it back to mu_static when the slip has turned
    round since (point 5 of the module docstring); ``position_share`` is the share of a step's
    velocity change its move holds (point 3); ``overshoot`` (3,) [m] is how far the body's integrator
    moved it over that step beyond a velocity Verlet step with the same velocity change (semi-implicit
    Euler: (v - v_begun) dt / 2, zero for velocity Verlet; None when not known), whose part into the
    plane a rim point's lift, and a resting face's, make up uncharged (point 2; a face's is read off
    its speed when not known); ``rotate`` false treats a body whose
    attitude is held (only its translation responds); ``other_force`` (3,) [N, world] is the force
    on the body besides gravity and contacts (a wrench), held over the step: the dissipated energy
    uses it (the correction's jump against it, point 4 of the module docstring), and so does the
    test of whether a bounce would add energy (its lift against it).
    """
    x, q, v, w = state
    if geometry is None:
        geometry = contact_geometry(body.shape, body.radius, body.thickness, x, q, plane,
                                    face_tolerance(material, gravity, dt))
    if geometry.gap > 0.0:
        return None
    n = plane.normal
    a_n = dot(gravity, n)
    face = geometry.face and rotate
    r = geometry.r_ref if face else geometry.r_low
    if not rotate:
        w = ZERO  # a held attitude has no point velocity from rotation
    wr = cross(w, r)
    u = (v[0] + wr[0], v[1] + wr[1], v[2] + wr[2])
    un = dot(u, n)
    tau = time_since_contact(geometry.gap, un, a_n, dt)
    u_cross = un - a_n * tau
    e = material.restitution
    bounced = False
    if e > 0.0 and -u_cross > max(material.bounce_threshold, BOUNCE_STEPS * norm(gravity) * dt):
        out = -e * u_cross
        bounced = out * tau + 0.5 * a_n * tau * tau >= 0.0
    target_un = out + a_n * tau if bounced else 0.0
    m, inertia = body.mass, body.inertia
    k_before = kinetic_energy(m, inertia, state)
    ut = (u[0] - un * n[0], u[1] - un * n[1], u[2] - un * n[2])
    still_sliding = was_sliding and dot(ut, slip_before) >= 0.0  # (a zero slip_before: not known, sliding)
    mu_stick = material.mu_kinetic if still_sliding else material.mu_static
    res, face = _impulse(body, state, geometry, n, w, face, target_un, e if bounced else 0.0, mu_stick,
                            material.mu_kinetic, rotate)
    f = other_force
    force = (m * gravity[0] + f[0], m * gravity[1] + f[1], m * gravity[2] + f[2])
    if bounced and _bounce_gains(body, state, res, rotate, k_before, force, tau, x):
        # Newton's restitution with Coulomb friction can create energy (Kane's paradox: a rim impact
        # whose friction keeps pushing after the normal impulse has reversed the slip); where it
        # would, the impact is plastic instead (its target normal velocity 0)
        bounced, target_un = False, 0.0
        res, face = _impulse(body, state, geometry, n, w, geometry.face and rotate, target_un, 0.0, mu_stick,
                                material.mu_kinetic, rotate)
    j = res.linear
    jn = dot(j, n)
    resting_fall = None
    integrators_fall = 0.0  # [m] of a rim point's lift, the integrator's own fall (not booked)
    if bounced:  # the centre has moved with the whole impulse since the impact, tau ago
        s = tau / m
        correction = (s * j[0], s * j[1], s * j[2])
    else:  # normal: back onto the plane (unless leaving); tangential: the friction force's own share
        s = position_share * tau / m
        c_n = -geometry.gap if un <= 0.0 else 0.0
        # lifted by its whole fall, a face or a sphere in contact through the whole step (see below)
        whole = face or not rotate or body.shape is Shape.SPHERE
        resting_fall = c_n if whole and tau == dt and c_n > 0.0 else None
        c_t = (s * (j[0] - jn * n[0]), s * (j[1] - jn * n[1]), s * (j[2] - jn * n[2]))
        press = -dot(force, n)  # [N] how hard the forces press the body onto the plane
        if c_n > 0.0 and press > 0.0 and (face or not whole):
            # On a rim point the lift may cost at most the energy the impulse took: a disk resting on
            # its rim sinks by its whole fall in a step while the impulse, turning it, takes only a
            # share of its speed (1 / (M K_nn), a fifth for a flat disk); lifted by the whole fall it
            # would gain energy every step. What is left of the penetration is taken up at the next
            # steps. A face takes the whole speed, and lying still its lift costs just that; but a
            # disk still rocking when it comes within the face's tolerance is lifted by its lowest
            # rim point's penetration, more than its centre fell (a tilted disk settling at 2 ms
            # steps gained 1.8 uJ so), and is held to the same cap. (A sphere keeps its whole lift.)
            # Of the fall, what the integrator moved the body into the plane beyond a velocity Verlet
            # step is its own error (a semi-implicit Euler step falls g dt^2, twice Verlet's, losing
            # M (g dt)^2 / 2): lifted uncharged, as a resting face's is (below). Left to the
            # energy cap, a disk rolling on its rim under that integrator sank g dt^2 / 2 a step
            # (1.4 mm in 0.5 s at 0.5 ms) and lost that energy (3%), the ground booking nothing.
            own_fall = 0.0 if overshoot is None else min(c_n, max(0.0, -dot(overshoot, n)))
            if not whole:  # (a face's own fall is booked with its resting fall, below)
                integrators_fall = own_fall
            elif resting_fall is not None and resting_fall + 0.5 * un * dt > 0.25 * resting_fall:
                # a resting face is lifted by its whole fall beyond a Verlet step's: the integrator's
                # own (booked below), or what rocking on its rim left of its falls in the plane, each
                # lift there capped at its impulse's energy: put back on the plane, the potential
                # energy those steps booked as dissipated is given back, and booked so (below)
                own_fall = min(c_n, max(own_fall, resting_fall + 0.5 * un * dt))
            k_impulse = _kinetic_energy_after(body, state, res, rotate)
            # (the tangential correction's work at Verlet's share, as it is booked below)
            spare = k_before - k_impulse + dot(force, c_t) * (0.5 / position_share)
            if press * (c_n - own_fall) - spare > _round_off(k_before, k_impulse, press, x, c_n):
                c_n = own_fall + max(0.0, spare) / press
                if resting_fall is not None:
                    resting_fall = c_n
        correction = (c_n * n[0] + c_t[0], c_n * n[1] + c_t[1], c_n * n[2] + c_t[2])
    after = apply_impulse(m, inertia, state, j, res.angular, correction, rotate=rotate)
    # mechanical energy before minus after, plus F_other . c; the potential energy's change is linear
    # in the jump, -M g . c, so it is added as such (point 4 of the module docstring)
    k_after = kinetic_energy(m, inertia, after)
    dissipated = k_before - k_after + dot(force, correction)
    if not bounced and position_share != 0.5:
        # the tangential correction beyond Verlet's share undoes the integrator's own move (point 3)
        dissipated -= (position_share - 0.5) / position_share * dot(force, c_t)
    if integrators_fall > 0.0:
        dissipated -= dot(force, n) * integrators_fall
    if resting_fall is not None:
        # A body at rest on the plane through the step (put there at rest by the last response) falls
        # -u_n dt / 2 in a velocity Verlet step, whatever the forces held over it; a semi-implicit Euler
        # step falls -u_n dt, twice that. The lift's share beyond the Verlet fall is that integrator's
        # own error, not energy the contact exchanged: charged for it, the ground booked
        # -M (a_n dt)^2 / 2 a step for a body lying still (3.06 mJ/s for a 127 g disk, without end).
        # Only this step's own: a disk that rocked on its rim comes onto its face already sunk by what
        # its capped lifts left (0.39 mm for a 6 mm disk at 0.5 ms steps), which is no fall of this
        # step; taken for one, its lift was booked as the integrator's error, and kinetic + potential
        # + dissipated rose by its potential energy (0.46 mJ, as the disk gained 0.46 of its 3.3 mJ)
        beyond = _beyond_verlet(resting_fall, un, dt, overshoot, n)
        if beyond > 0.0:
            dissipated -= dot(force, n) * beyond
    if dissipated < 0.0:
        # A resting step dissipates nothing: what is left is round-off, of the kinetic energies and of
        # the positions (the step's fall and the correction's jump are rounded to the last bit of the
        # coordinates, worth |F| ulp(|x|) in energy). Booked, it would make the cumulative dissipation
        # fall by a bit or two now and then; a response cannot dissipate a negative amount that small.
        if -dissipated <= _round_off(k_before, k_after, norm(force), x, norm(correction)):
            dissipated = 0.0
    slip = ZERO
    if res.sliding and (size := norm(ut)) > 0.0:
        slip = (ut[0] / size, ut[1] / size, ut[2] / size)
    return ContactResult(j, res.angular, correction, res.normal, res.friction, res.sliding, bounced, face,
                         res.painleve, tau, dissipated, slip)
