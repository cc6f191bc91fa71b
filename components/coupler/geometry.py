"""Geometry of a body over water columns: vertical chords, partial wetting, surface elements.

Frames: world z up. A disk has radius R, thickness e and its symmetry axis ``a`` (body z) in the
world; a sphere has radius R. Positions are relative to the centre of mass unless named absolute.

Two samplings, each chosen for what it feeds:

* **Columns** (occupied height, buoyancy, displacement, wave drag): each water column is cut by the
  vertical line through the centre of each of its ``k x k`` sub-cells; :func:`disk_chord` and
  :func:`sphere_chord` give the exact vertical extent of the body on that line, so
  ``b_ij = mean over sub-cells of (min(z_hi, h_ij) - max(z_lo, bed_ij))+`` and the buoyancy of a
  column acts at the centroid of that wet interval. The chord of a sphere or a tilted disk goes to
  zero continuously at the silhouette, so the sums are continuous in the body's pose; a level
  disk's chord is its whole thickness up to its rim and then none, so its sums step as sub-cell
  lines cross the rim (by up to 0.6% of its buoyancy for 25 um of travel, 1 cm cells), and its
  sampled volume depends on where it lies on the grid (0.987-1.013 of its own, wholly under, for a
  5 cm disk 6 mm thick on 1 cm cells; finer sub-columns bring both to 1).
* **Surface elements** (pressure, friction): the faces are tiled once in the body frame (a square
  grid clipped to the disk, plus the rim; equal-area latitude bands on a sphere). Each element
  reads the water height and vertical velocity at its own position (bilinear between column
  centres) and is wet by the fraction of its area below that surface (:func:`box_coverage`), so the
  wetted area, and every force on it, varies continuously as the body moves across cells and the
  waterline sweeps across elements. Forces are then independent of the water's cell size, and a
  stone smaller than one cell is handled like any other. A disk face's square is also cut into
  4 x 4 pieces (``Elements.sub``): a partly wet square is wetted piece by piece, and its planing
  load placed piece by piece, so that neither follows how the tiling lies against the waterline as
  the disk turns about its axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numba import njit

from components import kernel_cache

kernel_cache.install()  # before the cached kernels below: their cache keyed on every kernel source

EMPTY = (1.0, 0.0)  # an empty chord (lo > hi)
AXIS_EPS = 1e-12  # below this, a disk axis component counts as zero (no division by it)


@njit(cache=True)
def box_coverage(t: float, w1: float, w2: float) -> float:
    """Fraction of a flat element below a level lying ``t`` above the element's centre.

    The element's height varies linearly across it with total ranges ``w1`` and ``w2`` [m] along
    its two sides, so its height distribution is the sum of two uniform ones (a trapezoid): the
    fraction is that distribution's CDF at ``t``. Exact for a planar element under a flat surface;
    summed over a tiling, it reproduces the wetted area of a straight waterline exactly.
    """
    a, b, half, d, ab2 = box_shape(w1, w2)
    return box_fraction(t, a, b, half, d, ab2)


@njit(cache=True, inline="always")
def box_shape(w1: float, w2: float) -> tuple[float, float, float, float, float]:
    """What :func:`box_coverage` needs of the ranges ``w1``, ``w2`` [m], for elements (or pieces) that
    share them: (a, b) the smaller and larger range, half their mean, d half their difference [m],
    2 a b [m^2]."""
    a = min(abs(w1), abs(w2))
    b = max(abs(w1), abs(w2))
    return a, b, 0.5 * (a + b), 0.5 * (b - a), 2.0 * a * b


@njit(cache=True, inline="always")
def box_fraction(t: float, a: float, b: float, half: float, d: float, ab2: float) -> float:
    """:func:`box_coverage` at ``t`` [m] of the ranges :func:`box_shape` describes."""
    if t <= -half:
        return 0.0
    if t >= half:
        return 1.0
    if a <= 1e-12 * b:
        return 0.5 + t / b
    if t < -d:
        s = t + half
        return s * s / ab2
    if t > d:
        s = half - t
        return 1.0 - s * s / ab2
    return 0.5 + t / b


@njit(cache=True)
def box_density(t: float, w1: float, w2: float) -> float:
    """Derivative of :func:`box_coverage` with respect to ``t`` [1/m] (rate of wetting per depth)."""
    a = min(abs(w1), abs(w2))
    b = max(abs(w1), abs(w2))
    half = 0.5 * (a + b)
    if t <= -half or t >= half:
        return 0.0
    if a <= 1e-12 * b:
        return 1.0 / b
    d = 0.5 * (b - a)
    if t < -d:
        return (t + half) / (a * b)
    if t > d:
        return (half - t) / (a * b)
    return 1.0 / b


@njit(cache=True)
def disk_chord(dx: float, dy: float, ax: float, ay: float, az: float, radius: float,
               thickness: float) -> tuple[float, float]:
    """Vertical extent (lo, hi) [m, relative to the centre's z] of a disk on the vertical line at
    horizontal offset (dx, dy) from its centre; lo > hi when the line misses the disk.

    The disk is the slab |(p - c).a| <= e/2 intersected with the infinite cylinder of radius R
    about the axis a (a unit vector): a linear and a quadratic condition in z.
    """
    sigma = dx * ax + dy * ay
    half_e = 0.5 * thickness
    if abs(az) > AXIS_EPS:
        z1 = (-half_e - sigma) / az
        z2 = (half_e - sigma) / az
        lo = min(z1, z2)
        hi = max(z1, z2)
    else:
        if abs(sigma) > half_e:
            return EMPTY
        lo = -math.inf
        hi = math.inf
    # radial distance from the axis squared: A z^2 + B z + C + R^2
    qa = 1.0 - az * az
    qb = -2.0 * sigma * az
    qc = dx * dx + dy * dy - sigma * sigma - radius * radius
    if qa > AXIS_EPS:
        disc = qb * qb - 4.0 * qa * qc
        if disc < 0.0:
            return EMPTY
        sq = math.sqrt(disc)
        lo = max(lo, (-qb - sq) / (2.0 * qa))
        hi = min(hi, (-qb + sq) / (2.0 * qa))
    elif qc > 0.0:
        return EMPTY
    return lo, hi


@njit(cache=True)
def sphere_chord(dx: float, dy: float, radius: float) -> tuple[float, float]:
    """Vertical extent (lo, hi) [m, relative to the centre's z] of a sphere at offset (dx, dy)."""
    r2 = dx * dx + dy * dy
    if r2 >= radius * radius:
        return EMPTY
    h = math.sqrt(radius * radius - r2)
    return -h, h


def disk_half_extents(axis: np.ndarray, radius: float, thickness: float) -> tuple[float, float]:
    """Half-widths [m] of a disk's horizontal bounding box along world x and y."""
    ax, ay = abs(float(axis[0])), abs(float(axis[1]))
    return (radius * math.sqrt(max(0.0, 1.0 - ax * ax)) + 0.5 * thickness * ax,
            radius * math.sqrt(max(0.0, 1.0 - ay * ay)) + 0.5 * thickness * ay)


def lowest_point(shape_is_disk: bool, centre: np.ndarray, axis: np.ndarray, radius: float,
                 thickness: float) -> tuple[float, float, float]:
    """The body's lowest point (x, y, z) in world coordinates [m]."""
    cx, cy, cz = float(centre[0]), float(centre[1]), float(centre[2])
    if not shape_is_disk:
        return cx, cy, cz - radius
    ax, ay, az = float(axis[0]), float(axis[1]), float(axis[2])
    # -z projected on the disk plane, scaled to the rim; then down to the lower face
    dx, dy, dz = az * ax, az * ay, -1.0 + az * az
    norm = math.sqrt(dx * dx + dy * dy + dz * dz)
    k = radius / norm if norm > 1e-12 else 0.0
    f = -0.5 * thickness * (1.0 if az >= 0 else -1.0)
    return cx + k * dx + f * ax, cy + k * dy + f * ay, cz + k * dz + f * az


@dataclass(frozen=True)
class Elements:
    """A tiling of a body's surface into flat elements.

    pos: (N, 3) element centroids [m] and nrm: (N, 3) outward unit normals, relative to the centre
    of mass, in the body frame (disk) or the world frame (sphere, which is tiled once in the world:
    its surface looks the same in any attitude); area: (N,) [m^2]; t1, t2: (N, 3) the element's two
    sides as vectors [m] (their z components in the world give the element's height range, for
    partial wetting); sub: (N, S, 3) a disk face square's pieces, ``FACE_SUBDIVISION`` per side
    (S = FACE_SUBDIVISION^2): each piece's centroid (du, dv) [m] from the element's centroid along body x
    and y, and its share of the element's area [-] (zero outside the disk), so that where on the
    element its wetted part lies, and the planing pressure's weight there, are resolved finer than
    the element (kernel._element_pass); S = 0 for a sphere's bands. whole: (N,) 1.0 for a face
    square the rim does not clip (its pieces a regular grid of equal shares, which the kernel sums in
    closed form), else 0.0.
    """

    pos: np.ndarray
    nrm: np.ndarray
    area: np.ndarray
    t1: np.ndarray
    t2: np.ndarray
    sub: np.ndarray
    whole: np.ndarray
    world_fixed: bool

    @property
    def total_area(self) -> float:
        return float(self.area.sum())


FACE_SUBDIVISION = 4  # pieces per side of a disk face's square (Elements.sub)


PAIRWISE_BLOCK = 128  # numpy's PW_BLOCKSIZE: the longest run its pairwise sum adds without splitting


@njit(cache=True)
def _block_sum(values: np.ndarray, lo: int, n: int) -> float:
    """numpy's pairwise sum of a run of at most PAIRWISE_BLOCK values (see :func:`_numpy_sum`)."""
    if n < 8:
        res = -0.0
        for i in range(lo, lo + n):
            res += values[i]
        return res
    r0, r1, r2, r3 = values[lo], values[lo + 1], values[lo + 2], values[lo + 3]
    r4, r5, r6, r7 = values[lo + 4], values[lo + 5], values[lo + 6], values[lo + 7]
    i = 8
    end = n - n % 8
    while i < end:
        at = lo + i
        r0 += values[at]
        r1 += values[at + 1]
        r2 += values[at + 2]
        r3 += values[at + 3]
        r4 += values[at + 4]
        r5 += values[at + 5]
        r6 += values[at + 6]
        r7 += values[at + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += values[lo + i]
        i += 1
    return res


@njit(cache=True)
def _numpy_sum(values: np.ndarray, lo: int, n: int) -> float:
    """The sum of ``values[lo:lo + n]`` exactly as ``numpy.add.reduce`` forms it on a contiguous
    float64 run (its pairwise summation, ``pairwise_sum`` in numpy/_core/src/umath/loops_utils.h.src):
    under 8 values in turn from -0.0; up to PAIRWISE_BLOCK in eight running sums, joined in pairs,
    then the rest in turn; a longer run halved (the first half a multiple of 8) and each half summed
    so, left plus right. The same bits as numpy's, so the compiled tiling is the one numpy built.
    (The halving is walked with a stack of its own: numba's cache does not keep recursive kernels.)"""
    depth = 64
    run_lo = np.empty(depth, np.int64)
    run_n = np.empty(depth, np.int64)
    left = np.empty(depth)
    halved = np.zeros(depth, np.bool_)  # its left half summed, into left
    run_lo[0], run_n[0] = lo, n
    top = 1
    total = 0.0
    done = False  # total holds the sum of the run just left (the top's child)
    while True:
        if done:
            if top == 0:
                return total
            f = top - 1
            if not halved[f]:  # its left half: keep it and go down the right one
                left[f] = total
                halved[f] = True
                half = run_n[f] // 2
                half -= half % 8
                run_lo[top], run_n[top], halved[top] = run_lo[f] + half, run_n[f] - half, False
                top += 1
                done = False
            else:  # its right half: the run's sum is left plus right
                total = left[f] + total
                top -= 1
            continue
        f = top - 1
        if run_n[f] <= PAIRWISE_BLOCK:
            total = _block_sum(values, run_lo[f], run_n[f])
            top -= 1
            done = True
            continue
        half = run_n[f] // 2
        half -= half % 8
        run_lo[top], run_n[top], halved[top] = run_lo[f], half, False
        top += 1


@njit(cache=True)
def _face_squares(radius: float, across: int, oversample: int, m: int):
    """The squares of a disk face clipped to its circle, as :func:`disk_elements` describes them:
    (centroid u (n,), centroid v (n,), area (n,) before the clipping residual is removed, pieces
    (n, m * m, 3): each piece's centroid offset from its square's and share of its area), each
    square sampled on ``oversample x oversample`` points and each mean formed as numpy's ``mean``
    forms it (:func:`_numpy_sum` over the inside points in row order, divided by their count)."""
    side = 2.0 * radius / across
    sub = (np.arange(oversample) + 0.5) / oversample * side
    k = oversample // m  # samples per piece side
    n_max = across * across
    us = np.empty(n_max)
    vs = np.empty(n_max)
    areas = np.empty(n_max)
    pieces = np.zeros((n_max, m * m, 3))
    gx = np.empty(oversample * oversample)  # the inside points' coordinates, in row order
    gy = np.empty(oversample * oversample)
    px = np.empty(k * k)
    py = np.empty(k * k)
    inside = np.empty((oversample, oversample), np.bool_)
    r2 = radius * radius
    n_face = 0
    for i in range(across):
        x0 = -radius + i * side
        for j in range(across):
            y0 = -radius + j * side
            count = 0
            for a in range(oversample):
                x = x0 + sub[a]
                for b in range(oversample):
                    y = y0 + sub[b]
                    inside[a, b] = x * x + y * y <= r2
                    if inside[a, b]:
                        gx[count] = x
                        gy[count] = y
                        count += 1
            if count == 0:
                continue
            u0 = _numpy_sum(gx, 0, count) / count
            v0 = _numpy_sum(gy, 0, count) / count
            us[n_face] = u0
            vs[n_face] = v0
            areas[n_face] = count / (oversample * oversample) * side * side
            for pa in range(m):
                for pb in range(m):
                    n = 0
                    for a in range(pa * k, (pa + 1) * k):
                        for b in range(pb * k, (pb + 1) * k):
                            if inside[a, b]:
                                px[n] = x0 + sub[a]
                                py[n] = y0 + sub[b]
                                n += 1
                    if n:
                        q = pa * m + pb
                        pieces[n_face, q, 0] = _numpy_sum(px, 0, n) / n - u0
                        pieces[n_face, q, 1] = _numpy_sum(py, 0, n) / n - v0
                        pieces[n_face, q, 2] = n / count
            n_face += 1
    return us[:n_face], vs[:n_face], areas[:n_face], pieces[:n_face]


@lru_cache(maxsize=16)
def disk_elements(radius: float, thickness: float, across: int = 16, rim: int = 48,
                  oversample: int = 16) -> Elements:
    """Both faces of a disk as ``across x across`` squares clipped to the circle, plus ``rim`` strips.

    A clipped square keeps its true area and centroid (computed on an ``oversample``-fine grid), so
    the face area is pi R^2 to ~1e-4 and the face's first moments are right; so does each of its
    ``FACE_SUBDIVISION x FACE_SUBDIVISION`` pieces (``Elements.sub``; ``oversample`` a multiple of
    it). The squares are found by a compiled pass (:func:`_face_squares`, 0.7 ms
    where numpy's array calls square by square took about 40 ms of a process's first wet step).

    Cached: the same disk's tiling is shared by every coupler of a process, the runs of a sweep's
    worker among them. Its arrays are read, never written.
    """
    if across < 2 or rim < 3:
        raise ValueError(f"disk tiling needs across >= 2 and rim >= 3 (got {across}, {rim})")
    m = FACE_SUBDIVISION
    if oversample % m:
        raise ValueError(f"disk tiling needs oversample a multiple of {m} (got {oversample})")
    side = 2.0 * radius / across
    u, v, a, pieces = _face_squares(float(radius), int(across), int(oversample), m)
    a *= math.pi * radius * radius / a.sum()  # remove the residual of the oversampled clipping
    n_face = len(u)
    half_e = 0.5 * thickness
    pos, nrm, area, t1, t2 = [], [], [], [], []
    for sign in (1.0, -1.0):
        pos.append(np.column_stack([u, v, np.full(n_face, sign * half_e)]))
        nrm.append(np.tile([0.0, 0.0, sign], (n_face, 1)))
        area.append(a)
        t1.append(np.tile([side, 0.0, 0.0], (n_face, 1)))
        t2.append(np.tile([0.0, side, 0.0], (n_face, 1)))
    if thickness > 0:
        theta = (np.arange(rim) + 0.5) * 2.0 * math.pi / rim
        c, s = np.cos(theta), np.sin(theta)
        arc = 2.0 * math.pi * radius / rim
        pos.append(np.column_stack([radius * c, radius * s, np.zeros(rim)]))
        nrm.append(np.column_stack([c, s, np.zeros(rim)]))
        area.append(np.full(rim, arc * thickness))
        t1.append(np.column_stack([-arc * s, arc * c, np.zeros(rim)]))
        t2.append(np.tile([0.0, 0.0, thickness], (rim, 1)))
    n_rim = rim if thickness > 0 else 0
    sub = np.concatenate([pieces, pieces, np.zeros((n_rim, m * m, 3))])
    whole = np.all(pieces[:, :, 2] == 1.0 / (m * m), axis=1).astype(np.float64)
    return Elements(*(np.ascontiguousarray(np.concatenate(x)) for x in (pos, nrm, area, t1, t2)),
                    sub=np.ascontiguousarray(sub), whole=np.concatenate([whole, whole, np.zeros(n_rim)]),
                    world_fixed=False)


@lru_cache(maxsize=16)
def sphere_elements(radius: float, bands: int = 24) -> Elements:
    """A sphere as equal-area latitude bands (Archimedes' hat-box: equal steps in z), each cut into
    azimuthal pieces about as long as they are high.

    A band's height range is exactly its z step, and the area of a sphere below a horizontal plane
    is linear in the plane's height, so the linear partial wetting of :func:`box_coverage` makes the
    wetted area of a sphere in still water exact.
    """
    if bands < 2:
        raise ValueError(f"sphere tiling needs bands >= 2 (got {bands})")
    dz = 2.0 / bands
    pos, nrm, area, t1, t2 = [], [], [], [], []
    for k in range(bands):
        nz = -1.0 + (k + 0.5) * dz
        st = math.sqrt(max(0.0, 1.0 - nz * nz))
        height = radius * math.acos(-1.0 + k * dz) - radius * math.acos(min(1.0, -1.0 + (k + 1) * dz))
        n_az = 2 * max(2, round(math.pi * radius * st / max(height, 1e-12)))
        phi = (np.arange(n_az) + 0.5 + 0.5 * (k % 2)) * 2.0 * math.pi / n_az
        c, s = np.cos(phi), np.sin(phi)
        n = np.column_stack([st * c, st * s, np.full(n_az, nz)])
        nrm.append(n)
        pos.append(radius * n)
        area.append(np.full(n_az, 2.0 * math.pi * radius * radius * dz / n_az))
        arc = 2.0 * math.pi * radius * st / n_az
        t1.append(np.column_stack([-arc * s, arc * c, np.zeros(n_az)]))
        # the band's meridian side: its z range is exactly the band's z step
        t2.append(np.column_stack([np.zeros(n_az), np.zeros(n_az), np.full(n_az, radius * dz)]))
    n = sum(len(x) for x in area)
    return Elements(*(np.ascontiguousarray(np.concatenate(x)) for x in (pos, nrm, area, t1, t2)),
                    sub=np.zeros((n, 0, 3)), whole=np.zeros(n), world_fixed=True)


@njit(cache=True)
def quat_to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (body -> world) of a unit quaternion (w, x, y, z); its columns are the body axes."""
    w, x, y, z = q[0], q[1], q[2], q[3]
    n = w * w + x * x + y * y + z * z
    s = 2.0 / n if n > 0 else 0.0
    m = np.empty((3, 3))
    m[0, 0] = 1 - s * (y * y + z * z)
    m[0, 1] = s * (x * y - w * z)
    m[0, 2] = s * (x * z + w * y)
    m[1, 0] = s * (x * y + w * z)
    m[1, 1] = 1 - s * (x * x + z * z)
    m[1, 2] = s * (y * z - w * x)
    m[2, 0] = s * (x * z - w * y)
    m[2, 1] = s * (y * z + w * x)
    m[2, 2] = 1 - s * (x * x + y * y)
    return m
