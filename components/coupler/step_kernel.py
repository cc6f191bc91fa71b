"""One coupler step's column and element work in a single compiled call (ring displacement).

The component's step used to be a dozen compiled kernels glued by Python: the body's pose, the
planing share of the pressure, the forces against the met surface (:func:`kernel.evaluate`), the
body under the rest level, the ring's map, deposit and lift, the water level the deposit leaves,
the hydrostatics and the stability bound, each with its own dispatch, temporary arrays and
conversions; the glue cost as much as the kernels. :func:`ring_step` does the same arithmetic,
in the same order, into work arrays the component keeps (:class:`RingScratch`), so Python is left
with reading the messages and building the ones it publishes. The results are those of the
separate kernels (the same operations on the same values).

Scalar parameters travel in one float64 vector (``P_*`` indices, built once by the component), the
body's pose and motion in another (``B_*``), so a call passes a handful of arrays, not forty values.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from components import kernel_cache
from components.coupler import kernel
from components.coupler.effects import BUOYANCY, DISPLACEMENT
from components.coupler.geometry import quat_to_matrix
from components.coupler.met_surface import _freeze

kernel_cache.install()  # before the cached kernels below: their cache keyed on every kernel source

# parameter vector (float64), set once per component
P_RHO = 0
P_G = 1
P_C_L = 2
P_C_N = 3
P_C_F = 4
P_C_W = 5
P_C_MIN = 6
P_WET_RAMP = 7
P_C_D = 8  # submerged pressure drag coefficient of the body's shape
P_CLOSURE = 9  # closure depth [m]
P_RING_CELLS = 10  # width of the displacement band [cells]
P_DAMPING_SAFETY = 11
P_SPRING_SAFETY = 12
P_MOTION_FRACTION = 13
P_C_B = 14  # impact pressure coefficient of a blunt body (a sphere)
P_RING_SHARE = 15  # width of the displacement band [share of the body's radius]
N_PARAMS = 16

# body vector (float64), filled each step from the BodyState
B_POS = 0  # (3) [m]
B_QUAT = 3  # (4) (w, x, y, z)
B_VEL = 7  # (3) [m/s]
B_OMEGA = 10  # (3) [rad/s]
B_RADIUS = 13
B_THICKNESS = 14
B_MASS = 15
B_INERTIA_MIN = 16  # least principal moment of inertia [kg m^2]
N_BODY = 17

# results vector (float64) besides stats
R_PLANING = 0  # the planing share of the pressure [-] (see WaterCoupler._immersion)
R_TOP_UNDER = 1  # how far the body's top is under the live surface [m]; NaN off the patch or over dry land
R_BOUND = 2  # the stability bound [s]
R_I_LO = 3  # the deposit's window in patch indices (i_lo, i_hi, j_lo, j_hi); empty: i_lo > i_hi
R_I_HI = 4
R_J_LO = 5
R_J_HI = 6
R_DISPLACED = 7  # volume under the rest level [m^3]
R_SHARES = 8  # values in the ring's factors ((columns + band) x kernel.RING_TERMS): share_work needs this many
N_RESULTS = 9


# the numbers a step writes (float64 vector of a RingScratch), by where they start
NUM_STATS = 0  # the step's stats (kernel.N_STATS)
NUM_REST = kernel.N_STATS  # the rest pass's stats (kernel.N_STATS)
NUM_LIFTED = 2 * kernel.N_STATS  # the ring's lifted levels (3)
NUM_RESULTS = NUM_LIFTED + 3  # results (N_RESULTS)
NUM_AXES = NUM_RESULTS + N_RESULTS  # the body's axes (3 x 3, row-major)
NUM_POSE = NUM_AXES + 9  # its lowest point (x, y, z) and half-extents (hx, hy) [m] (5)
N_POSE = 5
# kept from step to step: the columns (i_lo, i_hi, j_lo, j_hi) outside which the planes are zero
NUM_BOX = NUM_POSE + N_POSE  # b_geo, b_rest and waterline (kernel.evaluate_with_rest)
NUM_OUT_BOX = NUM_BOX + 4  # b_out (the last deposit's window)
N_NUMBERS = NUM_OUT_BOX + 4

# the planes of a RingScratch's (N_PLANES, nj, ni) grid block
PLANE_B_GEO = 0
PLANE_B_REST = 1
PLANE_B_OUT = 2
PLANE_WATERLINE = 3  # three planes
PLANE_FLAT = 6
PLANE_STILL = 7
N_PLANES = 8


class RingScratch:
    """Work arrays of :func:`ring_step` over a patch of shape (nj, ni), reused while the shape holds,
    in three blocks so that a call passes three arrays, not twenty: ``planes`` (N_PLANES, nj, ni)
    holds b_geo, b_rest, b_out [m], waterline (3, nj, ni), flat (the rest level [m]) and still
    (zeros [m/s]) (the rest pass's surface); ``numbers`` (N_NUMBERS,) holds stats and rest_stats
    (kernel.N_STATS,), lifted (3,), results (N_RESULTS,), the body's axes (3, 3) and pose (5,);
    ``work`` (1-D) holds the elements' planing work arrays and room for the ring's factors, grown to
    the largest seen (:meth:`grow`). The named arrays are views of the blocks."""

    def __init__(self, shape: tuple[int, int], rest_level: float):
        self.shape = shape
        self.rest_level = rest_level
        self.planes = np.zeros((N_PLANES, *shape))
        self.planes[PLANE_FLAT] = rest_level
        self.b_geo = self.planes[PLANE_B_GEO]
        self.b_rest = self.planes[PLANE_B_REST]
        self.b_out = self.planes[PLANE_B_OUT]
        self.waterline = self.planes[PLANE_WATERLINE:PLANE_WATERLINE + 3]
        self.numbers = np.zeros(N_NUMBERS)
        self.stats = self.numbers[NUM_STATS:NUM_STATS + kernel.N_STATS]
        self.rest_stats = self.numbers[NUM_REST:NUM_REST + kernel.N_STATS]
        self.lifted = self.numbers[NUM_LIFTED:NUM_LIFTED + 3]
        self.results = self.numbers[NUM_RESULTS:NUM_RESULTS + N_RESULTS]
        self.axes = self.numbers[NUM_AXES:NUM_AXES + 9].reshape(3, 3)
        self.numbers[NUM_BOX:NUM_BOX + 4] = self.numbers[NUM_OUT_BOX:NUM_OUT_BOX + 4] = (1, 0, 1, 0)  # empty
        self.work = np.empty(0)

    def work_for(self, n_elements: int) -> np.ndarray:
        """The work block for a body of ``n_elements`` surface elements: its planing arrays
        (:func:`_planing_arrays`) and at least the ring's factors of the last step."""
        needed = PLANING_PER_ELEMENT * n_elements + int(self.results[R_SHARES])
        if needed > self.work.size:
            self.work = np.empty(PLANING_PER_ELEMENT * n_elements + 2 * int(self.results[R_SHARES]))
        return self.work


PLANING_PER_ELEMENT = 5 + kernel.PLANING_PLACE  # values of the planing work arrays per surface element
# (pl_f: 3; pl_r: kernel.PLANING_PLACE; pl_s, pl_m: 1)


@njit(cache=True)
def _planing_arrays(work, n):
    """pl_f (n, 3), pl_r (n, kernel.PLANING_PLACE), pl_s, pl_m (n,) of kernel.evaluate_into and the
    rest of ``work`` (room for the ring's factors)."""
    r = kernel.PLANING_PLACE
    pl_f = work[0:3 * n].reshape((n, 3))
    pl_r = work[3 * n:(3 + r) * n].reshape((n, r))
    pl_s = work[(3 + r) * n:(4 + r) * n]
    pl_m = work[(4 + r) * n:(5 + r) * n]
    return pl_f, pl_r, pl_s, pl_m, work[(5 + r) * n:]


@njit(cache=True)
def body_pose(shape, body, axes):
    """Fill ``axes`` (3, 3) from the body vector's quaternion; return the lowest point (x, y, z) [m]
    and the horizontal half-extents (hx, hy) [m] (as geometry.lowest_point, disk_half_extents)."""
    m = quat_to_matrix(body[B_QUAT:B_QUAT + 4])
    axes[:, :] = m
    cx, cy, cz = body[B_POS], body[B_POS + 1], body[B_POS + 2]
    radius = body[B_RADIUS]
    thickness = body[B_THICKNESS]
    if shape != kernel.SHAPE_DISK:
        return cx, cy, cz - radius, radius, radius
    ax, ay, az = m[0, 2], m[1, 2], m[2, 2]
    dx, dy, dz = az * ax, az * ay, -1.0 + az * az
    norm = math.sqrt(dx * dx + dy * dy + dz * dz)
    k = radius / norm if norm > 1e-12 else 0.0
    f = -0.5 * thickness * (1.0 if az >= 0 else -1.0)
    bx, by = abs(ax), abs(ay)
    hx = radius * math.sqrt(max(0.0, 1.0 - bx * bx)) + 0.5 * thickness * bx
    hy = radius * math.sqrt(max(0.0, 1.0 - by * by)) + 0.5 * thickness * by
    return cx + k * dx + f * ax, cy + k * dy + f * ay, cz + k * dz + f * az, hx, hy


@njit(cache=True)
def _top_under(body, x_low, y_low, z_low, x0, y0, cell, height, wvel, bottom):
    """How far [m] the body's top (its lowest point mirrored through the centre) is under the
    surface ``height``; NaN off the patch or over dry land (no water above the bed ``bottom``)."""
    tx = 2.0 * body[B_POS] - x_low
    ty = 2.0 * body[B_POS + 1] - y_low
    tz = 2.0 * body[B_POS + 2] - z_low
    ok, h_top, _, depth = kernel.sample_water(tx, ty, x0, y0, cell, height, wvel, bottom)
    return h_top - tz if ok and depth > 0.0 else np.nan


@njit(cache=True)
def stability_bound(body, stats, prm):
    """The step bound of WaterCoupler.max_stable_step [s]."""
    vx, vy, vz = body[B_VEL], body[B_VEL + 1], body[B_VEL + 2]
    wx, wy, wz = body[B_OMEGA], body[B_OMEGA + 1], body[B_OMEGA + 2]
    radius = body[B_RADIUS]
    speed = math.sqrt(vx * vx + vy * vy + vz * vz) + radius * math.sqrt(wx * wx + wy * wy + wz * wz)
    bound = np.inf if speed <= 0 else prm[P_MOTION_FRACTION] * radius / speed
    mass = body[B_MASS]
    inertia = body[B_INERTIA_MIN]
    rate = 0.0
    if mass > 0:
        rate = stats[kernel.S_DAMP_LIN] / mass
    if inertia > 0:
        rate = max(rate, stats[kernel.S_DAMP_ROT] / inertia)
    if rate > 0:
        bound = min(bound, prm[P_DAMPING_SAFETY] / rate)
    if mass > 0 and stats[kernel.S_STIFF] > 0:
        bound = min(bound, prm[P_SPRING_SAFETY] / math.sqrt(stats[kernel.S_STIFF] / mass))
    return bound


@njit(cache=True)
def ring_step(shape, body, prm, flags, local_flags, nsub, rest_level, share,
              x0, y0, cell, met_h, met_v, height, wvel, bottom, held, has_held,
              el_pos, el_nrm, el_area, el_t1, el_t2, el_sub, el_whole, world_fixed, planes, numbers, work):
    """The forces of the named effects on the body over one patch, with the ring displacement.

    body (N_BODY,), prm (N_PARAMS,); met_h, met_v: the surface the surface effects read (the met
    surface), height, wvel, bottom, held (nj, ni): the patch and the occupied height it holds (used
    when has_held); share: the planing share of the body's motion (met_surface.planing_share);
    planes, numbers, work: a :class:`RingScratch`'s blocks. Writes the body's axes and pose
    (:func:`body_pose`), stats (the forces against the met surface plus the hydrostatics of the
    ring, as WaterCoupler._add_hydrostatics), b_geo, and the ring's b_rest, waterline, b_out,
    rest_stats, lifted; results (N_RESULTS,) the planing share, the top's depth, the stability
    bound, the deposit's window, the displaced volume and the size of the ring's factors.
    """
    b_geo = planes[PLANE_B_GEO]
    b_rest = planes[PLANE_B_REST]
    b_out = planes[PLANE_B_OUT]
    waterline = planes[PLANE_WATERLINE:PLANE_WATERLINE + 3]
    flat = planes[PLANE_FLAT]
    still = planes[PLANE_STILL]
    stats = numbers[NUM_STATS:NUM_STATS + kernel.N_STATS]
    rest_stats = numbers[NUM_REST:NUM_REST + kernel.N_STATS]
    lifted = numbers[NUM_LIFTED:NUM_LIFTED + 3]
    results = numbers[NUM_RESULTS:NUM_RESULTS + N_RESULTS]
    axes = np.empty((3, 3))
    x_low, y_low, z_low, half_x, half_y = body_pose(shape, body, axes)
    for q in range(9):
        numbers[NUM_AXES + q] = axes[q // 3, q % 3]
    numbers[NUM_POSE] = x_low
    numbers[NUM_POSE + 1] = y_low
    numbers[NUM_POSE + 2] = z_low
    numbers[NUM_POSE + 3] = half_x
    numbers[NUM_POSE + 4] = half_y
    pl_f, pl_r, pl_s, pl_m, share_work = _planing_arrays(work, el_area.shape[0])
    radius = body[B_RADIUS]
    thickness = body[B_THICKNESS]
    centre = body[B_POS:B_POS + 3]
    velocity = body[B_VEL:B_VEL + 3]
    omega = body[B_OMEGA:B_OMEGA + 3]
    rho, g = prm[P_RHO], prm[P_G]
    under = _top_under(body, x_low, y_low, z_low, x0, y0, cell, met_h, met_v, bottom)
    planing = 1.0 if math.isnan(under) else min(1.0, max(0.0, 1.0 - under / prm[P_CLOSURE]))
    wave_depth = 0.0 if math.isnan(under) else max(0.0, under)  # (the wave drag's depth)
    results[:] = 0.0
    results[R_PLANING] = planing
    results[R_TOP_UNDER] = _top_under(body, x_low, y_low, z_low, x0, y0, cell, height, wvel, bottom)
    results[R_I_LO] = 1.0
    results[R_I_HI] = 0.0
    # the forces against the met surface and the body under the rest level (the ring's), the two
    # passes over the columns in one loop
    kernel.evaluate_with_rest(shape, radius, thickness, centre, axes, velocity, omega, half_x, half_y,
                              x_low, y_low, z_low, x0, y0, cell, met_h, met_v, bottom,
                              el_pos, el_nrm, el_area, el_t1, el_t2, el_sub, el_whole, world_fixed,
                              rho, g, prm[P_C_L], prm[P_C_N], prm[P_C_B], prm[P_C_F], prm[P_C_W], prm[P_C_MIN],
                              prm[P_WET_RAMP], local_flags, nsub, b_geo, stats, planing, prm[P_C_D],
                              wave_depth, pl_f, pl_r, pl_s, pl_m,
                              rest_level, flat, still, DISPLACEMENT | (flags & BUOYANCY), b_rest, waterline,
                              rest_stats, numbers[NUM_BOX:NUM_BOX + 4])
    # --- the ring: the body under the rest level, pushed out around it --------------------------
    lifted[:] = 0.0
    if z_low < rest_level:  # else nothing of the body below the rest level: no displacement
        if rest_stats[kernel.S_VOLUME] > 0.0:
            box = numbers[NUM_BOX:NUM_BOX + 4]
            band_j, band_i, col_j, col_i, columns, band = kernel.ring_map_into(
                shape, radius, thickness, centre, axes, x0, y0, cell, b_rest,
                kernel.band_width(prm[P_RING_CELLS], prm[P_RING_SHARE], cell, radius), share_work,
                int(box[0]), int(box[1]), int(box[2]), int(box[3]))
            results[R_SHARES] = columns.size + band.size
            out_box = numbers[NUM_OUT_BOX:NUM_OUT_BOX + 4]
            kernel.clear_box(b_out, out_box)  # b_out is zero outside the last deposit's window
            i_lo, i_hi, j_lo, j_hi = kernel.deposit_onto_zero(b_rest, band_j, band_i, col_j, col_i, columns, band,
                                                              b_out)
            # a submerged body's water rises over a width set by its depth (the top as far above the
            # centre as the lowest point is below it)
            sigma = kernel.depth_spread(rest_level - (2.0 * centre[2] - z_low), radius) / cell
            reach = kernel.spread_reach(sigma) if i_lo <= i_hi else 0
            if reach:
                nj, ni = b_out.shape
                rows_lo, rows_hi = j_lo, j_hi  # the deposit's rows before the spread: the others are zeros
                i_lo, i_hi = max(0, i_lo - reach), min(ni - 1, i_hi + reach)
                j_lo, j_hi = max(0, j_lo - reach), min(nj - 1, j_hi + reach)
                kernel.spread_deposit(b_out[j_lo:j_hi + 1, i_lo:i_hi + 1], sigma, rows_lo - j_lo, rows_hi - j_lo)
            out_box[0], out_box[1], out_box[2], out_box[3] = i_lo, i_hi, j_lo, j_hi
            if i_lo <= i_hi:
                results[R_I_LO] = i_lo
                results[R_I_HI] = i_hi
                results[R_J_LO] = j_lo
                results[R_J_HI] = j_hi
                if reach:
                    _ring_lift_spread(waterline, height, held, has_held, b_out, rest_level, sigma,
                                      i_lo, i_hi, j_lo, j_hi, band_j, band_i, col_j, col_i, columns, band, lifted)
                else:
                    _ring_lift_live(waterline, height, held, has_held, b_out, rest_level,
                                    band_j, band_i, col_j, col_i, columns, band, lifted)
    results[R_DISPLACED] = rest_stats[kernel.S_VOLUME]
    add_hydrostatics(stats, rest_stats, lifted, flags, rho * g, share, shape == kernel.SHAPE_SPHERE)
    results[R_BOUND] = stability_bound(body, stats, prm)


@njit(cache=True)
def met_ring_step(freeze, i0, j0, mi0, mj0, m_h, m_v, fr_h, fr_v,
                  shape, body, prm, flags, local_flags, nsub, rest_level, share,
                  x0, y0, cell, met_h, met_v, height, wvel, bottom, held, has_held,
                  el_pos, el_nrm, el_area, el_t1, el_t2, el_sub, el_whole, world_fixed, planes, numbers, work):
    """:func:`ring_step` over the met surface made in the same call: when ``freeze``, the patch at
    (i0, j0) with the window the body met (m_h, m_v at (mi0, mj0)) frozen into fr_h, fr_v and, when
    ``share`` < 1, blended with the live surface into met_h, met_v (met_surface._freeze; the arrays
    :meth:`met_surface.MetSurface.plan` hands out), else met_h, met_v as given (the live patch).
    One dispatch instead of two, the same arithmetic."""
    if freeze:
        _freeze(i0, j0, height, wvel, mi0, mj0, m_h, m_v, fr_h, fr_v, share, met_h, met_v)
    ring_step(shape, body, prm, flags, local_flags, nsub, rest_level, share,
              x0, y0, cell, met_h, met_v, height, wvel, bottom, held, has_held,
              el_pos, el_nrm, el_area, el_t1, el_t2, el_sub, el_whole, world_fixed, planes, numbers, work)


@njit(cache=True)
def _ring_lift_live(waterline, height, held, has_held, b_out, rest_level, band_j, band_i, col_j, col_i,
                    columns, band, lifted):
    """:func:`kernel.ring_lift` over the water above the rest level as this step's displacement
    leaves it (WaterCoupler._ring_field), read where it is needed instead of made whole: the
    patch minus the occupied height it holds plus the one published now (b_out, zero outside its
    window), or the patch alone when not ``has_held``: it does not say what it holds, or the window
    raises no mound (the water takes it as already at rest: WaterCoupler._mound_raised)."""
    n = band_j.size
    if n > 0:
        band_field = np.empty(n)  # the field over the band
        for k in range(n):
            band_field[k] = _field(height, held, has_held, b_out, rest_level, band_j[k], band_i[k])
        kernel.ring_levels(band_field, waterline, col_j, col_i, columns, band, lifted)
        return
    lifted[:] = 0.0
    for c in range(col_j.size):
        j, i = col_j[c], col_i[c]
        area = waterline[0, j, i]
        if area <= 0.0:
            continue
        level = _field(height, held, has_held, b_out, rest_level, j, i)
        lifted[0] += level * area
        lifted[1] += level * waterline[2, j, i]
        lifted[2] -= level * waterline[1, j, i]


@njit(cache=True)
def _ring_lift_spread(waterline, height, held, has_held, b_out, rest_level, sigma, i_lo, i_hi, j_lo, j_hi,
                      band_j, band_i, col_j, col_i, columns, band, lifted):
    """:func:`_ring_lift_live` for a deposit spread by a Gaussian of ``sigma`` [columns] over the
    window [j_lo, j_hi] x [i_lo, i_hi]: the field over the window read through the same filter (the
    adjoint of spreading the deposit through it), as WaterCoupler._ring does."""
    field = np.empty((j_hi - j_lo + 1, i_hi - i_lo + 1))
    for j in range(j_lo, j_hi + 1):
        for i in range(i_lo, i_hi + 1):
            field[j - j_lo, i - i_lo] = _field(height, held, has_held, b_out, rest_level, j, i)
    # spread where it is read only: the band's columns (or the body's, with no band)
    read_lo, read_hi = i_hi, i_lo
    for k in range(band_i.size):
        read_lo, read_hi = min(read_lo, band_i[k]), max(read_hi, band_i[k])
    if band_i.size == 0:
        for c in range(col_i.size):
            read_lo, read_hi = min(read_lo, col_i[c]), max(read_hi, col_i[c])
    if read_lo <= read_hi:
        kernel.spread_columns(field, sigma, read_lo - i_lo, read_hi - i_lo)
    kernel.ring_lift(waterline, field, band_j, band_i, col_j, col_i, columns, band, lifted, j_lo, i_lo)


@njit(cache=True, inline="always")
def _field(height, held, has_held, b_out, rest_level, j, i):
    value = height[j, i] - rest_level
    if has_held:
        value = value - held[j, i]
        value = value + b_out[j, i]
    return value


@njit(cache=True)
def add_hydrostatics(stats, rest, lifted, flags, f, share, sphere):
    """The hydrostatics of the ring displacement (WaterCoupler._add_hydrostatics says why): the rest
    pass's buoyancy ``rest`` (kernel.S_* layout), the mound's lift ``f`` [N/m^3] times ``lifted``
    [m^3] (a floating body only: times 1 - ``share``; a sphere's without a torque, its pressure
    acting through its centre) and the waterline stiffness into ``stats``, and the total."""
    b = kernel.S_BUOYANCY
    for q in range(6):
        stats[b + q] = rest[b + q]
    if flags & BUOYANCY:
        mound = f * (1.0 - share)
        stats[b + 2] += mound * lifted[0]
        if not sphere:
            stats[b + 3] += mound * lifted[1]
            stats[b + 4] += mound * lifted[2]
        stats[kernel.S_STIFF] += f * rest[kernel.S_WATERLINE]
    for q in range(6):
        stats[kernel.S_TOTAL + q] += stats[b + q]
