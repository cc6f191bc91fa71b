"""Contact impulses: the frictionless corner impulse of physics.md and its Coulomb-bounded versions.

Notation: a body of mass M and world inverse inertia I^-1, an impulse J [N s] at offset r [m] from the
centre of mass, contact-point velocity u = v + w x r, plane normal n. The impulse changes u by K J with
the contact matrix

    K x = x / M + (I^-1 (r x x)) x r.

Frictionless (Painlevé's simplified problem, Stewart 2000): P = -(1 + e) u.n / K_nn, K_nn = n.K n =
1/M + (r x n).I^-1 (r x n), J = P n (:func:`corner_impulse`).

With Coulomb friction (:func:`point_impulse`) the sticking impulse reaches the normal target and stops
the tangential slip, J = K^-1 (du_n n - u_t); it is kept when |J_t| <= mu J_n. Otherwise the point
slides: J = J_n (n - mu_k t), t the slip direction, J_n = du_n / (n.K (n - mu_k t)). That denominator
is where Painlevé's paradox lives: it stays positive for mu_k below sqrt(5)/2 for a thin disk
(physics.md: (1 + 4 cos^2 theta) - 4 mu sin theta cos theta > 0 for all theta), 4/3 for a rod, and
always for a sphere (r x n = 0). Above the bound the solver drops the friction of that impulse
(``painleve`` flag) instead of returning a negative or infinite normal impulse.

:func:`face_impulse` handles a disk lying flat: the face supplies the normal impulse through the face
centre plus any couple that keeps the centre of pressure inside the face, so the tilt rates are set
directly (to -e times their value, or to zero) and the normal impulse decouples from the friction.
The sliding and the spin about the normal share one friction: Coulomb's law holds at every point of
the face, under a uniform pressure, so a face that both slides and spins gets less of each than it
would of either alone (Contensou 1963; Farkas, Bartels, Unger & Wolf, PRL 90, 248302, 2003: the two
motions stop together). :func:`contensou` integrates it over the face by a fixed quadrature; its
limits are the force mu N of pure sliding and the torque mu N 2/3 R (the arm of a uniform pressure)
of pure spin.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from components.rigid.dynamics import inertia_apply, inertia_solve
from components.rigid.vec import ZERO, Mat3, Vec, cross, dot, solve3

PAINLEVE_MARGIN = 1e-9  # a sliding denominator below this fraction of K_nn counts as inconsistent
SLIP_EPS = 1e-12        # [m/s] a tangential speed below this has no direction of its own
TORSION_ARM = 2.0 / 3.0  # torsional friction arm of a uniformly pressed disk face, in radii
CONTENSOU_RINGS = 64    # rings of equal width of the face quadrature (see :func:`contensou`)
CONTENSOU_ANGLES = 64   # points per ring; a multiple of 4 keeps every point off the slip's axis


def _face_quadrature(rings: int, angles: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points (x, y) [radii] and weights (summing to 1) of a polar rule over the unit disk: rings of
    equal width, each point at its ring's mean radius (so the sum of w r is 2/3, pure spin's moment,
    and the sum of w is 1, pure sliding's force, both exact) and at the midpoints of equal angles.
    Only the half x > 0 is kept, with doubled weights: :func:`contensou`'s integrands are even in x."""
    edges = np.linspace(0.0, 1.0, rings + 1)
    area = edges[1:] ** 2 - edges[:-1] ** 2  # ring areas / pi
    radius = 2.0 / 3.0 * (edges[1:] ** 3 - edges[:-1] ** 3) / area
    theta = (np.arange(angles) + 0.5) * (2.0 * math.pi / angles)
    r, t = np.meshgrid(radius, theta, indexing="ij")
    x, y = (r * np.cos(t)).ravel(), (r * np.sin(t)).ravel()
    w = np.repeat(area / angles, angles)
    half = x > 0.0
    return x[half], y[half], 2.0 * w[half]


_FACE_X, _FACE_Y, _FACE_W = _face_quadrature(CONTENSOU_RINGS, CONTENSOU_ANGLES)
_FACE_X2 = _FACE_X * _FACE_X
_FACE_WY = _FACE_W * _FACE_Y
_FACE_WR2 = _FACE_W * (_FACE_X2 + _FACE_Y * _FACE_Y)


class ImpulseResult(NamedTuple):
    """linear: (3,) J [N s]; angular: (3,) H about the centre of mass [N m s], world frame;
    normal: J.n [N s] (>= 0); friction: |J_t| [N s]; sliding: kinetic friction acted; painleve: the
    friction was dropped because the sliding problem had no consistent solution."""

    linear: Vec
    angular: Vec
    normal: float
    friction: float
    sliding: bool
    painleve: bool


NO_IMPULSE = ImpulseResult(ZERO, ZERO, 0.0, 0.0, False, False)


def contact_matrix(mass: float, inertia: Vec, axis: Vec, r: Vec, rotate: bool = True) -> Mat3:
    """K (3x3, row-major, [1/kg]): the change of the velocity of point r per unit impulse at r.

    ``inertia``: principal moments (I_d, I_d, I_a); ``axis``: body symmetry axis (world);
    ``rotate`` false: the attitude is held, K = I / M.
    """
    inv_m = 1.0 / mass
    cols = []
    for e in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)):
        wr = cross(inertia_solve(inertia, axis, cross(r, e)), r) if rotate else ZERO
        cols.append((e[0] * inv_m + wr[0], e[1] * inv_m + wr[1], e[2] * inv_m + wr[2]))
    return (cols[0][0], cols[1][0], cols[2][0],
            cols[0][1], cols[1][1], cols[2][1],
            cols[0][2], cols[1][2], cols[2][2])


def corner_impulse(mass: float, inertia: Vec, axis: Vec, r: Vec, n: Vec, v: Vec, w: Vec,
                   restitution: float) -> float:
    """Frictionless impact impulse P [N s] along n at r (physics.md section 2); 0 unless approaching.

    K = 1/M + (r x n).I^-1 (r x n);  P = -(1 + e) v_n / K, with v_n = (v + w x r).n < 0.
    """
    wr = cross(w, r)
    vn = dot((v[0] + wr[0], v[1] + wr[1], v[2] + wr[2]), n)
    if vn >= 0.0:
        return 0.0
    rn = cross(r, n)
    k = 1.0 / mass + dot(rn, inertia_solve(inertia, axis, rn))
    return -(1.0 + restitution) * vn / k


def _mv(m: Mat3, x: Vec) -> Vec:
    return (m[0] * x[0] + m[1] * x[1] + m[2] * x[2],
            m[3] * x[0] + m[4] * x[1] + m[5] * x[2],
            m[6] * x[0] + m[7] * x[1] + m[8] * x[2])


def point_impulse(k: Mat3, r: Vec, u: Vec, n: Vec, target_un: float, mu_stick: float,
                  mu_slide: float) -> ImpulseResult:
    """Coulomb-bounded impulse at a contact point.

    k: contact matrix at r; u: (3,) contact-point velocity [m/s]; target_un: wanted normal velocity
    after the impulse [m/s]; mu_stick: the bound that decides sticking (mu_s when sticking before,
    mu_k when sliding before); mu_slide: the kinetic coefficient used while sliding.
    """
    un = dot(u, n)
    dun = target_un - un
    if dun <= 0.0:
        return NO_IMPULSE
    ut = (u[0] - un * n[0], u[1] - un * n[1], u[2] - un * n[2])
    j = solve3(k, (dun * n[0] - ut[0], dun * n[1] - ut[1], dun * n[2] - ut[2]))
    jn = dot(j, n)
    jt = (j[0] - jn * n[0], j[1] - jn * n[1], j[2] - jn * n[2])
    jt_size = math.sqrt(dot(jt, jt))
    if jn >= 0.0 and jt_size <= mu_stick * jn:
        return ImpulseResult(j, cross(r, j), jn, jt_size, False, False)
    slip = math.sqrt(dot(ut, ut))
    if slip > SLIP_EPS:
        t = (ut[0] / slip, ut[1] / slip, ut[2] / slip)
    elif jt_size > 0.0:
        t = (-jt[0] / jt_size, -jt[1] / jt_size, -jt[2] / jt_size)
    else:
        t = ZERO
    d = (n[0] - mu_slide * t[0], n[1] - mu_slide * t[1], n[2] - mu_slide * t[2])
    denom = dot(n, _mv(k, d))
    knn = dot(n, _mv(k, n))
    painleve = denom <= PAINLEVE_MARGIN * knn
    if painleve:
        d, denom = n, knn
    jn = dun / denom
    j = (d[0] * jn, d[1] * jn, d[2] * jn)
    friction = 0.0 if painleve else mu_slide * jn * math.sqrt(dot(t, t))
    return ImpulseResult(j, cross(r, j), jn, friction, not painleve, painleve)


def contensou(slip: float, rim_speed: float) -> tuple[float, float]:
    """Coulomb friction of a uniformly pressed disk face that slides and spins: (f, m), the force as a
    fraction of mu N, against the face centre's slip, and the moment about the normal in units of
    mu N R, against the spin (m has the sign of ``rim_speed``).

    slip: the face centre's tangential speed [m/s] (>= 0); rim_speed: omega_n R [m/s] (signed). At a
    point rho of the face the slip is u = v_t + omega_n n x rho and the traction -mu p u/|u|, with
    p = N / (pi R^2); in a frame with e1 along v_t, e2 = n x e1 and rho = R (x e1 + y e2),
    u = (|v_t| - omega_n R y) e1 + omega_n R x e2 and

        f = (1/pi) integral (u . e1) / |u| dA,   m = (1/pi) integral (x u.e2 - y u.e1) / |u| dA

    over the unit disk (the e2 force vanishes by the mirror symmetry x -> -x). Pure sliding gives
    (1, 0), pure spin (0, 2/3); in between both are smaller (at omega R = v, f = 8 / (3 pi) and
    m = 8 / (9 pi)). The integrals are taken by the fixed polar rule of :func:`_face_quadrature`
    (64 x 64 points, half of them used): both within 0.25 % of the exact (elliptic-integral) values
    for v / (omega R) from 0.01 to 100. Below that f's relative error tends to 0.5 % (f itself
    tends to v / (omega R): the inner rings take the 1/rho of the traction's deflection); the limits
    are exact.
    """
    if slip <= SLIP_EPS:
        return 0.0, (math.copysign(TORSION_ARM, rim_speed) if abs(rim_speed) > SLIP_EPS else 0.0)
    if abs(rim_speed) <= SLIP_EPS:
        return 1.0, 0.0
    # with a = |v_t|, b = omega_n R: u.e1 = a - b y, |u| = sqrt((a - b y)^2 + b^2 x^2) (never 0: no
    # point lies on x = 0) and x u.e2 - y u.e1 = b (x^2 + y^2) - a y, so three sums of w / |u| do
    inv = 1.0 / np.sqrt((slip - rim_speed * _FACE_Y) ** 2 + (rim_speed * rim_speed) * _FACE_X2)
    s_w, s_wy = float(np.dot(_FACE_W, inv)), float(np.dot(_FACE_WY, inv))
    return slip * s_w - rim_speed * s_wy, rim_speed * float(np.dot(_FACE_WR2, inv)) - slip * s_wy


def face_impulse(mass: float, inertia: Vec, axis: Vec, radius: float, r: Vec, v: Vec, w: Vec, n: Vec,
                 target_un: float, tilt_restitution: float, mu_stick: float,
                 mu_slide: float) -> ImpulseResult | None:
    """Impulse of a disk lying flat on the plane, acting at the face centre r; None when the face
    cannot hold the body (no compression, or the couple would put the centre of pressure outside the
    face: the disk tips onto its rim and the point contact takes over).

    The tilt rates (the components of the angular velocity normal to n) are set directly: they become
    -tilt_restitution times their value. The normal impulse J_n then follows from the normal target
    alone. The friction, a tangential impulse J_t at the face centre and a torsional one H_n about n,
    is that of one face under a uniform pressure J_n / (pi R^2):

    - sticking: J_t = -M u_t and H_n = -I_nn omega_n, which stop the face centre's slip u_t (its
      tangential velocity with the tilt rates set) and the spin omega_n, are kept while they lie
      inside the face's limit surface, taken as the ellipse
      (|J_t| / (mu_stick J_n))^2 + (H_n / (mu_stick J_n 2/3 R))^2 <= 1 (the exact surface of a
      uniform pressure lies a little inside it: at omega R = v its point is 0.95 of the way out to
      the ellipse);
    - sliding: local Coulomb friction over the face with mu_slide (:func:`contensou`, computed from
      u_t and omega_n before the response), J_t = -mu_slide J_n f u_t / |u_t| and
      H_n = -mu_slide J_n R m, each cut to what stops its motion if it would reverse it.
    """
    wn = dot(w, n)
    w_perp = (w[0] - wn * n[0], w[1] - wn * n[1], w[2] - wn * n[2])
    wp = (-tilt_restitution * w_perp[0], -tilt_restitution * w_perp[1], -tilt_restitution * w_perp[2])
    # r is parallel to n for a flat face, and (n x r).n = 0 always: the spin does not enter u_n.
    jn = mass * (target_un - dot(v, n) - dot(cross(wp, r), n))
    if jn <= 0.0:
        return None
    i_nn = dot(n, inertia_apply(inertia, axis, n))
    # the face centre's velocity with the tilt rates set (the spin moves it only as far as r leans off n,
    # within the face tolerance; it is stopped with the spin when sticking, and left out)
    wr = cross(wp, r)
    u = (v[0] + wr[0], v[1] + wr[1], v[2] + wr[2])
    un = dot(u, n)
    ut = (u[0] - un * n[0], u[1] - un * n[1], u[2] - un * n[2])
    slip = math.sqrt(dot(ut, ut))
    # sticking: the impulses that stop the slip and the spin, |J_t| = M |u_t| and |H_n| = I_nn |omega_n|,
    # if they lie inside the limit surface (the ellipse)
    jt_size, hn_size = mass * slip, i_nn * abs(wn)
    force_cap = mu_stick * jn
    torque_cap = force_cap * TORSION_ARM * radius
    if torque_cap > 0.0:
        a, b = jt_size / force_cap, hn_size / torque_cap  # (products, not **: a tiny J_n gives inf)
        sliding = a * a + b * b > 1.0
    else:  # no friction to hold it (mu_stick 0, or J_n too small to count)
        sliding = jt_size > 0.0 or hn_size > 0.0
    wn_new = 0.0
    if sliding:  # local Coulomb friction; a motion it would reverse is stopped instead
        f, m = contensou(slip, wn * radius)
        jt_size = min(jt_size, mu_slide * jn * f)
        dwn = mu_slide * jn * radius * m / i_nn  # (m has the sign of omega_n)
        if abs(dwn) < abs(wn):
            wn_new = wn - dwn
    c = -jt_size / slip if slip > 0.0 else 0.0
    jt = (c * ut[0], c * ut[1], c * ut[2])
    w_new = (wp[0] + wn_new * n[0], wp[1] + wn_new * n[1], wp[2] + wn_new * n[2])
    j = (jn * n[0] + jt[0], jn * n[1] + jt[1], jn * n[2] + jt[2])
    h = inertia_apply(inertia, axis, (w_new[0] - w[0], w_new[1] - w[1], w_new[2] - w[2]))
    couple = cross(r, j)
    couple = (h[0] - couple[0], h[1] - couple[1], h[2] - couple[2])
    cn = dot(couple, n)
    c_perp = math.sqrt(max(0.0, dot(couple, couple) - cn * cn))
    if c_perp > radius * jn:
        return None
    return ImpulseResult(j, h, jn, jt_size, sliding, False)
