"""The compiled per-step work: columns under the body, wetted surface elements, displacement.

:func:`evaluate` sums every switched-on effect's force and torque (about the centre of mass) for one
body state over one water patch, writes the occupied height of each column, and fills ``stats``
(see the ``S_*`` indices) with what the component reports and its stability bound needs. Work is
confined to the columns under the body's bounding box and to the elements below the patch's
highest surface; an effect not switched on is skipped entirely.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from components import kernel_cache
from components.coupler.effects import BUOYANCY, DISPLACEMENT, FRICTION, PRESSURE, WAVE_DRAG
from components.coupler.forces import pressure_magnitude, ventilation, wave_drag_magnitude
from components.coupler.geometry import (
    FACE_SUBDIVISION,
    box_coverage,
    box_density,
    box_fraction,
    box_shape,
    disk_chord,
    sphere_chord,
)

kernel_cache.install()  # before the cached kernels below: their cache keyed on every kernel source

SHAPE_DISK = 0
SHAPE_SPHERE = 1

# stats layout (float64 vector)
S_BUOYANCY = 0  # force (3) then torque (3)
S_PRESSURE = 6
S_FRICTION = 12
S_WAVE = 18
S_VOLUME = 24  # submerged volume [m^3] (column sum, same as sum b_ij s^2)
S_AREA = 25  # wetted area [m^2] (element sum)
S_DAMP_LIN = 26  # d|F|/d|v| summed over wet elements [kg/s]
S_DAMP_ROT = 27  # d|torque|/d|omega| summed over wet elements [kg m^2/s]
S_STIFF = 28  # d|F|/dz from the wetted area growing with depth [N/m]
S_COLUMNS = 29  # columns evaluated
S_ELEMENTS = 30  # wet elements evaluated
S_CENTROID = 31  # volume-weighted sum of the wet-interval centroids (3) [m^4]
S_WATERLINE = 34  # area of sub-columns the surface cuts through the body [m^2]
S_ADVANCING = 35  # wetted area advancing into the water [m^2]
S_TOTAL = 36  # sum of the switched-on effects: force (3) then torque (3)
S_SURFACE_LOW = 42  # water height at the body's lowest point [m] (NaN off the patch or over dry land)
S_HMAX = 43  # highest surface of the patch [m]
N_STATS = 44

PREFILTER_MARGIN = 1e-12  # relative margin of a bound computed without divisions, against the rounding
# (a few 1e-16) that separates it from the exact value it stands in for: a test it passes or fails by
# more than this gives the exact test's answer

RING_FOCUS = 4  # power of the share (1 + q cos) a column gives each band column: a rim column puts half
# its volume within +-27 deg of its own direction [-]


@njit(cache=True)
def _chord(shape, dx, dy, ax, ay, az, radius, thickness):
    if shape == SHAPE_DISK:
        return disk_chord(dx, dy, ax, ay, az, radius, thickness)
    return sphere_chord(dx, dy, radius)


@njit(cache=True, inline="always")
def sample_surface(x, y, x0, y0, cell, height, wvel):
    """Bilinear water height and vertical velocity at (x, y); ok is False outside the patch.

    Inlined where it is called: it runs for every surface element of a body at every step, and a
    call with the two arrays as arguments takes and drops a reference on each: a third of the
    sampling's time (700 samples in a compiled loop, called against inlined, bit for bit)."""
    ok, i, j, i1, j1, w00, w10, w01, w11 = _bilinear(x, y, x0, y0, cell, height.shape)
    if not ok:
        return False, 0.0, 0.0
    h = w00 * height[j, i] + w10 * height[j, i1] + w01 * height[j1, i] + w11 * height[j1, i1]
    v = w00 * wvel[j, i] + w10 * wvel[j, i1] + w01 * wvel[j1, i] + w11 * wvel[j1, i1]
    return True, h, v


@njit(cache=True, inline="always")
def sample_water(x, y, x0, y0, cell, height, wvel, bottom):
    """:func:`sample_surface` and the water's depth there: (ok, height [m], vertical velocity [m/s],
    depth [m]), the depth the bilinear mean of the columns' own, max(height - bottom, 0), so that it
    is 0 exactly over dry land (a column whose surface is its bed) and the layer between the bed and
    the surface elsewhere. (The same weights as sample_surface's, the height and velocity the same
    to the bit.) :func:`sample_water_slope` without the slope."""
    ok, h, v, d, _, _ = sample_water_slope(x, y, x0, y0, cell, height, wvel, bottom)
    return ok, h, v, d


@njit(cache=True, inline="always")
def sample_water_slope(x, y, x0, y0, cell, height, wvel, bottom):
    """:func:`sample_water` and the slope of the surface it samples there, the gradient of the
    bilinear interpolant: (ok, height [m], vertical velocity [m/s], depth [m], dh/dx, dh/dy [-]).
    The slope is 0 exactly on a level
    surface, and in the outer half column of a patch, where the height is held at the edge's, it is
    the edge cell's (the surface going on as it went)."""
    ok, i, j, i1, j1, w00, w10, w01, w11 = _bilinear(x, y, x0, y0, cell, height.shape)
    if not ok:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    h00, h10, h01, h11 = height[j, i], height[j, i1], height[j1, i], height[j1, i1]
    h = w00 * h00 + w10 * h10 + w01 * h01 + w11 * h11
    v = w00 * wvel[j, i] + w10 * wvel[j, i1] + w01 * wvel[j1, i] + w11 * wvel[j1, i1]
    d = (w00 * max(h00 - bottom[j, i], 0.0) + w10 * max(h10 - bottom[j, i1], 0.0)
         + w01 * max(h01 - bottom[j1, i], 0.0) + w11 * max(h11 - bottom[j1, i1], 0.0))
    tx, ty = w10 + w11, w01 + w11  # the place within the cell the weights come from
    gx = ((1.0 - ty) * (h10 - h00) + ty * (h11 - h01)) / cell
    gy = ((1.0 - tx) * (h01 - h00) + tx * (h11 - h10)) / cell
    return True, h, v, d, gx, gy


@njit(cache=True, inline="always")
def _bilinear(x, y, x0, y0, cell, shape):
    """The bilinear weights of (x, y) [m] on an (nj, ni) patch whose first column is centred at
    (x0, y0): (ok, i, j, i1, j1, w00, w10, w01, w11); ok is False outside the patch (half a column
    beyond its outer centres). The indices are unsigned, as they are never negative: a signed index
    is wrapped at each access in case it is, a select apiece (twelve for sample_water)."""
    nj, ni = shape
    fx = (x - x0) / cell
    fy = (y - y0) / cell
    zero = np.uint64(0)
    if fx < -0.5 or fy < -0.5 or fx > ni - 0.5 or fy > nj - 0.5:
        return False, zero, zero, zero, zero, 0.0, 0.0, 0.0, 0.0
    fx = min(max(fx, 0.0), ni - 1.0)
    fy = min(max(fy, 0.0), nj - 1.0)
    i = min(int(fx), max(ni - 2, 0))
    j = min(int(fy), max(nj - 2, 0))
    tx = fx - i
    ty = fy - j
    i1 = min(i + 1, ni - 1)
    j1 = min(j + 1, nj - 1)
    w00 = (1 - tx) * (1 - ty)
    w10 = tx * (1 - ty)
    w01 = (1 - tx) * ty
    w11 = tx * ty
    return True, np.uint64(i), np.uint64(j), np.uint64(i1), np.uint64(j1), w00, w10, w01, w11


@njit(cache=True, inline="always")
def add_wrench(acc, rx, ry, rz, fx, fy, fz):
    """Add the force (fx, fy, fz) [N] acting at (rx, ry, rz) [m] from the centre of mass to ``acc``
    (6,): force, then its torque r x F [N m]."""
    acc[0] += fx
    acc[1] += fy
    acc[2] += fz
    acc[3] += ry * fz - rz * fy
    acc[4] += rz * fx - rx * fz
    acc[5] += rx * fy - ry * fx


SPRAY_ROOT_POWER = 6  # planing pressure grows like xi^p from the trailing edge (xi = 0) to the spray
# root (xi = 1): its centre at (p + 1) / (p + 2) = 7/8 of the wetted length; fitted once on Rosellini et
# al.'s fig. 3 (p = 2, Savitsky's steady 3/4, lets a 65 rev/s disk lose 4 deg of attack) [-]
SPRAY_ROOT_LEVEL = 0.5 * math.sin(math.radians(4.0))  # [-] the lean (sin(2 tilt) / 2: 2 deg of tilt) from
# which the side a disk's lowest point is on, not the flow, says where its spray root is (_spray_root)


FACE_PIECES = FACE_SUBDIVISION * FACE_SUBDIVISION  # pieces of a disk face's square (Elements.sub)
PL_SLOPE = 8  # where a row of pl_r holds how high its pieces lie per body x and y over the surface (2)
PL_PIECES = 10  # where a row of pl_r holds its element's pieces' wetted shares (FACE_PIECES)
PLANING_PLACE = PL_PIECES + FACE_PIECES  # values per element of pl_r: lever arm (3), element index, level
# over its centre, its two height ranges, the bed's level over its centre, its pieces' heights per body
# x and y over the surface's plane (PL_SLOPE); then the wetted shares of its
# pieces, found as its wetted fraction was (a square partly under, or cut by the bed) and read again
# where its load is spread (_spread_planing), not worked out a second time


@njit(cache=True)
def _pieces_wet(el_sub, k, t, t_bed, w1, w2, zx, zy, wet_ramp, out):
    """The wetted shares [-] of element ``k``'s pieces into ``out`` (el_sub.shape[1],): each piece's
    share of the element's area times the fraction of it between the bed, ``t_bed`` [m] over the
    element's centre, and a level ``t`` [m] over it (the part under the bed is in the ground, not in
    the water; a bed below the element, t_bed at most -(w1 + w2) / 2, cuts nothing). A piece is the
    element shrunk by FACE_SUBDIVISION, its height ranges the element's ``w1``, ``w2`` over that (the
    smaller at least ``wet_ramp / FACE_SUBDIVISION``, as the element's at least ``wet_ramp``), its
    centre ``du zx + dv zy`` above the element's.

    The pieces share their ranges: what the fraction needs of them is worked out once for all
    (geometry.box_shape), each piece's fraction the same to the bit as box_coverage's."""
    m = FACE_SUBDIVISION
    whole = t >= 0.5 * (w1 + w2)  # the whole element is under the level
    bed_whole = t_bed >= 0.5 * (w1 + w2)
    cut = t_bed > -0.5 * (w1 + w2)
    p1 = w1 / m
    p2 = w2 / m
    if p1 < p2:
        p1 = max(p1, wet_ramp / m)
    else:
        p2 = max(p2, wet_ramp / m)
    a, b, half, d, ab2 = box_shape(p1, p2)
    for q in range(el_sub.shape[1]):
        share = el_sub[k, q, 2]
        if share <= 0.0:
            out[q] = 0.0
            continue
        tau = el_sub[k, q, 0] * zx + el_sub[k, q, 1] * zy
        c = share if whole else share * box_fraction(t - tau, a, b, half, d, ab2)
        if cut and c > 0.0:
            c = max(c - (share if bed_whole else share * box_fraction(t_bed - tau, a, b, half, d, ab2)), 0.0)
        out[q] = c


@njit(cache=True)
def _binomial(n, k):
    """n choose k, as a float."""
    c = 1.0
    for j in range(k):
        c = c * (n - j) / (j + 1)
    return c


@njit(cache=True)
def _grid_moments(a, b, even, odd_u, odd_v):
    """Moments of a whole face square's m x m pieces (m = FACE_SUBDIVISION), equal shares at offsets
    (i, j) pitches from its centre (i, j in -(m - 1) / 2 .. (m - 1) / 2), whose places along the flow
    are a i + b j [-] from the centre's: even[n] = mean of (a i + b j)^n, odd_u[n] = mean of (a i + b j)^n i, odd_v[n] =
    mean of (a i + b j)^n j, for n = 0 .. len - 1. Then the mean over the pieces of (x + a i + b j)^p
    is sum_n C(p, n) x^(p - n) even[n], and of it times i or j the same with odd_u or odd_v."""
    for n in range(even.shape[0]):
        even[n] = 0.0
        odd_u[n] = 0.0
        odd_v[n] = 0.0
    m = FACE_SUBDIVISION
    for ii in range(m):
        i = ii - 0.5 * (m - 1)
        for jj in range(m):
            j = jj - 0.5 * (m - 1)
            d = a * i + b * j
            dn = 1.0 / (m * m)
            for n in range(even.shape[0]):
                even[n] += dn
                odd_u[n] += dn * i
                odd_v[n] += dn * j
                dn *= d


@njit(cache=True)
def _pieces_weight(el_sub, k, t, w1, w2, x, a, b, zx, zy, wet_ramp, forward, t_bed=-math.inf):
    """The spray root's mean weight over element ``k``'s wet pieces, and where it puts the load:
    (mean weight [-], du, dv [m] from the element's centroid along body x and y). ``x``: the
    centroid's place between the trailing edge (0) and the spray root (1); a piece at (du, dv) lies
    ``du a + dv b`` further on; t, t_bed, w1, w2 as :func:`_pieces_wet`.
    No piece under the level (the element's own fraction is wider): the centroid's weight, at the
    centroid."""
    shares = np.empty(el_sub.shape[1])
    _pieces_wet(el_sub, k, t, t_bed, w1, w2, zx, zy, wet_ramp, shares)
    return _weight_of_pieces(el_sub, k, shares, x, a, b, forward)


@njit(cache=True)
def _weight_of_pieces(el_sub, k, shares, x, a, b, forward):
    """:func:`_pieces_weight` with the pieces' wetted shares given: ``shares`` (el_sub.shape[1],) [-],
    :func:`_pieces_wet`'s."""
    p = SPRAY_ROOT_POWER
    wet = 0.0
    mean_w = 0.0
    du = 0.0
    dv = 0.0
    for q in range(el_sub.shape[1]):
        c = shares[q]
        if c <= 0.0:
            continue
        xi = min(1.0, max(0.0, x + el_sub[k, q, 0] * a + el_sub[k, q, 1] * b))
        wq = c * ((1.0 - forward) + forward * (p + 1) * xi ** p)
        wet += c
        mean_w += wq
        du += wq * el_sub[k, q, 0]
        dv += wq * el_sub[k, q, 1]
    if wet <= 0.0 or mean_w <= 0.0:
        xi = min(1.0, max(0.0, x))
        return (1.0 - forward) + forward * (p + 1) * xi ** p, 0.0, 0.0
    return mean_w / wet, du / mean_w, dv / mean_w


@njit(cache=True, inline="always")
def _height_ranges(t1z, t2z, face, wet_ramp):
    """(w1, w2) [m]: an element's height range along each of its two sides, from their rises ``t1z``,
    ``t2z`` [m]; a level one goes from dry to wet over at least ``wet_ramp``. A disk face's squares
    (``face``) are alike along both sides (its tiling maps onto itself by a quarter turn), so that
    least range goes to the smaller of the two, whichever side it lies along: kept on the second
    side, it made a spinning disk's wetting depend on how far the disk had turned against its own
    tiling (the same throw laid along y skipped differently from along x). A rim strip's and a
    sphere band's second side is their height (the thickness, the band's step): it keeps the ramp."""
    w1 = abs(t1z)
    w2 = abs(t2z)
    if face and w1 < w2:
        w1 = max(w1, wet_ramp)
    else:
        w2 = max(w2, wet_ramp)
    return w1, w2


@njit(cache=True, inline="always")
def _spray_root(lean_x, lean_y, vx, vy, hspeed):
    """(hx, hy, share): the horizontal direction from a wetted face's trailing edge towards its spray
    root, and the share [0, 1] of the planing load weighted towards it, of a disk leaning by (lean_x,
    lean_y) [-] (its axis's horizontal part times minus its vertical one: sin(2 tilt) / 2 towards
    its centre from its lowest point, 0 level and edge on) and moving at (vx, vy) [m/s] (``hspeed``).

    A tilted disk's wetted area is the segment around its lowest point, cut by the waterline across
    the direction from that point to the centre: the water meets it along that direction, the lean's.
    A level face is wetted all over at once and meets the water along the flow, as does a disk on
    its edge (its lowest point under its centre). Within SPRAY_ROOT_LEVEL of level (a lean below it,
    about 2 deg of tilt) the flow's direction is added, fading out as the lean grows to it: the
    direction turns smoothly from the flow's to the lean's, and is the lean's alone beyond. (It was
    the lean's whenever the lowest point was off the centre: a disk tilted 1e-7 rad nose down had its
    load's centre 26 mm behind its centre where level had it 26 mm ahead, and a flat throw bounced or
    sank on a 1e-5 deg difference of its tilt.) Where the two cancel (a disk leaning nose down into
    the flow by half SPRAY_ROOT_LEVEL), no side leads and the share falls to 0: the load is spread
    evenly, as on a face meeting the water head on."""
    lean = math.sqrt(lean_x * lean_x + lean_y * lean_y)
    hx, hy = lean_x, lean_y
    if hspeed > 0.0 and lean < SPRAY_ROOT_LEVEL:
        flow = (SPRAY_ROOT_LEVEL - lean) / hspeed
        hx += flow * vx
        hy += flow * vy
    reach = math.sqrt(hx * hx + hy * hy)
    if not reach > 0.0:
        return 1.0, 0.0, 0.0
    return hx / reach, hy / reach, min(1.0, reach / SPRAY_ROOT_LEVEL)


@njit(cache=True)
def face_of(el_nrm, k):
    """Which face of a disk its face element ``k`` is on: 1 the upper (its normal along the body's +z),
    0 the lower."""
    return 1 if el_nrm[k, 2] > 0.0 else 0


@njit(cache=True)
def _spread_planing(fp, pl_f, pl_r, pl_s, pl_m, n_pl, el_sub, el_whole, el_t1, el_nrm, axes, sx, sy, wet_ramp,
                    s_lo, s_hi, forward):
    """Add the planing loads of a disk's face elements (pl_*, ``n_pl`` of them) to the wrench ``fp``
    (6,), each spread over its wet pieces (Elements.sub) with the weight of the spray root, and
    scaled so that each face's sum is unchanged.

    Face by face (:func:`face_of`, ``s_lo`` and ``s_hi`` (2,) each face's): a disk pitching into the
    water drives both faces into it at once, their loads pushing opposite ways. Scaled together, the
    sum of the loads' sizes was kept, not the force: the upper face's load, near the trailing edge,
    was weighted down and the lower face's up, so that a disk pitching at 60 rad/s felt 8.0 N where
    the law summed over its elements gives 0.8 N (and at 10 rad/s nose down, +0.28 N up for -0.43).

    A planing surface is not pressed evenly: the pressure peaks where the water meets it, at the
    spray root along the front of the wetted area (Wagner 1932), and the centre of pressure of a
    planing plate lies at 3/4 of the wetted length from its trailing edge at speed (Savitsky 1964,
    "Hydrodynamic design of planing hulls"), not at half. With xi a piece's place between ``s_lo``
    (the trailing edge) and ``s_hi`` (the spray root) [m] along the flow, the weight
    (1 - f) + f (p + 1) xi^p (p = SPRAY_ROOT_POWER) puts it there for a plate planing forward
    (f = ``forward`` = 1, the flow along the surface) and keeps the even pressure of a body meeting
    the water head on (f = 0). The total force is unchanged: C_L and the law stay the measured ones,
    only the place they act moves.

    Piece by piece, because the weight changes across a square: with each square's load at its
    centroid, weighted by its centroid's place between the outermost wet centroids, the centre of
    pressure of a 5 cm stone's face moved with how its 6 mm squares lay against the waterline, by up
    to 2.8 mm along the flow and 2.3 mm across it with the trailing edge 1 mm under, and with the
    spin the stone's attitude turned by the tiling, not the water (tests/test_planing_centre.py:
    within 0.3 mm along and 0.1 mm across now). A whole square wholly under (el_whole) is summed in
    closed form over its grid of pieces (:func:`_grid_moments`), the same sum."""
    p = SPRAY_ROOT_POWER
    n_sub = el_sub.shape[1]
    spans = np.ones(2)
    forwards = np.zeros(2)
    for f in range(2):
        if s_hi[f] - s_lo[f] > 0.0 and forward > 0.0:
            spans[f] = s_hi[f] - s_lo[f]
            forwards[f] = forward
        # else: no extent along the flow, the pressure even over the face's wetted area
    total = np.zeros(2)
    weighted = np.zeros(2)
    acc = np.zeros((2, 6))
    grid_side = -1.0
    grid_face = -1
    even = np.zeros(p + 1)
    odd_u = np.zeros(p + 1)
    odd_v = np.zeros(p + 1)
    for i in range(n_pl):
        k = int(pl_r[i, 3])
        f = face_of(el_nrm, k)
        span = spans[f]
        forward = forwards[f]
        t = pl_r[i, 4]
        w1 = pl_r[i, 5]
        w2 = pl_r[i, 6]
        t_bed = pl_r[i, 7]
        x = (pl_s[i] - s_lo[f]) / span
        if el_whole[k] > 0.0 and t >= 0.5 * (w1 + w2) and t_bed <= -0.5 * (w1 + w2):
            pitch = el_t1[k, 0] / FACE_SUBDIVISION  # [m] between the pieces' centres
            if el_t1[k, 0] != grid_side or f != grid_face:
                grid_side = el_t1[k, 0]
                grid_face = f
                _grid_moments(pitch * sx / span, pitch * sy / span, even, odd_u, odd_v)
                for j in range(p + 1):  # C(p, j) folded in once, not per square
                    c = _binomial(p, j)
                    even[j] *= c
                    odd_u[j] *= c
                    odd_v[j] *= c
            mean_w = 0.0
            su = 0.0
            sv = 0.0
            for j in range(p + 1):  # sum over j of C(p, j) x^(p - j) times the grid's j-th moments
                c = x ** (p - j)
                mean_w += c * even[j]
                su += c * odd_u[j]
                sv += c * odd_v[j]
            mean_w = (1.0 - forward) + forward * (p + 1) * mean_w
            du = forward * (p + 1) * pitch * su / mean_w
            dv = forward * (p + 1) * pitch * sv / mean_w
        elif n_sub <= FACE_PIECES:  # its pieces' shares kept by _element_pass
            mean_w, du, dv = _weight_of_pieces(el_sub, k, pl_r[i, PL_PIECES:PL_PIECES + n_sub], x, sx / span,
                                               sy / span, forward)
        else:
            mean_w, du, dv = _pieces_weight(el_sub, k, t, w1, w2, x, sx / span, sy / span, pl_r[i, PL_SLOPE],
                                            pl_r[i, PL_SLOPE + 1], wet_ramp, forward,
                                            t_bed)
        total[f] += pl_m[i]
        weighted[f] += mean_w * pl_m[i]
        add_wrench(acc[f], pl_r[i, 0] + axes[0, 0] * du + axes[0, 1] * dv,
                   pl_r[i, 1] + axes[1, 0] * du + axes[1, 1] * dv, pl_r[i, 2] + axes[2, 0] * du + axes[2, 1] * dv,
                   mean_w * pl_f[i, 0], mean_w * pl_f[i, 1], mean_w * pl_f[i, 2])
    for f in range(2):
        if total[f] > 0.0:
            scale = total[f] / weighted[f] if weighted[f] > 0.0 else 1.0
            for q in range(6):
                fp[q] += scale * acc[f, q]


@njit(cache=True)
def evaluate(shape, radius, thickness, centre, axes, velocity, omega, half_x, half_y, x_low, y_low, z_low,
             x0, y0, cell, height, wvel, bottom,
             el_pos, el_nrm, el_area, el_t1, el_t2, el_sub, el_whole, world_fixed,
             rho, g, c_l, c_n, c_b, c_f, c_w, c_min, wet_ramp, flags, nsub,
             b_geo, waterline, stats, planing, c_d, wave_depth):
    """:func:`evaluate_into` with work arrays of its own."""
    n_el = el_area.shape[0]
    evaluate_into(shape, radius, thickness, centre, axes, velocity, omega, half_x, half_y, x_low, y_low, z_low,
                  x0, y0, cell, height, wvel, bottom, el_pos, el_nrm, el_area, el_t1, el_t2, el_sub, el_whole,
                  world_fixed,
                  rho, g, c_l, c_n, c_b, c_f, c_w, c_min, wet_ramp, flags, nsub, b_geo, waterline, stats, planing, c_d,
                  wave_depth, np.empty((n_el, 3)), np.empty((n_el, PLANING_PLACE)), np.empty(n_el), np.empty(n_el))


@njit(cache=True)
def evaluate_into(shape, radius, thickness, centre, axes, velocity, omega, half_x, half_y, x_low, y_low, z_low,
                  x0, y0, cell, height, wvel, bottom,
                  el_pos, el_nrm, el_area, el_t1, el_t2, el_sub, el_whole, world_fixed,
                  rho, g, c_l, c_n, c_b, c_f, c_w, c_min, wet_ramp, flags, nsub,
                  b_geo, waterline, stats, planing, c_d, wave_depth, pl_f, pl_r, pl_s, pl_m):
    """Water forces on one body state over one patch; see the module docstring.

    centre (3,), velocity (3,), omega (3,) world [m, m/s, rad/s]; axes (3, 3) body->world rotation
    (columns = body axes); half_x, half_y: horizontal half-extents of the body [m]; z_low: its
    lowest point (x_low, y_low, z_low) [m]; x0, y0: centre of the patch's first column [m]; height,
    wvel, bottom: (nj, ni) patch arrays; el_*: the body's surface elements; nsub: sub-cells per
    column side; planing [-]: the share of the pressure that is the planing law (1 while the body
    pierces the surface), the rest (1 - planing) is the submerged pressure drag of coefficient c_d
    (``-1/2 rho c_d (u.n) u dA``, see :mod:`components.coupler.forces`); wave_depth [m]: how far the
    body's top is under the surface (0 while it pierces it; the wave drag's depth,
    :func:`components.coupler.forces.wave_drag_magnitude`). Writes b_geo (nj, ni) [m] (zero where dry) and
    stats (N_STATS,); and, unless it is
    empty, waterline (3, nj, ni): per column, the area [m^2] of its sub-columns the surface cuts
    through the body and that area's first moments about the centre, sum dx a and sum dy a [m^3].
    pl_f (N, 3), pl_r (N, PLANING_PLACE), pl_s, pl_m (N,): work arrays for the elements' planing
    loads (force; lever arm and what places the load on the element's pieces; place along the flow;
    magnitude), N the number of elements.
    """
    empty, hmax = _prologue(stats, b_geo, waterline, height, wvel, bottom, x_low, y_low, x0, y0, cell)
    if empty:
        return
    if flags & (DISPLACEMENT | BUOYANCY | WAVE_DRAG):
        _column_passes(shape, radius, thickness, centre, axes, velocity, half_x, half_y, z_low, x0, y0, cell,
                       height, bottom, rho, g, c_w, c_min, nsub, flags, b_geo, waterline, stats, wave_depth,
                       0.0, 0, b_geo, waterline, stats)
    if flags & (PRESSURE | FRICTION):
        _element_pass(shape, radius, centre, axes, velocity, omega, x0, y0, cell, height, wvel,
                      bottom, hmax, el_pos, el_nrm, el_area, el_t1, el_t2, el_sub, el_whole, world_fixed, rho, g, c_l,
                      c_n, c_b, c_f,
                      wet_ramp, flags, stats, planing, c_d, pl_f, pl_r, pl_s, pl_m)
    _totals(stats)


@njit(cache=True)
def evaluate_with_rest(shape, radius, thickness, centre, axes, velocity, omega, half_x, half_y, x_low, y_low,
                       z_low, x0, y0, cell, height, wvel, bottom, el_pos, el_nrm, el_area, el_t1, el_t2,
                       el_sub, el_whole, world_fixed, rho, g, c_l, c_n, c_b, c_f, c_w, c_min, wet_ramp, flags, nsub,
                       b_geo, stats, planing, c_d, wave_depth, pl_f, pl_r, pl_s, pl_m,
                       rest_level, flat, still, rest_flags, b_rest, rest_waterline, rest_stats, box):
    """:func:`evaluate_into` (no waterline) and, when the body reaches below ``rest_level``, the rest
    pass: :func:`evaluate_into` of the body at rest (zero velocity) against the flat surface
    ``flat`` (nj, ni) at the rest level with ``rest_flags`` (column effects only) into b_rest,
    rest_waterline and rest_stats (all zero when it does not reach). The two passes share one loop
    over the columns (:func:`_column_passes`); each one's results are those of a call of its own,
    bit for bit.

    ``box`` (4,) holds the columns (i_lo, i_hi, j_lo, j_hi) the previous call may have written in
    b_geo, b_rest and rest_waterline, everywhere else zero: only those are cleared, in all three
    planes at every call (the planes span the whole patch, the body a few of its columns), and the
    box of this call is put in its place.
    """
    do_rest = z_low < rest_level
    nj, ni = height.shape
    # all three every call, the rest planes too when this call has no rest pass: the box moves on,
    # and what it leaves behind must be zero
    clear_box(b_geo, box)
    clear_box(b_rest, box)
    for q in range(rest_waterline.shape[0]):
        clear_box(rest_waterline[q], box)
    i_lo, i_hi, j_lo, j_hi = _column_box(centre[0], centre[1], half_x, half_y, x0, y0, cell, nj, ni)
    box[0], box[1], box[2], box[3] = i_lo, i_hi, j_lo, j_hi
    empty, hmax = _surface_stats(stats, height, wvel, bottom, x_low, y_low, x0, y0, cell)
    if do_rest:
        _surface_stats(rest_stats, flat, still, bottom, x_low, y_low, x0, y0, cell, rest_level)
    else:
        rest_stats[:] = 0.0
    if empty:
        return
    columns = (flags & (DISPLACEMENT | BUOYANCY | WAVE_DRAG)) != 0
    rest_columns = do_rest and (rest_flags & (DISPLACEMENT | BUOYANCY | WAVE_DRAG)) != 0
    if columns or rest_columns:
        _column_passes(shape, radius, thickness, centre, axes, velocity, half_x, half_y, z_low, x0, y0, cell,
                       height, bottom, rho, g, c_w, c_min, nsub, flags if columns else 0, b_geo,
                       np.zeros((0, 0, 0)), stats, wave_depth, rest_level, rest_flags if rest_columns else 0, b_rest,
                       rest_waterline, rest_stats)
    if flags & (PRESSURE | FRICTION):
        _element_pass(shape, radius, centre, axes, velocity, omega, x0, y0, cell, height, wvel,
                      bottom, hmax, el_pos, el_nrm, el_area, el_t1, el_t2, el_sub, el_whole, world_fixed, rho, g, c_l,
                      c_n, c_b, c_f,
                      wet_ramp, flags, stats, planing, c_d, pl_f, pl_r, pl_s, pl_m)
    _totals(stats)
    if do_rest:
        _totals(rest_stats)


@njit(cache=True)
def _prologue(stats, b_geo, waterline, height, wvel, bottom, x_low, y_low, x0, y0, cell):
    """Clear a pass's stats, occupied height and waterline (when not empty), and put in the patch's
    highest surface and the surface at the body's lowest point; (the patch is empty, its highest
    surface)."""
    b_geo[:, :] = 0.0
    if waterline.size > 0:
        waterline[:, :, :] = 0.0
    return _surface_stats(stats, height, wvel, bottom, x_low, y_low, x0, y0, cell)


@njit(cache=True)
def _surface_stats(stats, height, wvel, bottom, x_low, y_low, x0, y0, cell, level=np.nan):
    """Clear ``stats`` and put in the patch's highest surface and the surface at the body's lowest
    point (none, NaN, over dry land: no water above the bed ``bottom`` there); (the patch is empty,
    its highest surface). A ``level`` [m] given says every column of ``height`` is at it (the rest
    pass's flat surface): its highest surface is then found without a scan."""
    stats[:] = 0.0
    nj, ni = height.shape
    stats[S_SURFACE_LOW] = np.nan
    if nj == 0 or ni == 0:
        return True, -np.inf
    hmax = level
    if math.isnan(level):
        hmax = -np.inf
        for j in range(nj):
            for i in range(ni):
                hmax = max(hmax, height[j, i])
    stats[S_HMAX] = hmax
    ok, h_low, _, depth = sample_water(x_low, y_low, x0, y0, cell, height, wvel, bottom)
    if ok and depth > 0.0:
        stats[S_SURFACE_LOW] = h_low
    return False, hmax


@njit(cache=True)
def clear_box(plane, box):
    """Zero ``plane`` (nj, ni) over the columns i_lo..i_hi, j_lo..j_hi of ``box`` (4,), clipped to
    the plane (empty when lo > hi)."""
    nj, ni = plane.shape
    i_lo, i_hi = max(0, int(box[0])), min(ni - 1, int(box[1]))
    j_lo, j_hi = max(0, int(box[2])), min(nj - 1, int(box[3]))
    for j in range(j_lo, j_hi + 1):
        row = plane[j]
        for i in range(i_lo, i_hi + 1):
            row[i] = 0.0


@njit(cache=True, inline="always")
def _column_box(cx, cy, half_x, half_y, x0, y0, cell, nj, ni):
    """The columns (i_lo, i_hi, j_lo, j_hi) of an (nj, ni) patch whose centres lie within the body's
    horizontal half-extents of its centre (cx, cy) [m], to the nearest column: those a column pass
    visits (empty when lo > hi)."""
    i_lo = max(0, math.floor((cx - half_x - x0) / cell + 0.5))
    i_hi = min(ni - 1, math.floor((cx + half_x - x0) / cell + 0.5))
    j_lo = max(0, math.floor((cy - half_y - y0) / cell + 0.5))
    j_hi = min(nj - 1, math.floor((cy + half_y - y0) / cell + 0.5))
    return i_lo, i_hi, j_lo, j_hi


@njit(cache=True)
def _totals(stats):
    """The sum of the switched-on effects' forces and torques."""
    for q in range(6):
        stats[S_TOTAL + q] = stats[S_BUOYANCY + q] + stats[S_PRESSURE + q] + stats[S_FRICTION + q] \
            + stats[S_WAVE + q]


@njit(cache=True, inline="always")
def _column_dry(shape, hcol, z_low, xc, yc, cx, cy, cz, base, gx, gy, slack, radius, cell):
    """Whether the body certainly stays above ``hcol`` [m] over the column centred at (xc, yc): a
    lower bound of its lowest point there (a disk's lower slab face is a plane z = cz + base +
    gx dx + gy dy; a sphere's bottom is lowest at the column's nearest point to the centre) is at or
    above it."""
    if z_low >= hcol:
        return True
    if shape == SHAPE_DISK:
        return cz + base + gx * (xc - cx) + gy * (yc - cy) - slack >= hcol
    nx_ = max(abs(xc - cx) - 0.5 * cell, 0.0)
    ny_ = max(abs(yc - cy) - 0.5 * cell, 0.0)
    rn2 = nx_ * nx_ + ny_ * ny_
    return rn2 < radius * radius and cz - math.sqrt(radius * radius - rn2) >= hcol


@njit(cache=True)
def _column_passes(shape, radius, thickness, centre, axes, velocity, half_x, half_y, z_low, x0, y0, cell,
                   height, bottom, rho, g, c_w, c_min, nsub, flags, b_geo, waterline, stats, wave_depth,
                   rest_level, rest_flags, b_rest, rest_waterline, rest_stats):
    """The columns' part of :func:`evaluate_into` (occupied height, buoyancy, submerged volume, wave
    drag) against ``height`` (nj, ni) with ``flags`` (0: not this pass) into b_geo, waterline (when
    not empty) and stats, and, when ``rest_flags`` is not 0, the same against a flat surface at
    ``rest_level`` [m] into b_rest, rest_waterline and rest_stats: one loop over the columns, each
    sub-column's chord through the body found once for both passes. Each pass adds up its sums in
    the order of a pass of its own."""
    nj, ni = height.shape
    cx, cy, cz = centre[0], centre[1], centre[2]
    ax, ay, az = axes[0, 2], axes[1, 2], axes[2, 2]
    live = flags != 0
    rest = rest_flags != 0
    i_lo, i_hi, j_lo, j_hi = _column_box(cx, cy, half_x, half_y, x0, y0, cell, nj, ni)
    sub = cell / nsub
    a_sub = sub * sub
    by_column = waterline.size > 0
    rest_by_column = rest_waterline.size > 0
    fz = tx = ty = vol = mx = my = mz = wl = 0.0
    r_fz = r_tx = r_ty = r_vol = r_mx = r_my = r_mz = r_wl = 0.0
    ncol = 0
    r_ncol = 0
    # columns whose lowest body point is bounded from below above their surface are dry, skipped
    # (_column_dry)
    if shape == SHAPE_DISK and abs(az) > 1e-3:
        gx = -ax / az
        gy = -ay / az
        base = -0.5 * thickness / abs(az)
        slack = 0.5 * cell * (abs(gx) + abs(gy))
    else:
        gx = 0.0
        gy = 0.0
        base = z_low - cz
        slack = 0.0
    # the sub-columns' offsets from their column's centre [m], the same for every column: worked out
    # once, not one division per sub-column (a third of the pass's time for a ball on 3 x 3)
    offset = np.empty(nsub)
    for s in range(nsub):
        offset[s] = ((s + 0.5) / nsub - 0.5) * cell
    for j in range(j_lo, j_hi + 1):
        yc = y0 + j * cell
        for i in range(i_lo, i_hi + 1):
            hcol = height[j, i]
            xc = x0 + i * cell
            wet = live and not _column_dry(shape, hcol, z_low, xc, yc, cx, cy, cz, base, gx, gy, slack,
                                           radius, cell)
            r_wet = rest and not _column_dry(shape, rest_level, z_low, xc, yc, cx, cy, cz, base, gx, gy,
                                             slack, radius, cell)
            if not (wet or r_wet):
                continue
            ncol += wet
            r_ncol += r_wet
            bed = bottom[j, i]
            bsum = 0.0
            r_bsum = 0.0
            for sa in range(nsub):
                xs = xc + offset[sa]
                dx = xs - cx
                for sb in range(nsub):
                    ys = yc + offset[sb]
                    dy = ys - cy
                    lo, hi = _chord(shape, dx, dy, ax, ay, az, radius, thickness)
                    if lo >= hi:
                        continue
                    zlo = cz + lo
                    zhi = cz + hi
                    bot = max(zlo, bed)
                    if wet:
                        top = min(zhi, hcol)
                        if not top <= bot:
                            w = top - bot
                            bsum += w
                            dv = w * a_sub
                            vol += dv
                            zm = 0.5 * (top + bot)
                            mx += xs * dv
                            my += ys * dv
                            mz += zm * dv
                            f = rho * g * dv
                            fz += f
                            tx += dy * f
                            ty -= dx * f
                            if zlo < hcol < zhi:
                                wl += a_sub
                                if by_column:
                                    waterline[0, j, i] += a_sub
                                    waterline[1, j, i] += dx * a_sub
                                    waterline[2, j, i] += dy * a_sub
                    if r_wet:
                        top = min(zhi, rest_level)
                        if not top <= bot:
                            w = top - bot
                            r_bsum += w
                            dv = w * a_sub
                            r_vol += dv
                            zm = 0.5 * (top + bot)
                            r_mx += xs * dv
                            r_my += ys * dv
                            r_mz += zm * dv
                            f = rho * g * dv
                            r_fz += f
                            r_tx += dy * f
                            r_ty -= dx * f
                            if zlo < rest_level < zhi:
                                r_wl += a_sub
                                if rest_by_column:
                                    rest_waterline[0, j, i] += a_sub
                                    rest_waterline[1, j, i] += dx * a_sub
                                    rest_waterline[2, j, i] += dy * a_sub
            if wet:
                b_geo[j, i] = bsum / (nsub * nsub)
            if r_wet:
                b_rest[j, i] = r_bsum / (nsub * nsub)
    if shape == SHAPE_SPHERE:
        # the water's pressure on a sphere acts along its normals, all through its centre: no torque about
        # it. The columns' sum (each sub-column's weight of water at its place) has one only as sampling
        # error, which grew with the ball's place on the grid and set a ball resting on a bed rolling
        tx = ty = r_tx = r_ty = 0.0
    if live:
        _column_stats(stats, flags, vol, mx, my, mz, wl, ncol, fz, tx, ty, velocity, radius, rho, g, c_w, c_min,
                      cx, cy, cz, shape == SHAPE_SPHERE, wave_depth)
    if rest:
        _column_stats(rest_stats, rest_flags, r_vol, r_mx, r_my, r_mz, r_wl, r_ncol, r_fz, r_tx, r_ty,
                      np.zeros(3), radius, rho, g, c_w, c_min, cx, cy, cz, shape == SHAPE_SPHERE, 0.0)


@njit(cache=True)
def _column_stats(stats, flags, vol, mx, my, mz, wl, ncol, fz, tx, ty, velocity, radius, rho, g, c_w, c_min,
                  cx, cy, cz, through_centre, wave_depth):
    """A column pass's sums into ``stats``: volume, centroid, waterline, columns; the buoyancy and
    its stiffness and the wave drag when switched on, the wave drag at the submerged centroid, or
    through the centre when ``through_centre`` (a sphere: the waves' pressure, as all pressure on
    it, acts along its normals; at the centroid it rolled a pushed floating ball and, spun backwards,
    gave it energy), faded with the depth ``wave_depth`` [m] of the body's top under the surface."""
    stats[S_VOLUME] = vol
    stats[S_CENTROID] = mx
    stats[S_CENTROID + 1] = my
    stats[S_CENTROID + 2] = mz
    stats[S_WATERLINE] = wl
    stats[S_COLUMNS] = ncol
    if flags & BUOYANCY:
        stats[S_BUOYANCY + 2] = fz
        stats[S_BUOYANCY + 3] = tx
        stats[S_BUOYANCY + 4] = ty
        stats[S_STIFF] += rho * g * wl
    if flags & WAVE_DRAG and vol > 0.0:
        vx = velocity[0]
        vy = velocity[1]
        speed = math.sqrt(vx * vx + vy * vy)
        mag = wave_drag_magnitude(speed, vol, 2.0 * radius, rho, c_w, c_min, g, wave_depth)
        if mag > 0.0:
            fx = -mag * vx / speed
            fy = -mag * vy / speed
            rx = mx / vol - cx
            ry = my / vol - cy
            rz = mz / vol - cz
            stats[S_WAVE] = fx
            stats[S_WAVE + 1] = fy
            if not through_centre:
                stats[S_WAVE + 3] = -rz * fy
                stats[S_WAVE + 4] = rz * fx
                stats[S_WAVE + 5] = rx * fy - ry * fx


@njit(cache=True)
def _element_pass(shape, radius, centre, axes, velocity, omega, x0, y0, cell, height, wvel,
                  bottom, hmax, el_pos, el_nrm, el_area, el_t1, el_t2, el_sub, el_whole, world_fixed, rho, g, c_l,
                  c_n, c_b, c_f,
                  wet_ramp, flags, stats, planing, c_d, pl_f, pl_r, pl_s, pl_m):
    """The surface elements' part of :func:`evaluate_into`: pressure and friction into ``stats``.

    An element meets the water between the bed (``bottom``) and the surface (``height``) only: over
    dry land (no water above the bed, a beach above the rest level) none, and at a shore's thin
    layer only the part of it above the bed (the rest is in the ground), as the buoyancy's columns
    are clipped at the bed. On a pond whose bed lies below every element nothing is cut."""
    cx, cy, cz = centre[0], centre[1], centre[2]
    ax, ay, az = axes[0, 2], axes[1, 2], axes[2, 2]
    if flags & (PRESSURE | FRICTION):
        wx, wy, wz = omega[0], omega[1], omega[2]
        if shape == SHAPE_DISK:
            spin = wx * ax + wy * ay + wz * az
            px_, py_, pz_ = wx - spin * ax, wy - spin * ay, wz - spin * az
            # a disk (faces and rim) follows the planing law measured on it
            c_lin, c_sq = c_l, c_n
        else:
            px_, py_, pz_ = 0.0, 0.0, 0.0
            # a sphere has no lifting face: it meets the water as a blunt body, the impact pressure
            # 1/2 rho C_B (u.n)^2 alone (see components.coupler.forces)
            c_lin, c_sq = 0.0, c_b
        vx, vy, vz = velocity[0], velocity[1], velocity[2]
        n_el = el_area.shape[0]
        # the planing pressure of each disk face element (force, lever arm, place along the flow:
        # pl_*), weighted towards the spray root once the wetted area's extent along the flow is known
        # (see _spread_planing), piece by piece of the element (Elements.sub)
        n_pl = 0
        hspeed = math.sqrt(vx * vx + vy * vy)
        # a disk leans towards its lowest point (its axis tilted the other way); a sphere does not
        lean = -az if shape == SHAPE_DISK else 0.0
        hx, hy, root_share = _spray_root(lean * ax, lean * ay, vx, vy, hspeed)
        # a face piece's offset (du, dv) along body x and y moves it by du sx + dv sy along the flow
        # and by du zx + dv zy in height
        sx, sy = axes[0, 0] * hx + axes[1, 0] * hy, axes[0, 1] * hx + axes[1, 1] * hy
        zx, zy = axes[2, 0], axes[2, 1]
        n_sub = el_sub.shape[1]
        piece_wet = np.zeros(n_sub)  # the wetted shares of a partly wet face square's pieces
        s_lo = np.full(2, math.inf)  # each face's wetted extent along the flow (face_of)
        s_hi = np.full(2, -math.inf)
        do_p = (flags & PRESSURE) != 0
        do_f = (flags & FRICTION) != 0
        fp = np.zeros(6)
        ff = np.zeros(6)
        area = 0.0
        adv = 0.0
        d_lin = 0.0
        d_rot = 0.0
        stiff = 0.0
        nel = 0
        for k in range(n_el):
            if world_fixed:
                rx, ry, rz = el_pos[k, 0], el_pos[k, 1], el_pos[k, 2]
                t1z = el_t1[k, 2]
                t2z = el_t2[k, 2]
            else:
                u, v, w = el_pos[k, 0], el_pos[k, 1], el_pos[k, 2]
                rz = axes[2, 0] * u + axes[2, 1] * v + axes[2, 2] * w
                t1z = axes[2, 0] * el_t1[k, 0] + axes[2, 1] * el_t1[k, 1] + axes[2, 2] * el_t1[k, 2]
                t2z = axes[2, 0] * el_t2[k, 0] + axes[2, 1] * el_t2[k, 1] + axes[2, 2] * el_t2[k, 2]
            # a disk's face (its normal along the axis, in the body frame), not its rim
            face = shape == SHAPE_DISK and abs(el_nrm[k, 2]) > 0.5
            w1, w2 = _height_ranges(t1z, t2z, face, wet_ramp)
            half = 0.5 * (w1 + w2)
            pz = cz + rz
            if pz - half >= hmax:
                continue  # above the highest surface of the patch: dry
            if not world_fixed:
                rx = axes[0, 0] * u + axes[0, 1] * v + axes[0, 2] * w
                ry = axes[1, 0] * u + axes[1, 1] * v + axes[1, 2] * w
            ok, h, wv, depth, gx, gy = sample_water_slope(cx + rx, cy + ry, x0, y0, cell, height, wvel, bottom)
            if not ok:
                continue
            # the element's and its pieces' heights over the surface's plane through its centre, not
            # over a level one (each 6 mm square of a disk face read the surface at its centre and
            # wetted its pieces against that level: on a slope of 0.1 the wetted area was 4% short
            # to 5% over, and turned with the face's tiling); on level water the same to the bit
            zxk, zyk = zx, zy
            if gx != 0.0 or gy != 0.0:
                if world_fixed:
                    t1z -= gx * el_t1[k, 0] + gy * el_t1[k, 1]
                    t2z -= gx * el_t2[k, 0] + gy * el_t2[k, 1]
                else:
                    t1z -= (gx * (axes[0, 0] * el_t1[k, 0] + axes[0, 1] * el_t1[k, 1] + axes[0, 2] * el_t1[k, 2])
                            + gy * (axes[1, 0] * el_t1[k, 0] + axes[1, 1] * el_t1[k, 1] + axes[1, 2] * el_t1[k, 2]))
                    t2z -= (gx * (axes[0, 0] * el_t2[k, 0] + axes[0, 1] * el_t2[k, 1] + axes[0, 2] * el_t2[k, 2])
                            + gy * (axes[1, 0] * el_t2[k, 0] + axes[1, 1] * el_t2[k, 1] + axes[1, 2] * el_t2[k, 2]))
                w1, w2 = _height_ranges(t1z, t2z, face, wet_ramp)
                half = 0.5 * (w1 + w2)
                zxk = zx - (gx * axes[0, 0] + gy * axes[1, 0])
                zyk = zy - (gx * axes[0, 1] + gy * axes[1, 1])
            t = h - pz
            if t <= -half or not depth > 0.0:
                continue  # above the surface, or over dry land: no water to meet
            # the bed's level over the element's centre: above the element's lowest point (a shore's thin
            # layer, a body pressed onto the bed) it cuts the element, whose part under it is in the
            # ground, not in the water
            t_bed = t - depth
            cut = t_bed > -half
            if face and (t < half or cut) and n_sub > 0:
                # a disk face's square partly under: its wetted fraction summed over its pieces, each
                # under by its own height range; a square clipped by the rim is then wetted where
                # its part of the disk lies, not as a whole square about its centroid would be
                _pieces_wet(el_sub, k, t, t_bed, w1, w2, zxk, zyk, wet_ramp, piece_wet)
                frac = 0.0
                for q in range(n_sub):
                    frac += piece_wet[q]
                if frac <= 0.0:
                    continue
            else:
                frac = box_coverage(t, w1, w2)
                if cut:
                    frac -= box_coverage(t_bed, w1, w2)
                    if frac <= 0.0:
                        continue
            # the water's vertical speed at the element's height: the surface's, falling linearly to
            # 0 at the bed. That is the long-wave profile (continuity through a layer whose horizontal
            # flow is uniform over its depth), and shorter waves fall off faster (sinh(k z) / sinh(k H)
            # <= z / H), so it is the most a wave can move the water at that depth. A body under the
            # surface then meets the water as it is where the body is: a ball on the bed of a pond
            # is not pushed by the surface's bobbing 24 cm above it
            if t > 0.0:
                wv *= max(1.0 - t / depth, 0.0)
            nel += 1
            a_el = el_area[k]
            fa = frac * a_el
            area += fa
            if world_fixed:
                nx, ny, nz = el_nrm[k, 0], el_nrm[k, 1], el_nrm[k, 2]
            else:
                n0, n1, n2 = el_nrm[k, 0], el_nrm[k, 1], el_nrm[k, 2]
                nx = axes[0, 0] * n0 + axes[0, 1] * n1 + axes[0, 2] * n2
                ny = axes[1, 0] * n0 + axes[1, 1] * n1 + axes[1, 2] * n2
                nz = axes[2, 0] * n0 + axes[2, 1] * n1 + axes[2, 2] * n2
            if do_p:
                # point velocity without the spin that slides the surface along itself
                ux = vx + py_ * rz - pz_ * ry
                uy = vy + pz_ * rx - px_ * rz
                uz = vz + px_ * ry - py_ * rx - wv
                un = ux * nx + uy * ny + uz * nz
                if un > 0.0:
                    speed = math.sqrt(ux * ux + uy * uy + uz * uz)
                    p = planing * pressure_magnitude(speed, un, rho, c_lin, c_sq)
                    if p > 0.0 and face:
                        # a disk face: its planing load is spread towards the spray root below
                        pl_f[n_pl, 0] = -p * fa * nx
                        pl_f[n_pl, 1] = -p * fa * ny
                        pl_f[n_pl, 2] = -p * fa * nz
                        pl_r[n_pl, 0] = rx
                        pl_r[n_pl, 1] = ry
                        pl_r[n_pl, 2] = rz
                        pl_r[n_pl, 3] = k
                        pl_r[n_pl, 4] = t
                        pl_r[n_pl, 5] = w1
                        pl_r[n_pl, 6] = w2
                        pl_r[n_pl, 7] = t_bed
                        pl_r[n_pl, PL_SLOPE] = zxk
                        pl_r[n_pl, PL_SLOPE + 1] = zyk
                        if n_sub <= FACE_PIECES and not (el_whole[k] > 0.0 and t >= half and not cut):
                            # the pieces' shares _spread_planing weighs (not in closed form): those above
                            # when the square is partly under or cut, else (a clipped square wholly
                            # under) each piece's own share
                            if t < half or cut:
                                for q in range(n_sub):
                                    pl_r[n_pl, PL_PIECES + q] = piece_wet[q]
                            else:
                                _pieces_wet(el_sub, k, t, t_bed, w1, w2, zxk, zyk, wet_ramp,
                                            pl_r[n_pl, PL_PIECES:PL_PIECES + n_sub])
                        s_el = rx * hx + ry * hy
                        pl_s[n_pl] = s_el
                        pl_m[n_pl] = p * fa
                        n_pl += 1
                        # the wetted area's extent along the flow, from its wet pieces
                        f = face_of(el_nrm, k)
                        if t >= half and el_whole[k] > 0.0 and not cut:
                            # all under, its outermost pieces (m - 1) / 2m of a side from its centre
                            reach_s = (0.5 - 0.5 / FACE_SUBDIVISION) * el_t1[k, 0] * (abs(sx) + abs(sy))
                            s_lo[f] = min(s_lo[f], s_el - reach_s)
                            s_hi[f] = max(s_hi[f], s_el + reach_s)
                        else:
                            for q in range(n_sub):
                                if (piece_wet[q] if t < half or cut else el_sub[k, q, 2]) > 0.0:
                                    s_q = s_el + el_sub[k, q, 0] * sx + el_sub[k, q, 1] * sy
                                    s_lo[f] = min(s_lo[f], s_q)
                                    s_hi[f] = max(s_hi[f], s_q)
                    elif p > 0.0:
                        # the rim, or a sphere: the pressure where it acts
                        add_wrench(fp, rx, ry, rz, -p * fa * nx, -p * fa * ny, -p * fa * nz)
                    # submerged: a pressure drag along -u on the face's projected area (u.n / |u|) dA
                    kd = (1.0 - planing) * 0.5 * rho * c_d * un * fa
                    if shape == SHAPE_DISK:
                        add_wrench(fp, rx, ry, rz, -kd * ux, -kd * uy, -kd * uz)
                    else:
                        # a sphere's: a pressure, normal to its surface, so through its centre
                        add_wrench(fp, 0.0, 0.0, 0.0, -kd * ux, -kd * uy, -kd * uz)
                    adv += fa
                    ce = rho * (planing * (c_lin * speed + c_sq * un) + (1.0 - planing) * c_d * speed) * fa
                    cxn = ry * nz - rz * ny
                    cyn = rz * nx - rx * nz
                    czn = rx * ny - ry * nx
                    d_lin += ce
                    d_rot += ce * (cxn * cxn + cyn * cyn + czn * czn)
                    dens = box_density(t, w1, w2)
                    if cut:  # the wetted share changes with depth at the bed's edge too (a bound, not a sum)
                        dens += box_density(t_bed, w1, w2)
                    stiff += p * a_el * dens
            if do_f:
                ux = vx + wy * rz - wz * ry
                uy = vy + wz * rx - wx * rz
                uz = vz + wx * ry - wy * rx - wv
                un = ux * nx + uy * ny + uz * nz
                utx = ux - un * nx
                uty = uy - un * ny
                utz = uz - un * nz
                speed = math.sqrt(ux * ux + uy * uy + uz * uz)
                kf = 0.5 * rho * c_f * speed * fa
                if un < 0.0 and planing > 0.0:
                    # at the mean depth of its wetted part: a partly wet element whose centre is above
                    # the surface still has water on it (its depth taken as 0, the factor fell from 1
                    # to 0 as u.n went from 0 to -1e-17, and a spinning disk's rim strips, sliding
                    # along themselves, lost their friction by the sign of a rounding). Only while the
                    # body pierces the surface (its planing share): air reaches a cavity behind it
                    # from there; a body wholly under water drags water behind it, not air, and the
                    # measured submerged drag the pressure effect takes over (c_d) leaves its whole
                    # skin friction to this effect
                    vent = ventilation(un, t if t >= half else 0.5 * (t + half), g)
                    kf *= 1.0 - planing * (1.0 - vent)
                dfx = -kf * utx
                dfy = -kf * uty
                dfz = -kf * utz
                add_wrench(ff, rx, ry, rz, dfx, dfy, dfz)
                d_lin += 2.0 * kf
                d_rot += 2.0 * kf * (rx * rx + ry * ry + rz * rz)
        if n_pl > 0:
            # planing: the body skims forward, faster than its own gravity waves (a Froude number
            # U / sqrt(g L) above 1); a floating or dropped body presses the water evenly
            forward = root_share * hspeed * hspeed / (hspeed * hspeed + vz * vz + 2.0 * g * radius)
            _spread_planing(fp, pl_f, pl_r, pl_s, pl_m, n_pl, el_sub, el_whole, el_t1, el_nrm, axes, sx, sy,
                            wet_ramp, s_lo, s_hi, forward)
        if do_p:
            for q in range(6):
                stats[S_PRESSURE + q] = fp[q]
        if do_f:
            for q in range(6):
                stats[S_FRICTION + q] = ff[q]
        stats[S_AREA] = area
        stats[S_ADVANCING] = adv
        stats[S_DAMP_LIN] = d_lin
        stats[S_DAMP_ROT] = d_rot
        stats[S_STIFF] += stiff
        stats[S_ELEMENTS] = nel


@njit(cache=True)
def _outline(shape, radius, thickness, axes):
    """The body's horizontal outline, an ellipse: unit vectors (tx, ty) along the disk and (sx, sy)
    across it (the tilt direction), and its half-axes a1, a2 [m] along them (a circle of the radius
    for a sphere or a flat disk)."""
    ax, ay, az = axes[0, 2], axes[1, 2], axes[2, 2]
    tx, ty, sx, sy = 1.0, 0.0, 0.0, 1.0
    a1 = radius
    a2 = radius
    if shape == SHAPE_DISK:
        sh = math.sqrt(ax * ax + ay * ay)
        if sh > 1e-9:
            sx, sy = ax / sh, ay / sh
            tx, ty = -sy, sx
        a2 = max(radius * abs(az) + 0.5 * thickness * sh, 1e-6 * radius)
    return tx, ty, sx, sy, a1, a2


@njit(cache=True)
def _polar(dx, dy, tx, ty, sx, sy, a1, a2):
    """Where (dx, dy) [m] from the centre lies against the outline: q, the outline's scale through
    the point (1 on it, < 1 inside), and the unit direction (c, s) of the point in the outline's
    normalised frame."""
    u = (dx * tx + dy * ty) / a1
    v = (dx * sx + dy * sy) / a2
    q = math.sqrt(u * u + v * v)
    if q < 1e-12:
        return 0.0, 1.0, 0.0
    return q, u / q, v / q


@njit(cache=True, inline="always")
def band_width(cells, share, cell, radius):
    """Half-width [m] of the displaced water's band around a body of ``radius`` [m] on columns of
    ``cell`` [m]: ``share`` of the radius, and at least ``cells`` columns.

    The water a body pushes aside rises within a distance set by the body, not by the columns; a band
    a fixed number of columns wide is a sharper source the finer the columns, and on 5 mm columns it
    fed the grid-scale waves that threw a slow, nearly sunk stone back out (docs/accuracy.md). The
    floor in columns keeps the band resolved on columns coarse against the body."""
    return max(cells * cell, share * radius)


@njit(cache=True)
def _ring_cells(shape, radius, thickness, centre, axes, x0, y0, cell, nj, ni, width):
    """The band of columns just outside the body's outline: tent weights phi over the distance d
    outside it (0 to 2 ``width`` [m], peak at ``width``), with each column's direction (c, s) in the
    outline's frame. Returns (n, index j, index i, phi, c, s), arrays of which the first n are used."""
    cx, cy = centre[0], centre[1]
    tx, ty, sx, sy, a1, a2 = _outline(shape, radius, thickness, axes)
    reach = 2.0 * width + cell
    # a column surely beyond the band is left before the root and the divisions below: its distance
    # outside the outline is at least (q - 1) min(a1, a2) (the outline's gradient there is at most
    # q / min(a1, a2)), so q >= 1 + 2 width / min(a1, a2) puts it 2 width out or more (the margin
    # keeps the test clear of d's rounding: the columns taken are the same to the bit)
    far = 1.0 + 2.0 * width / min(a1, a2)
    far2 = far * far * (1.0 + 1e-9)
    # q2 without its two divisions, to leave the columns surely inside (most of the body's box) or
    # surely beyond (its corners) before them: products by 1 / a^2 differ from the quotients squared by
    # a few roundings (1e-15 of q2), well inside the margin, so the columns kept are the same and their
    # q2 is still the one below (NaN or inf from a degenerate outline: the test falls through to it)
    a1a1 = a1 * a1
    a2a2 = a2 * a2
    inv_a1 = 1.0 / a1a1 if a1a1 > 0.0 else math.inf
    inv_a2 = 1.0 / a2a2 if a2a2 > 0.0 else math.inf
    inside = 1.0 - PREFILTER_MARGIN
    beyond = far2 * (1.0 + PREFILTER_MARGIN)
    i_lo = max(0, math.floor((cx - radius - reach - x0) / cell))
    i_hi = min(ni - 1, math.ceil((cx + radius + reach - x0) / cell))
    j_lo = max(0, math.floor((cy - radius - reach - y0) / cell))
    j_hi = min(nj - 1, math.ceil((cy + radius + reach - y0) / cell))
    size = max(0, (i_hi - i_lo + 1) * (j_hi - j_lo + 1))
    jj = np.empty(size, np.int64)
    ii = np.empty(size, np.int64)
    phi = np.empty(size)
    cs = np.empty(size)
    sn = np.empty(size)
    n = 0
    for j in range(j_lo, j_hi + 1):
        dy = y0 + j * cell - cy
        for i in range(i_lo, i_hi + 1):
            dx = x0 + i * cell - cx
            pu = dx * tx + dy * ty
            pv = dx * sx + dy * sy
            q2_near = pu * pu * inv_a1 + pv * pv * inv_a2
            if q2_near < inside or q2_near > beyond:
                continue
            # _polar
            un = pu / a1
            vn = pv / a2
            q2 = un * un + vn * vn
            if q2 <= 1.0 or q2 >= far2:
                continue
            q = math.sqrt(q2)
            u = pu / a1a1
            v = pv / a2a2
            d = (q - 1.0) / (math.sqrt(u * u + v * v) / q)  # distance outside the outline, to first order
            if d >= 2.0 * width:
                continue
            w = 1.0 - abs(d - width) / width
            if w <= 0.0:
                continue
            c, s = un / q, vn / q  # the direction, for the columns kept only
            jj[n] = j
            ii[n] = i
            phi[n] = w
            cs[n] = c
            sn[n] = s
            n += 1
    return n, jj, ii, phi, cs, sn


# The share column c gives band column k, phi_k (1 + alpha_c X_k + beta_c Y_k)^4 / T_c (alpha, beta: the
# column's scaled direction q (c, s); X, Y: the band column's direction), is a polynomial of degree
# RING_FOCUS in (X_k, Y_k): a sum over the monomials X^a Y^b (a + b <= 4) of a factor of the column
# times a factor of the band column. The shares matrix (columns x band) is then the product of a
# (columns x RING_TERMS) and a (band x RING_TERMS) matrix, and the deposit and the lift go through
# the RING_TERMS moments between them: work in columns + band, not columns x band (about 11,000
# shares a step for a 5 cm ball on 1 cm columns). The sums are those of the matrix to round-off.
RING_TERMS = (RING_FOCUS + 1) * (RING_FOCUS + 2) // 2  # monomials X^a Y^b with a + b <= RING_FOCUS
assert RING_FOCUS == 4, "_monomials is written out for RING_FOCUS = 4"


@njit(cache=True, inline="always")
def _monomials(x, y, scale, out):
    """out[m] = scale x^a y^b over the monomials (a, b), a + b <= RING_FOCUS, in the order n = a + b,
    then a (out: RING_TERMS,). Written out for RING_FOCUS = 4: in registers, not through ``out``."""
    y1 = scale * y
    y2 = y1 * y
    y3 = y2 * y
    out[0] = scale
    out[1] = y1
    out[2] = scale * x
    out[3] = y2
    out[4] = y1 * x
    out[5] = out[2] * x
    out[6] = y3
    out[7] = y2 * x
    out[8] = out[4] * x
    out[9] = out[5] * x
    out[10] = y3 * y
    out[11] = y3 * x
    out[12] = out[7] * x
    out[13] = out[8] * x
    out[14] = out[9] * x


def _multinomials() -> np.ndarray:
    """RING_FOCUS! / (a! b! (RING_FOCUS - a - b)!) per monomial X^a Y^b (RING_TERMS,): (1 + u + v)^p =
    sum of these times u^a v^b."""
    out = np.empty(RING_TERMS)
    fact = np.ones(RING_FOCUS + 1)
    for k in range(1, RING_FOCUS + 1):
        fact[k] = fact[k - 1] * k
    m = 0
    for n in range(RING_FOCUS + 1):
        for a in range(n + 1):
            out[m] = fact[RING_FOCUS] / (fact[a] * fact[n - a] * fact[RING_FOCUS - n])
            m += 1
    return out


MULTINOMIALS = _multinomials()  # a constant of the compiled ring map (made once, not at each call)


@njit(cache=True, inline="always")
def _column_factors(dx, dy, outline, moments, multinomial, out):
    """The column at (dx, dy) [m] from the centre: out (RING_TERMS,) such that its share of band column
    k is sum_m out[m] band[k, m] (:func:`ring_map_into`), its shares summing to 1 over the band
    (``moments``: the band's factors summed over it)."""
    tx, ty, sx, sy, a1, a2 = outline
    q, c, s = _polar(dx, dy, tx, ty, sx, sy, a1, a2)
    total = 0.0
    for scale in (min(q, 1.0), 0.0):
        # (1 + q (c X + s Y))^p = sum_m multinomial_m (q c)^a (q s)^b X^a Y^b
        _monomials(scale * c, scale * s, 1.0, out)
        total = 0.0
        for m in range(RING_TERMS):
            out[m] *= multinomial[m]
            total += out[m] * moments[m]
        if total > 0.0:
            break
        # on the outline with the whole band straight across (every share (1 - 1)^p = 0): spread
        # evenly, as a column at the centre does (a band's weights sum to more than 0)
    for m in range(RING_TERMS):
        out[m] /= total


@njit(cache=True)
def ring_map(shape, radius, thickness, centre, axes, x0, y0, cell, b_geo, width):
    """:func:`ring_map_into` with factors of its own."""
    nj, ni = b_geo.shape
    return ring_map_into(shape, radius, thickness, centre, axes, x0, y0, cell, b_geo, width, np.empty(0),
                         0, ni - 1, 0, nj - 1)


@njit(cache=True)
def ring_map_into(shape, radius, thickness, centre, axes, x0, y0, cell, b_geo, width, work, i_lo, i_hi, j_lo, j_hi):
    """Where each column's displaced volume goes: the linear map of :func:`ring_deposit` and
    :func:`ring_lift`, computed once a step for both.

    The band: columns just outside the body's outline, tent weights over the distance outside it (0
    to 2 ``width`` [m], peak at ``width``). Each column holding volume (occupied height b_geo > 0)
    gives band column k the share phi_k (1 + q cos)^RING_FOCUS, normalised over the band, with q the
    column's scale in the outline (clipped to 1) and the angle between the column's direction and
    the band column's, so a column at the centre spreads its volume evenly around the band, a
    skipping disk pushes water from its wet trailing edge (the only columns it occupies) and a
    rocking one from the side going down. Returns (band j, band i, column j, column i, column
    factors (columns, RING_TERMS), band factors (band, RING_TERMS)): the share of band column k in
    column c's volume is sum_m column[c, m] band[k, m], and a column's shares sum to 1 (see
    RING_TERMS). No band column in the window: an empty band (each column then keeps its volume, and
    the column factors are left unset: nothing reads them).
    The factors are written into ``work`` (1-D) when it is large enough ((columns + band) x
    RING_TERMS values), else into arrays of their own. Only the columns i_lo..i_hi, j_lo..j_hi of
    b_geo are read: it is zero outside them.
    """
    nj, ni = b_geo.shape
    n, jj, ii, phi, cs, sn = _ring_cells(shape, radius, thickness, centre, axes, x0, y0, cell, nj, ni, width)
    outline = _outline(shape, radius, thickness, axes)
    i_lo, i_hi, j_lo, j_hi = max(0, i_lo), min(ni - 1, i_hi), max(0, j_lo), min(nj - 1, j_hi)
    count = 0
    for j in range(j_lo, j_hi + 1):
        for i in range(i_lo, i_hi + 1):
            if b_geo[j, i] > 0.0:
                count += 1
    cj = np.empty(count, np.int64)
    ci = np.empty(count, np.int64)
    size = (count + n) * RING_TERMS
    store = work[:size] if work.size >= size else np.empty(size)
    band = store[:n * RING_TERMS].reshape((n, RING_TERMS))
    columns = store[n * RING_TERMS:].reshape((count, RING_TERMS))
    moments = np.zeros(RING_TERMS)
    for k in range(n):
        _monomials(cs[k], sn[k], phi[k], band[k])
        for m in range(RING_TERMS):
            moments[m] += band[k, m]
    multinomial = MULTINOMIALS
    c = 0
    for j in range(j_lo, j_hi + 1):
        for i in range(i_lo, i_hi + 1):
            if b_geo[j, i] > 0.0:
                cj[c], ci[c] = j, i
                if n > 0:  # with no band each column keeps its volume: its factors would go unused
                    _column_factors(x0 + i * cell - centre[0], y0 + j * cell - centre[1], outline, moments,
                                    multinomial, columns[c])
                c += 1
    return jj[:n], ii[:n], cj, ci, columns, band


@njit(cache=True)
def ring_deposit(b_geo, band_j, band_i, col_j, col_i, columns, band, b_out):
    """Push each column's displaced volume (occupied height b_geo [m]) out into the band around the
    body (:func:`ring_map`): b_out (nj, ni) [m].

    The displaced water is put where it goes in reality, around the body (as Yuksel et al.'s wave
    particles do, along the silhouette), not under it: a height field whose surface under the body
    included the body's own displacement would feed that displacement back into the next occupied
    height (the surface rises, so more of the body is "below" it, so the surface rises ...), which
    diverges for a floating body. The map is linear, column by column, and each column's shares sum
    to 1, so sum(b_out) s^2 = sum(b_geo) s^2 (to round-off). When no band column lies in the window,
    the volume stays where it is (b_out = b_geo). Returns the window (i_lo, i_hi, j_lo, j_hi) of
    nonzero b_out, empty when i_lo > i_hi.
    """
    b_out[:, :] = 0.0
    return deposit_onto_zero(b_geo, band_j, band_i, col_j, col_i, columns, band, b_out)


@njit(cache=True)
def deposit_onto_zero(b_geo, band_j, band_i, col_j, col_i, columns, band, b_out):
    """:func:`ring_deposit` into a b_out that is already zero."""
    n = band_j.size
    if n == 0:
        for c in range(col_j.size):
            b_out[col_j[c], col_i[c]] = b_geo[col_j[c], col_i[c]]
    else:
        # sum_c b_c share_ck = sum_m (sum_c b_c column[c, m]) band[k, m]
        through = np.zeros(RING_TERMS)
        for c in range(col_j.size):
            b = b_geo[col_j[c], col_i[c]]
            for m in range(RING_TERMS):
                through[m] += b * columns[c, m]
        for k in range(n):
            value = 0.0
            for m in range(RING_TERMS):
                value += through[m] * band[k, m]
            # a share is never negative; the sum of the monomials is, by round-off, where it is
            # nearly zero (across the body from every column holding volume)
            b_out[band_j[k], band_i[k]] = max(value, 0.0)
    nj, ni = b_out.shape
    i_lo, i_hi, j_lo, j_hi = ni, -1, nj, -1
    touched_j, touched_i = (band_j, band_i) if n > 0 else (col_j, col_i)
    for k in range(touched_j.size):
        j, i = touched_j[k], touched_i[k]
        if b_out[j, i] > 0.0:
            i_lo, i_hi = min(i_lo, i), max(i_hi, i)
            j_lo, j_hi = min(j_lo, j), max(j_hi, j)
    return i_lo, i_hi, j_lo, j_hi


@njit(cache=True)
def ring_levels(band_field, waterline, col_j, col_i, columns, band, lifted):
    """lifted (3,) = sum_c level_c (area_c, moment_y_c, -moment_x_c) [m^3] over the waterline columns,
    level_c the mean of ``band_field`` (n,) (the water above the rest level over the band) weighted
    by column c's shares (:func:`ring_map_into`); see :func:`ring_lift`. Columns with no waterline
    area are skipped; an empty band is the caller's (each column then reads its own water)."""
    # sum_k field_k share_ck = sum_m column[c, m] (sum_k field_k band[k, m])
    seen = np.zeros(RING_TERMS)
    for k in range(band_field.size):
        f = band_field[k]
        for m in range(RING_TERMS):
            seen[m] += f * band[k, m]
    lifted[:] = 0.0
    for c in range(col_j.size):
        j, i = col_j[c], col_i[c]
        area = waterline[0, j, i]
        if area <= 0.0:
            continue
        level = 0.0
        for m in range(RING_TERMS):
            level += columns[c, m] * seen[m]
        lifted[0] += level * area
        lifted[1] += level * waterline[2, j, i]
        lifted[2] -= level * waterline[1, j, i]


@njit(cache=True)
def ring_lift(waterline, field, band_j, band_i, col_j, col_i, columns, band, lifted, j0=0, i0=0):
    """The level at which each column's displaced volume enters the water, summed over the waterline:
    lifted (3,) = sum_k level_k (area_k, moment_y_k, -moment_x_k) [m^3].

    level_k [m] is the mean of ``field`` (nj, ni) [m] (the water above the rest level) over the band
    columns, weighted by the shares :func:`ring_deposit` gives them of column k's volume (its own
    ``field`` when the band is empty); ``waterline`` (3, nj, ni) holds the columns' waterline areas
    and moments (:func:`evaluate`). Times rho g, lifted is the force and torque (x, y) that go with
    the displacement (see the component's _add_hydrostatics). ``field`` may be a window of the
    patch whose first column is column (j0, i0).
    """
    n = band_j.size
    if n > 0:
        band_field = np.empty(n)  # the field over the band, read once for every column
        for k in range(n):
            band_field[k] = field[band_j[k] - j0, band_i[k] - i0]
        ring_levels(band_field, waterline, col_j, col_i, columns, band, lifted)
        return
    lifted[:] = 0.0
    for c in range(col_j.size):
        j, i = col_j[c], col_i[c]
        area = waterline[0, j, i]
        if area <= 0.0:
            continue
        level = field[j - j0, i - i0]
        lifted[0] += level * area
        lifted[1] += level * waterline[2, j, i]
        lifted[2] -= level * waterline[1, j, i]


@njit(cache=True)
def smooth_conservative(b, passes):
    """``passes`` sweeps of the [1, 2, 1]/4 filter along x then y, with no flux through the window's
    edges, so sum(b) is unchanged (Mueller's smoothing of the displacement)."""
    nj, ni = b.shape
    tmp = np.empty(max(ni, nj))
    for _ in range(passes):
        for j in range(nj):
            for i in range(ni):
                left = b[j, i - 1] if i > 0 else b[j, i]
                right = b[j, i + 1] if i < ni - 1 else b[j, i]
                tmp[i] = 0.25 * (left - 2.0 * b[j, i] + right)
            for i in range(ni):
                b[j, i] += tmp[i]
        for i in range(ni):
            for j in range(nj):
                down = b[j - 1, i] if j > 0 else b[j, i]
                up = b[j + 1, i] if j < nj - 1 else b[j, i]
                tmp[j] = 0.25 * (down - 2.0 * b[j, i] + up)
            for j in range(nj):
                b[j, i] += tmp[j]


# The water a submerged body displaces rises through the water above it, over a width set by the
# depth: an image source at depth d under a flat surface sends half its flux through the surface
# within sqrt(3) d of the point over it, and a Gaussian of the same half-flux radius has
# sigma = sqrt(3) d / sqrt(2 ln 2) = 1.47 d.
DEPTH_SPREAD = math.sqrt(3.0) / math.sqrt(2.0 * math.log(2.0))
SPREAD_REACH = 2.5  # the spread's kernel is cut at this many sigma (1.2% of a column's volume beyond, kept in)
SPREAD_LEAST = 0.05  # [columns] a narrower spread leaves the deposit as it is
# [radii] the widest spread: beyond it the mound over a stone is a fraction of a millimetre (a cap of 1.5
# or 3 radii left the surface over the sunk reference stone within 0.6 mm of this one's), and the
# deposit's window, which the patch must hold, stays small
SPREAD_CAP = 1.0


@njit(cache=True, inline="always")
def depth_spread(top_under, radius):
    """The width sigma [m] over which the water displaced by a body of ``radius`` [m] whose top is
    ``top_under`` [m] under the rest level rises beyond its band: 0 while the body pierces the
    level, then DEPTH_SPREAD times the top's depth (the spread of the water displaced nearest the
    surface, the body's shallowest: the rest of its volume, deeper, would spread wider), at most
    SPREAD_CAP radii."""
    if not top_under > 0.0:
        return 0.0
    return min(DEPTH_SPREAD * top_under, SPREAD_CAP * radius)


@njit(cache=True, inline="always")
def _mirror(k, n):
    """Index k reflected into 0..n-1 about the window's edges (half a column out: k = -1 is 0)."""
    period = 2 * n
    k %= period
    return k if k < n else period - 1 - k


@njit(cache=True)
def spread_reach(sigma):
    """How many columns [-] the spread of ``sigma`` [columns] reaches each way (0: no spread)."""
    return math.ceil(SPREAD_REACH * sigma) if sigma >= SPREAD_LEAST else 0


@njit(cache=True)
def _spread_weights(sigma, reach):
    """The spread's weights at whole columns -reach..reach: the Gaussian's, normalised."""
    weights = np.empty(2 * reach + 1)
    total = 0.0
    for k in range(-reach, reach + 1):
        weights[k + reach] = math.exp(-0.5 * (k / sigma) ** 2)
        total += weights[k + reach]
    return weights / total


@njit(cache=True)
def _spread_along_x(b, weights, reach, j_lo, j_hi, i_lo, i_hi):
    """The spread along x of rows j_lo..j_hi of ``b``, kept in its columns i_lo..i_hi only.

    Each value sums its taps from -reach to reach, starting from 0, as one dot product would; the
    taps go in the outer loop so that the inner one runs along the row (vectorised), and only the
    columns whose tap falls outside the window are mirrored (a modulo for every tap of every column
    made the spread of a submerged body's water most of the coupler's step)."""
    ni = b.shape[1]
    n = i_hi - i_lo + 1
    line = np.empty(n)
    for j in range(j_lo, j_hi + 1):
        row = b[j]
        line[:] = 0.0
        for k in range(-reach, reach + 1):
            w = weights[k + reach]
            mid_lo, mid_hi = max(i_lo, -k), min(i_hi, ni - 1 - k)  # the columns read inside the window
            if mid_lo > mid_hi:
                for i in range(i_lo, i_hi + 1):
                    line[i - i_lo] += w * row[_mirror(i + k, ni)]
                continue
            for i in range(i_lo, mid_lo):
                line[i - i_lo] += w * row[_mirror(i + k, ni)]
            dst = line[mid_lo - i_lo:mid_hi - i_lo + 1]
            src = row[mid_lo + k:mid_hi + k + 1]
            for t in range(dst.size):
                dst[t] += w * src[t]
            for i in range(mid_hi + 1, i_hi + 1):
                line[i - i_lo] += w * row[_mirror(i + k, ni)]
        for t in range(n):
            row[i_lo + t] = line[t]


@njit(cache=True)
def _spread_along_y(b, weights, reach, i_lo, i_hi):
    """The spread along y of columns i_lo..i_hi of ``b``: each value's taps summed as along x, a row
    of the window at a time (a column at a time strode across the rows at every tap)."""
    nj = b.shape[0]
    n = i_hi - i_lo + 1
    out = np.zeros((nj, n))
    for j in range(nj):
        dst = out[j]
        for k in range(-reach, reach + 1):
            w = weights[k + reach]
            src = b[_mirror(j + k, nj), i_lo:i_hi + 1]
            for t in range(n):
                dst[t] += w * src[t]
    for j in range(nj):
        row = b[j]
        for t in range(n):
            row[i_lo + t] = out[j, t]


@njit(cache=True)
def _spread(b, sigma, j_lo, j_hi, i_lo, i_hi):
    """Spread ``b`` (nj, ni) in place by a Gaussian of ``sigma`` [columns] along x (rows j_lo..j_hi,
    kept in columns i_lo..i_hi) then along y (columns i_lo..i_hi), reflected at the window's edges."""
    reach = spread_reach(sigma)
    if reach == 0:
        return
    weights = _spread_weights(sigma, reach)
    _spread_along_x(b, weights, reach, j_lo, j_hi, i_lo, i_hi)
    _spread_along_y(b, weights, reach, i_lo, i_hi)


@njit(cache=True)
def spread_gaussian(b, sigma):
    """Spread ``b`` (nj, ni) in place by a Gaussian of ``sigma`` [columns] along x then y, reflected at
    the window's edges (no flux through them), so sum(b) is unchanged; the filter is symmetric, so
    reading a field through it is the adjoint of depositing through it. Its weights are the
    Gaussian's at whole columns, normalised, cut at SPREAD_REACH sigma: they change smoothly with
    sigma, and sigma below SPREAD_LEAST columns leaves b as it is."""
    _spread(b, sigma, 0, b.shape[0] - 1, 0, b.shape[1] - 1)


@njit(cache=True)
def spread_deposit(b, sigma, j_lo, j_hi):
    """:func:`spread_gaussian` of a deposit ``b`` that is zero outside its rows j_lo..j_hi: the same
    numbers, bit for bit, without spreading the rows of zeros along x (they stay zeros)."""
    _spread(b, sigma, j_lo, j_hi, 0, b.shape[1] - 1)


@njit(cache=True)
def spread_columns(b, sigma, i_lo, i_hi):
    """:func:`spread_gaussian` of ``b`` where it is read, its columns i_lo..i_hi: there the same
    numbers, bit for bit (each column's spread along y needs only that column spread along x); the
    other columns are left as they were."""
    _spread(b, sigma, 0, b.shape[0] - 1, i_lo, i_hi)
