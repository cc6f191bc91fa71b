"""A disk lying flat that slides and spins at once: Coulomb's law at every point of a uniformly
pressed face couples the force and the torque (Contensou 1963; Farkas, Bartels, Unger & Wolf,
PRL 90, 248302, 2003), so each is smaller than alone and both motions stop together
(components.contact.impulse.contensou and face_impulse, and a SolidGround scene).

With eps = v / (omega R) the face's friction is f mu N against the slip and m mu N R against the
spin, the integrals of contensou's docstring; their closed forms, in the complete elliptic integrals
K and E of modulus k (scipy: parameter k^2), are

    eps <= 1:  f = 4/(3 pi) [(1 + eps^2) E(eps) - (1 - eps^2) K(eps)] / eps
               m = 4/(9 pi) [(4 - 2 eps^2) E(eps) - (1 - eps^2) K(eps)]
    eps >= 1:  f = 4/(3 pi) [(1 + eps^2) E(1/eps) - (eps^2 - 1) K(1/eps)]
               m = 4/(9 pi) [(4 eps - 2 eps^3) E(1/eps) + (2 eps^2 - 3) (eps^2 - 1) / eps K(1/eps)]

(f = 8/(3 pi), m = 8/(9 pi) at eps = 1), checked here against an independent integration.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import ellipe, ellipk

from components.contact.impulse import TORSION_ARM, contensou, face_impulse
from components.messages import Shape
from components.rigid.shapes import mass_properties
from cosim.scenario import loads
from cosim.scheduler import Simulation
from tests.ground_toys import disk_on_plane
from tests.toys import Channels

G = 9.81
MU = 0.4
R = 0.05
E = 0.006
DT = 0.0005
N = (0.0, 0.0, 1.0)
DISK = mass_properties(Shape.DISK, R, E, density=2700.0)
RATIOS = [0.01, 0.03, 0.1, 0.3, 0.7, 1.0, 1.5, 3.0, 10.0, 30.0, 100.0]


def exact(eps: float) -> tuple[float, float]:
    """(f, m) of a uniformly pressed face at eps = v / (omega R) > 0, in closed form."""
    if eps == 1.0:
        return 8.0 / (3.0 * math.pi), 8.0 / (9.0 * math.pi)
    e2 = eps * eps
    if eps < 1.0:
        k, e = ellipk(e2), ellipe(e2)
        return (4.0 / (3.0 * math.pi) * ((1.0 + e2) * e - (1.0 - e2) * k) / eps,
                4.0 / (9.0 * math.pi) * ((4.0 - 2.0 * e2) * e - (1.0 - e2) * k))
    k, e = ellipk(1.0 / e2), ellipe(1.0 / e2)
    return (4.0 / (3.0 * math.pi) * ((1.0 + e2) * e - (e2 - 1.0) * k),
            4.0 / (9.0 * math.pi) * ((4.0 * eps - 2.0 * eps * e2) * e + (2.0 * e2 - 3.0) * (e2 - 1.0) / eps * k))


def reference(eps: float) -> tuple[float, float]:
    """(f, m) by adaptive integration about the slip's centre of rotation c = (0, eps) [radii], where
    the traction's direction is (-sin phi, cos phi) on the ray at angle phi, so the integral along
    each ray is exact: a ray leaves the face at s = -eps sin phi +- sqrt(1 - eps^2 cos^2 phi)."""
    def ends(phi):
        root = math.sqrt(max(0.0, 1.0 - eps * eps * math.cos(phi) ** 2))
        far = -eps * math.sin(phi) + root
        return (0.0 if eps < 1.0 else -eps * math.sin(phi) - root), far

    def f_ray(phi):
        near, far = ends(phi)
        return -math.sin(phi) * (far * far - near * near) / 2.0

    def m_ray(phi):  # (rho x t).n with rho = c + s (cos phi, sin phi): eps sin phi + s
        near, far = ends(phi)
        return eps * math.sin(phi) * (far * far - near * near) / 2.0 + (far ** 3 - near ** 3) / 3.0

    if eps < 1.0:
        lo, hi = 0.0, 2.0 * math.pi
    else:  # the centre lies outside the face: only the rays of a cone below it cross it
        half = math.asin(1.0 / eps)
        lo, hi = 1.5 * math.pi - half, 1.5 * math.pi + half
    f = quad(f_ray, lo, hi, epsabs=1e-13, epsrel=1e-12, limit=200)[0]
    m = quad(m_ray, lo, hi, epsabs=1e-13, epsrel=1e-12, limit=200)[0]
    return f / math.pi, m / math.pi


# --- the quadrature ----------------------------------------------------------------------------------

@pytest.mark.parametrize("eps", RATIOS)
def test_closed_forms_match_an_independent_integration(eps):
    """The elliptic closed forms this file checks against agree with the integral taken along rays
    from the slip's centre of rotation (to 1e-7: at eps = 100 the closed form for m cancels terms a
    million times its size)."""
    assert exact(eps) == pytest.approx(reference(eps), rel=1e-7, abs=1e-12)


def test_contensou_limits_are_exact():
    """Pure sliding: the force mu N and no torque; pure spin (either way): no force and the torque
    2/3 R mu N of a uniform pressure."""
    assert contensou(1.0, 0.0) == (1.0, 0.0)
    assert contensou(0.0, 1.0) == pytest.approx((0.0, 2.0 / 3.0), rel=1e-15, abs=0.0)
    assert contensou(0.0, -3.0) == pytest.approx((0.0, -2.0 / 3.0), rel=1e-15, abs=0.0)
    assert TORSION_ARM == 2.0 / 3.0


@pytest.mark.parametrize("eps", RATIOS)
def test_contensou_within_half_a_percent_of_the_exact_integrals(eps):
    """Force and moment within 0.5% of the exact values over slip ratios 0.01 to 100, the same for
    any scale of the velocities, with the moment's sign following the spin's."""
    f, m = contensou(eps, 1.0)
    f_ref, m_ref = reference(eps)
    assert f == pytest.approx(f_ref, rel=5e-3)
    assert m == pytest.approx(m_ref, rel=5e-3)
    assert contensou(7.0 * eps, 7.0) == pytest.approx((f, m), rel=1e-12)
    assert contensou(eps, -1.0) == pytest.approx((f, -m), rel=1e-12)


def test_contensou_holds_its_bound_between_the_listed_ratios():
    """The same 0.5% at 401 ratios spaced evenly in log from 0.01 to 100 (no lucky points)."""
    eps = np.logspace(-2.0, 2.0, 401)
    got = np.array([contensou(e, 1.0) for e in eps])
    want = np.array([exact(e) for e in eps])
    assert np.abs(got / want - 1.0).max() < 5e-3


# --- one impulse ---------------------------------------------------------------------------------------

def test_face_impulse_shares_one_friction_between_slide_and_spin():
    """A flat disk sliding at 1 m/s spinning at omega R = 1 m/s under normal impulse J_n gets
    J_t = 8/(3 pi) mu J_n against the slip and H_n = 8/(9 pi) mu R J_n against the spin, not mu J_n
    and 2/3 mu R J_n."""
    r = (0.0, 0.0, -0.5 * E)
    res = face_impulse(DISK.mass, DISK.inertia, N, R, r, (1.0, 0.0, -0.01), (0.0, 0.0, 1.0 / R), N,
                       0.0, 0.0, MU, MU)
    assert res is not None and res.sliding
    jn = DISK.mass * 0.01
    assert res.normal == pytest.approx(jn, rel=1e-12)
    assert res.linear[0] == pytest.approx(-8.0 / (3.0 * math.pi) * MU * jn, rel=5e-3)
    assert res.linear[1] == 0.0
    assert res.friction == pytest.approx(-res.linear[0], rel=1e-12)
    assert res.angular[2] == pytest.approx(-8.0 / (9.0 * math.pi) * MU * R * jn, rel=5e-3)


@pytest.mark.parametrize("share, sticks", [((0.6, 0.78), True), ((0.75, 0.75), False), ((0.95, 0.0), True),
                                           ((0.0, 0.95), True)])
def test_face_sticks_inside_the_elliptic_limit_surface(share, sticks):
    """The impulses stopping the slip and the spin are kept while (|J_t| / mu J_n)^2 +
    (|H_n| / (2/3 mu R J_n))^2 <= 1: each alone within its own bound is not enough."""
    r = (0.0, 0.0, -0.5 * E)
    jn = DISK.mass * 0.01
    v = share[0] * MU * jn / DISK.mass
    w = share[1] * MU * TORSION_ARM * R * jn / DISK.inertia[2]
    res = face_impulse(DISK.mass, DISK.inertia, N, R, r, (v, 0.0, -0.01), (0.0, 0.0, w), N, 0.0, 0.0, MU, MU)
    assert res is not None
    assert res.sliding is not sticks
    stopped = (res.linear[0] == pytest.approx(-DISK.mass * v, rel=1e-12)
               and res.angular[2] == pytest.approx(-DISK.inertia[2] * w, rel=1e-12))
    assert stopped is sticks


# --- thrown through the scene machinery ------------------------------------------------------------------

def throw(v: float, w: float, until: float):
    """(t [s], x-velocity [m/s], spin [rad/s], y-velocity [m/s], dissipated energy [J]) at every step of
    a flat disk thrown on a level floor (tests.ground_toys.disk_on_plane)."""
    text = disk_on_plane(dt=DT, until=until, radius=R, thickness=E, mu_static=MU, mu_kinetic=MU, restitution=0.3,
                         velocity=(v, 0.0, 0.0), spin=w)
    watch = Channels("disk.state", "ground.contact")
    result = Simulation(loads(text), observers=[watch]).run(round(until * 1e9))
    assert result.status == "ok", result.reason
    states = watch.seen["disk.state"]
    t = np.array([t for t, _ in states])
    vx = np.array([s.velocity[0] for _, s in states])
    vy = np.array([s.velocity[1] for _, s in states])
    spin = np.array([s.angular_velocity[2] for _, s in states])
    booked = dict((t, c.dissipated_energy) for t, c in watch.seen["ground.contact"])
    dissipated = np.array([booked.get(tt, 0.0) for tt in t])
    return t, vx, spin, vy, dissipated


def slope(t, y, first, count=10):
    return np.polyfit(t[first:first + count], y[first:first + count], 1)[0]


def test_sliding_spinning_disk_slows_by_the_shared_friction_and_stops_at_once():
    """The audit's throw, v = omega R = 1 m/s, mu 0.4: it slows at 8/(3 pi) mu g = 3.33 m/s^2 (not
    mu g = 3.92), its spin at 8/(9 pi) mu g R M / I_a = 44.4 rad/s^2 (not 104.6), it dissipates
    32/(9 pi) mu = 0.453 J per second per newton of weight (not 0.667), and the sliding and the spin
    stop within a few steps of each other (Farkas et al. 2003: at the same moment)."""
    t, vx, spin, vy, dissipated = throw(1.0, 1.0 / R, 0.5)
    first = int(np.argmax(vx < 1.0)) - 1  # the last state before the first impulse acted
    assert -slope(t, vx, first) == pytest.approx(8.0 / (3.0 * math.pi) * MU * G, rel=0.02)
    assert -slope(t, spin, first) == pytest.approx(8.0 / (9.0 * math.pi) * MU * G * R * DISK.mass / DISK.inertia[2],
                                                   rel=0.03)
    booked = np.diff(dissipated)
    start = int(np.argmax(booked > 0.0))
    power = booked[start:start + 3].mean() / (DT * DISK.mass * G)  # the first three responses
    assert power == pytest.approx(32.0 / (9.0 * math.pi) * MU, rel=0.02)
    assert np.all(vy == 0.0)
    stops = (int(np.argmax(vx == 0.0)), int(np.argmax(spin == 0.0)))
    assert vx[stops[0]] == 0.0 and spin[stops[1]] == 0.0  # both stop within the run
    assert abs(stops[0] - stops[1]) <= 3
    assert np.all(vx[stops[0]:] == 0.0) and np.all(spin[stops[1]:] == 0.0)


def test_pure_sliding_and_pure_spin_keep_their_coulomb_rates():
    """Without spin the disk slows at mu g and does not turn; without sliding it spins down at
    4/3 mu g / R (the torsional friction of a uniform pressure, M g 2/3 R mu / I_a) and stays put."""
    t, vx, spin, vy, _ = throw(2.0, 0.0, 0.1)
    first = int(np.argmax(vx < 2.0)) - 1
    assert -slope(t, vx, first, 100) == pytest.approx(MU * G, rel=1e-9)
    assert np.all(spin == 0.0) and np.all(vy == 0.0)
    t, vx, spin, vy, _ = throw(0.0, 50.0, 0.1)
    first = int(np.argmax(spin < 50.0)) - 1
    rate = 4.0 / 3.0 * MU * G / R * (DISK.mass * R * R / 2.0) / DISK.inertia[2]
    assert -slope(t, spin, first, 100) == pytest.approx(rate, rel=1e-9)
    assert np.all(vx == 0.0) and np.all(vy == 0.0)


@pytest.mark.parametrize("v, w", [(0.025, 50.0), (1.0, 0.2)],
                         ids=["drift-of-a-spinning-disk", "spin-of-a-sliding-disk"])
def test_near_the_limits_the_smaller_motion_feels_little_friction(v, w):
    """Close to either limit the smaller motion is barely braked: a disk spinning at omega R = 2.5 m/s
    drifting at 2.5 cm/s (eps = 0.01) slows at f(0.01) mu g = 0.01 mu g, and a disk sliding at 1 m/s
    spinning at 0.2 rad/s (eps = 100) loses spin at m(100) mu g R M / I_a, 1/270 of the torsional rate
    (the spinning puck that glides far; the slide that barely unwinds the spin)."""
    t, vx, spin, _, _ = throw(v, w, 0.02)
    f, m = exact(v / (w * R))
    first = int(np.argmax(vx < v)) - 1
    assert -slope(t, vx, first) == pytest.approx(f * MU * G, rel=0.02)
    assert -slope(t, spin, first) == pytest.approx(m * MU * G * R * DISK.mass / DISK.inertia[2], rel=0.02)
