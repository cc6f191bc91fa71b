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
Spin about the normal meets torsional friction with the arm 2/3 R of a uniform pressure.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from components.rigid.dynamics import inertia_apply, inertia_solve
from components.rigid.vec import ZERO, Mat3, Vec, cross, dot, solve3

PAINLEVE_MARGIN = 1e-9  # a sliding denominator below this fraction of K_nn counts as inconsistent
SLIP_EPS = 1e-12        # [m/s] a tangential speed below this has no direction of its own
TORSION_ARM = 2.0 / 3.0  # torsional friction arm of a uniformly pressed disk face, in radii


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


def face_impulse(mass: float, inertia: Vec, axis: Vec, radius: float, r: Vec, v: Vec, w: Vec, n: Vec,
                 target_un: float, tilt_restitution: float, mu_stick: float,
                 mu_slide: float) -> ImpulseResult | None:
    """Impulse of a disk lying flat on the plane, acting at the face centre r; None when the face
    cannot hold the body (no compression, or the couple would put the centre of pressure outside the
    face: the disk tips onto its rim and the point contact takes over).

    The angular velocity after the impulse is chosen directly: tilt rates (the components normal to
    n) become -tilt_restitution times their value; the spin about n stops if torsional friction
    (arm 2/3 R, coefficient mu_stick) can stop it, else slows by mu_slide. The normal impulse then
    follows from the normal target alone, and the tangential impulse stops the face centre or is
    capped at mu_slide J_n.
    """
    wn = dot(w, n)
    w_perp = (w[0] - wn * n[0], w[1] - wn * n[1], w[2] - wn * n[2])
    wp = (-tilt_restitution * w_perp[0], -tilt_restitution * w_perp[1], -tilt_restitution * w_perp[2])
    # r is parallel to n for a flat face, and (n x r).n = 0 always: the spin does not enter u_n.
    jn = mass * (target_un - dot(v, n) - dot(cross(wp, r), n))
    if jn <= 0.0:
        return None
    i_nn = dot(n, inertia_apply(inertia, axis, n))
    spin_cap = TORSION_ARM * radius * jn
    sliding_spin = i_nn * abs(wn) > mu_stick * spin_cap
    wn_new = 0.0
    if sliding_spin:
        wn_new = wn - math.copysign(mu_slide * spin_cap / i_nn, wn)
        if wn_new * wn < 0.0:
            wn_new = 0.0
    w_new = (wp[0] + wn_new * n[0], wp[1] + wn_new * n[1], wp[2] + wn_new * n[2])
    # tangential: the face centre should come to rest, v_t + (w_new x r)_t = 0
    wr = cross(w_new, r)
    target = (v[0] + wr[0], v[1] + wr[1], v[2] + wr[2])
    tn = dot(target, n)
    jt = (-mass * (target[0] - tn * n[0]), -mass * (target[1] - tn * n[1]), -mass * (target[2] - tn * n[2]))
    jt_size = math.sqrt(dot(jt, jt))
    sliding = jt_size > mu_stick * jn
    if sliding:
        c = mu_slide * jn / jt_size
        jt = (jt[0] * c, jt[1] * c, jt[2] * c)
        jt_size = mu_slide * jn
    j = (jn * n[0] + jt[0], jn * n[1] + jt[1], jn * n[2] + jt[2])
    h = inertia_apply(inertia, axis, (w_new[0] - w[0], w_new[1] - w[1], w_new[2] - w[2]))
    couple = cross(r, j)
    couple = (h[0] - couple[0], h[1] - couple[1], h[2] - couple[2])
    cn = dot(couple, n)
    c_perp = math.sqrt(max(0.0, dot(couple, couple) - cn * cn))
    if c_perp > radius * jn:
        return None
    return ImpulseResult(j, h, jn, jt_size, sliding or sliding_spin, False)
