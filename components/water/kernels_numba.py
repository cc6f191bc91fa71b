"""Compiled kernels of the water step (numba), twins of :mod:`components.water.kernels_numpy`.

Speed comes from doing one pass over memory: the wave step reads h and v once and writes the new
h and v into the spare buffers (ping-pong), which is the same traffic as copying the two arrays.

Two kernel sets share the compiled code: :data:`SERIAL` (one thread, the default) and
:data:`PARALLEL`, which splits the rows of large grids across threads (``prange``). Each cell's
arithmetic does not depend on the split, so both agree bit for bit. The parallel set is opt-in:
on a loaded machine a step waits for its slowest thread, and a descheduled worker can cost a whole
scheduler time slice (milliseconds), whereas the single-threaded kernel degrades only as much as
anything else running there.

Compiled code is cached on disk (``cache=True``); the first call in a fresh checkout compiles.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from components import kernel_cache

kernel_cache.install()  # before the cached kernels below: their cache keyed on every kernel source

PARALLEL_MIN_CELLS = 32_768  # smaller grids run single-threaded even in PARALLEL (thread start-up dominates)
COLUMN_BLOCK = 64  # columns per thread's task in the parallel column (y) sweep: contiguous runs of this many doubles


# --- the wave step, one coefficient --------------------------------------------------------------

@njit(cache=True, inline="always")
def wave_uniform_span(hc, hs, hn, vc, ho, vo, lo, hi, kdt, dt, damp):  # pragma: no cover - compiled
    # Cells lo .. hi - 1 of one row (hc; hs, hn the rows south and north, the row itself at an edge;
    # vc its velocities; ho, vo the new row): an edge cell takes its own height for the neighbour it
    # lacks. The edge cells are peeled off so that the interior loop vectorises. The tiled step
    # (components.water.tiles) runs its spans through this too, so both hold the same bits.
    nx = hc.size
    if lo == 0 and hi > 0:
        c = hc[0]
        east = hc[1] if nx > 1 else c
        lap = c + east + hs[0] + hn[0] - 4.0 * c
        vn = (vc[0] + kdt * lap) * damp
        vo[0] = vn
        ho[0] = c + dt * vn
        lo = 1
    if hi == nx and nx - 1 >= lo:
        i = nx - 1
        c = hc[i]
        lap = hc[i - 1] + c + hs[i] + hn[i] - 4.0 * c
        vn = (vc[i] + kdt * lap) * damp
        vo[i] = vn
        ho[i] = c + dt * vn
        hi = nx - 1
    # Unsigned indices: numba wraps a signed index that may be negative (i - 1 with lo unknown), a
    # select per access that keeps the loop from vectorising (5x slower when lo and hi are not
    # constants, as in the tiled step's spans); here lo >= 1, so i - 1 never wraps.
    one = np.uint64(1)
    for i in range(np.uint64(lo), np.uint64(hi)):
        c = hc[i]
        lap = hc[i - one] + hc[i + one] + hs[i] + hn[i] - 4.0 * c
        vn = (vc[i] + kdt * lap) * damp
        vo[i] = vn
        ho[i] = c + dt * vn


@njit(cache=True, inline="always")
def _wave_uniform_row(h, v, h_out, v_out, j, kdt, dt, damp):  # pragma: no cover - compiled
    ny = h.shape[0]
    hc = h[j]
    hs = h[j - 1] if j > 0 else hc
    hn = h[j + 1] if j < ny - 1 else hc
    wave_uniform_span(hc, hs, hn, v[j], h_out[j], v_out[j], 0, hc.size, kdt, dt, damp)


@njit(cache=True, parallel=True)
def _wave_uniform_par(h, v, h_out, v_out, kdt, dt, damp):  # pragma: no cover - compiled
    for j in prange(h.shape[0]):
        _wave_uniform_row(h, v, h_out, v_out, j, kdt, dt, damp)


@njit(cache=True)
def _wave_uniform_ser(h, v, h_out, v_out, kdt, dt, damp):  # pragma: no cover - compiled
    for j in range(h.shape[0]):
        _wave_uniform_row(h, v, h_out, v_out, j, kdt, dt, damp)




# --- the wave step, per-face coefficients ---------------------------------------------------------
#
# Every helper called per cell takes scalars only: an inlined helper that is handed arrays makes
# numba take and drop a reference on each of them at every call (atomic operations), which made
# these kernels 30 to 40 times slower than the uniform step. Helpers here work on whole rows.

@njit(cache=True, inline="always")
def _wave_faces_row(h, v, h_out, v_out, ax, ay, j, dt, damp):  # pragma: no cover - compiled
    # Row j: the interior cells of an interior row have all four faces and run without a branch
    # (the loop vectorises); the edge cells of the row, and every cell of the first and last rows,
    # add only the faces they have. Terms are added west, east, south, north as in the numpy twin.
    ny, nx = h.shape
    south = j > 0
    north = j < ny - 1
    hc = h[j]
    hs = h[j - 1] if south else hc
    hn = h[j + 1] if north else hc
    aw = ax[j]
    a_s = ay[j - 1] if south else ay[j]  # the unused side of an edge row points at any valid row
    a_n = ay[j] if north else ay[j - 1]
    vc = v[j]
    ho = h_out[j]
    vo = v_out[j]
    interior = south and north
    for i in range(0, nx, nx - 1 if interior and nx > 1 else 1):
        c = hc[i]
        acc = 0.0
        if i > 0:
            acc += aw[i - 1] * (hc[i - 1] - c)
        if i < nx - 1:
            acc += aw[i] * (hc[i + 1] - c)
        if south:
            acc += a_s[i] * (hs[i] - c)
        if north:
            acc += a_n[i] * (hn[i] - c)
        vn = (vc[i] + dt * acc) * damp
        vo[i] = vn
        ho[i] = c + dt * vn
    if interior:
        for i in range(1, nx - 1):
            c = hc[i]
            acc = (aw[i - 1] * (hc[i - 1] - c) + aw[i] * (hc[i + 1] - c)
                   + a_s[i] * (hs[i] - c) + a_n[i] * (hn[i] - c))
            vn = (vc[i] + dt * acc) * damp
            vo[i] = vn
            ho[i] = c + dt * vn


@njit(cache=True, parallel=True)
def _wave_faces_par(h, v, h_out, v_out, ax, ay, dt, damp):  # pragma: no cover - compiled
    for j in prange(h.shape[0]):
        _wave_faces_row(h, v, h_out, v_out, ax, ay, j, dt, damp)


@njit(cache=True)
def _wave_faces_ser(h, v, h_out, v_out, ax, ay, dt, damp):  # pragma: no cover - compiled
    for j in range(h.shape[0]):
        _wave_faces_row(h, v, h_out, v_out, ax, ay, j, dt, damp)




# --- Kass-Miller alternating-direction sweeps -----------------------------------------------------

@njit(cache=True, inline="always")
def _adi_x_row(h, v, dt, out, lower, inv, upper, j):  # pragma: no cover - compiled
    nx = h.shape[1]
    f = j - j if lower.shape[0] == 1 else j  # one factor row shared by all rows on a uniform grid
    o = out[j]
    lo = lower[f]
    iv = inv[f]
    up = upper[f]
    hr = h[j]
    vr = v[j]
    prev = (hr[0] + dt * vr[0]) * iv[0]
    o[0] = prev
    for i in range(1, nx):
        prev = ((hr[i] + dt * vr[i]) - lo[i] * prev) * iv[i]
        o[i] = prev
    for i in range(nx - 2, -1, -1):
        prev = o[i] - up[i] * prev
        o[i] = prev


@njit(cache=True, inline="always")
def _adi_x_rows4(h, v, dt, out, lower, inv, upper, j):  # pragma: no cover - compiled
    # Rows j..j+3 solved side by side. Each row's sweep is a chain of dependent operations (a
    # multiply waits for the previous cell's result), so one row at a time leaves the core idle
    # most of each cycle; four independent chains interleaved keep it busy (about 4x faster).
    # Each row's arithmetic is that of _adi_x_row, so the bits are the same.
    nx = h.shape[1]
    shared = lower.shape[0] == 1
    f0, f1, f2, f3 = (0, 0, 0, 0) if shared else (j, j + 1, j + 2, j + 3)
    h0, h1, h2, h3 = h[j], h[j + 1], h[j + 2], h[j + 3]
    v0, v1, v2, v3 = v[j], v[j + 1], v[j + 2], v[j + 3]
    o0, o1, o2, o3 = out[j], out[j + 1], out[j + 2], out[j + 3]
    l0, l1, l2, l3 = lower[f0], lower[f1], lower[f2], lower[f3]
    i0, i1, i2, i3 = inv[f0], inv[f1], inv[f2], inv[f3]
    u0, u1, u2, u3 = upper[f0], upper[f1], upper[f2], upper[f3]
    p0 = (h0[0] + dt * v0[0]) * i0[0]
    p1 = (h1[0] + dt * v1[0]) * i1[0]
    p2 = (h2[0] + dt * v2[0]) * i2[0]
    p3 = (h3[0] + dt * v3[0]) * i3[0]
    o0[0], o1[0], o2[0], o3[0] = p0, p1, p2, p3
    for i in range(1, nx):
        p0 = ((h0[i] + dt * v0[i]) - l0[i] * p0) * i0[i]
        p1 = ((h1[i] + dt * v1[i]) - l1[i] * p1) * i1[i]
        p2 = ((h2[i] + dt * v2[i]) - l2[i] * p2) * i2[i]
        p3 = ((h3[i] + dt * v3[i]) - l3[i] * p3) * i3[i]
        o0[i], o1[i], o2[i], o3[i] = p0, p1, p2, p3
    for i in range(nx - 2, -1, -1):
        p0 = o0[i] - u0[i] * p0
        p1 = o1[i] - u1[i] * p1
        p2 = o2[i] - u2[i] * p2
        p3 = o3[i] - u3[i] * p3
        o0[i], o1[i], o2[i], o3[i] = p0, p1, p2, p3


@njit(cache=True, parallel=True)
def _adi_x_par(h, v, dt, out, lower, inv, upper):  # pragma: no cover - compiled
    ny = h.shape[0]
    for g in prange(ny // 4):
        _adi_x_rows4(h, v, dt, out, lower, inv, upper, 4 * g)
    for j in range(ny - ny % 4, ny):
        _adi_x_row(h, v, dt, out, lower, inv, upper, j)


@njit(cache=True)
def _adi_x_ser(h, v, dt, out, lower, inv, upper):  # pragma: no cover - compiled
    ny = h.shape[0]
    for g in range(ny // 4):
        _adi_x_rows4(h, v, dt, out, lower, inv, upper, 4 * g)
    for j in range(ny - ny % 4, ny):
        _adi_x_row(h, v, dt, out, lower, inv, upper, j)




@njit(cache=True, inline="always")
def _adi_y_block(h, dt, damp, out, v_out, lower, inv, upper, i0, i1):  # pragma: no cover - compiled
    # Columns i0..i1-1 solved together: the sweeps run over rows, the inner loop along a row
    # segment is contiguous and vectorises. The backward sweep also writes v_out, as each row is
    # final once the sweep has passed it (one pass over memory fewer). On a uniform grid the
    # factors are one column (ny, 1), shared by all columns.
    ny = h.shape[0]
    shared = lower.shape[1] == 1
    o = out[0]
    if shared:
        ivj = inv[0, 0]
        for i in range(i0, i1):
            o[i] = o[i] * ivj
    else:
        ivr = inv[0]
        for i in range(i0, i1):
            o[i] = o[i] * ivr[i]
    for j in range(1, ny):
        o = out[j]
        op = out[j - 1]
        if shared:
            loj = lower[j, 0]
            ivj = inv[j, 0]
            for i in range(i0, i1):
                o[i] = (o[i] - loj * op[i]) * ivj
        else:
            lr = lower[j]
            ir = inv[j]
            for i in range(i0, i1):
                o[i] = (o[i] - lr[i] * op[i]) * ir[i]
    o = out[ny - 1]
    hr = h[ny - 1]
    vo = v_out[ny - 1]
    for i in range(i0, i1):
        vo[i] = ((o[i] - hr[i]) / dt) * damp
    for j in range(ny - 2, -1, -1):
        o = out[j]
        on = out[j + 1]
        hr = h[j]
        vo = v_out[j]
        if shared:
            upj = upper[j, 0]
            for i in range(i0, i1):
                x = o[i] - upj * on[i]
                o[i] = x
                vo[i] = ((x - hr[i]) / dt) * damp
        else:
            ur = upper[j]
            for i in range(i0, i1):
                x = o[i] - ur[i] * on[i]
                o[i] = x
                vo[i] = ((x - hr[i]) / dt) * damp


@njit(cache=True, parallel=True)
def _adi_y_par(h, dt, damp, out, v_out, lower, inv, upper, block):  # pragma: no cover - compiled
    nx = h.shape[1]
    nblocks = (nx + block - 1) // block
    for b in prange(nblocks):
        _adi_y_block(h, dt, damp, out, v_out, lower, inv, upper, b * block, min(nx, (b + 1) * block))


@njit(cache=True)
def _adi_y_ser(h, dt, damp, out, v_out, lower, inv, upper):  # pragma: no cover - compiled
    # one thread: whole rows (the longest contiguous runs; blocks only serve to split the work)
    _adi_y_block(h, dt, damp, out, v_out, lower, inv, upper, 0, h.shape[1])




# --- smoothing and the absorbing layer ------------------------------------------------------------

@njit(cache=True, inline="always")
def _smooth_row(h, h_out, wx, wy, j, g):  # pragma: no cover - compiled
    # The face weights of row j, laid out like _wave_faces_row (interior without a branch).
    ny, nx = h.shape
    south = j > 0
    north = j < ny - 1
    hc = h[j]
    hs = h[j - 1] if south else hc
    hn = h[j + 1] if north else hc
    ww = wx[j]
    w_s = wy[j - 1] if south else wy[j]
    w_n = wy[j] if north else wy[j - 1]
    ho = h_out[j]
    interior = south and north
    for i in range(0, nx, nx - 1 if interior and nx > 1 else 1):
        c = hc[i]
        acc = 0.0
        if i > 0:
            acc += ww[i - 1] * (hc[i - 1] - c)
        if i < nx - 1:
            acc += ww[i] * (hc[i + 1] - c)
        if south:
            acc += w_s[i] * (hs[i] - c)
        if north:
            acc += w_n[i] * (hn[i] - c)
        ho[i] = c + g * acc
    if interior:
        for i in range(1, nx - 1):
            c = hc[i]
            acc = (ww[i - 1] * (hc[i - 1] - c) + ww[i] * (hc[i + 1] - c)
                   + w_s[i] * (hs[i] - c) + w_n[i] * (hn[i] - c))
            ho[i] = c + g * acc


@njit(cache=True, inline="always")
def _smooth_open_row(h, h_out, j, g):  # pragma: no cover - compiled
    # Every face open (weight exactly 1, so the products of _smooth_row are the differences
    # themselves): the same result without reading the two weight arrays.
    ny, nx = h.shape
    south = j > 0
    north = j < ny - 1
    hc = h[j]
    hs = h[j - 1] if south else hc
    hn = h[j + 1] if north else hc
    ho = h_out[j]
    interior = south and north
    for i in range(0, nx, nx - 1 if interior and nx > 1 else 1):
        c = hc[i]
        acc = 0.0
        if i > 0:
            acc += hc[i - 1] - c
        if i < nx - 1:
            acc += hc[i + 1] - c
        if south:
            acc += hs[i] - c
        if north:
            acc += hn[i] - c
        ho[i] = c + g * acc
    if interior:
        for i in range(1, nx - 1):
            c = hc[i]
            acc = (hc[i - 1] - c) + (hc[i + 1] - c) + (hs[i] - c) + (hn[i] - c)
            ho[i] = c + g * acc


@njit(cache=True, parallel=True)
def _smooth_par(h, h_out, wx, wy, f):  # pragma: no cover - compiled
    g = 0.25 * f
    for j in prange(h.shape[0]):
        _smooth_row(h, h_out, wx, wy, j, g)


@njit(cache=True)
def _smooth_ser(h, h_out, wx, wy, f):  # pragma: no cover - compiled
    g = 0.25 * f
    for j in range(h.shape[0]):
        _smooth_row(h, h_out, wx, wy, j, g)


@njit(cache=True, parallel=True)
def _smooth_open_par(h, h_out, f):  # pragma: no cover - compiled
    g = 0.25 * f
    for j in prange(h.shape[0]):
        _smooth_open_row(h, h_out, j, g)


@njit(cache=True)
def _smooth_open_ser(h, h_out, f):  # pragma: no cover - compiled
    g = 0.25 * f
    for j in range(h.shape[0]):
        _smooth_open_row(h, h_out, j, g)


@njit(cache=True)
def _blur(d, work, passes, weight):  # pragma: no cover - compiled
    # ``passes`` conservative blur passes of d (closed edges), in place; ``work`` is d's shape.
    # Per cell: 0 + east difference - west difference + north - south, as in the numpy twin.
    ny, nx = d.shape
    src, dst = d, work
    for _ in range(passes):
        for j in range(ny):
            for i in range(nx):
                c = src[j, i]
                acc = 0.0
                if i < nx - 1:
                    acc += src[j, i + 1] - c
                if i > 0:
                    acc -= c - src[j, i - 1]
                if j < ny - 1:
                    acc += src[j + 1, i] - c
                if j > 0:
                    acc -= c - src[j - 1, i]
                dst[j, i] = c + weight * acc
        src, dst = dst, src
    if passes % 2 == 1:
        d[:, :] = work


@njit(cache=True, inline="always")
def _sponge_cell(h, v, sx, sy, j, i, dt):  # pragma: no cover - compiled
    q = 1.0 / (1.0 + (sx[i] + sy[j]) * dt)
    h[j, i] *= q
    v[j, i] *= q


@njit(cache=True)
def _sponge(h, v, sx, sy, width, dt):  # pragma: no cover - compiled
    # Only the cells of the layer are visited (the interior factor is exactly 1): _sponge_moving
    # with the whole grid as one tile.
    ny, nx = h.shape
    _sponge_moving(h, v, sx, sy, width, dt, np.ones((1, 1), dtype=np.bool_), max(ny, nx, 1))




@njit(cache=True)
def _one_way(h_old, h, v, kl, kr, kb, kt, ol, orr, ob, ot, dt):  # pragma: no cover - compiled
    # Every edge cell: the bottom and top edges as one run of columns each.
    whole = np.array([[0, h.shape[1]]], dtype=np.int64)
    _one_way_runs(h_old, h, v, kl, kr, kb, kt, ol, orr, ob, ot, dt, whole, whole)


@njit(cache=True)
def _one_way_runs(h_old, h, v, kl, kr, kb, kt, ol, orr, ob, ot, dt, south, north):  # pragma: no cover - compiled
    # The one-way condition on the open cells of the left and right edges (masks ol, orr) and on
    # those of the bottom and top edges within the column runs ``south`` and ``north`` ((n, 2),
    # [start, end)). Left and right edges share each row's loop (each row is a different memory
    # page on large grids, so visiting it once matters); the results equal the edge-by-edge order
    # of the numpy twin. The bottom and top rows go by runs rather than by masks: a vectorised
    # loop whose masks are off over memory never written (a lake's far edge, its pages not yet
    # mapped) took 1.2 ms a call here on a 4000-column lake, against 12 us once its pages are.
    ny, nx = h.shape
    for j in range(ny):
        if ol[j]:
            h[j, 0] = h_old[j, 1] + kl[j] * (h[j, 1] - h_old[j, 0])
        if orr[j]:
            h[j, nx - 1] = h_old[j, nx - 2] + kr[j] * (h[j, nx - 2] - h_old[j, nx - 1])
    _edge_level(h_old, h, 0, 1, kb, ob, south)
    _edge_level(h_old, h, ny - 1, ny - 2, kt, ot, north)
    for j in range(ny):
        if ol[j]:
            v[j, 0] = (h[j, 0] - h_old[j, 0]) / dt
        if orr[j]:
            v[j, nx - 1] = (h[j, nx - 1] - h_old[j, nx - 1]) / dt
    _edge_rate(h_old, h, v, 0, ob, south, dt)
    _edge_rate(h_old, h, v, ny - 1, ot, north, dt)


@njit(cache=True, inline="always")
def _edge_level(h_old, h, row, inner, k, open_, runs):  # pragma: no cover - compiled
    # the one-way condition on the open cells of edge ``row`` within ``runs``, from its ``inner``
    # neighbour row. Unsigned indices: a signed one from a range with a variable start is wrapped
    # (a select per access), which keeps the loop from vectorising (see wave_uniform_span).
    edge_old, edge_new, in_old, in_new = h_old[row], h[row], h_old[inner], h[inner]
    for r in range(runs.shape[0]):
        for i in range(np.uint64(runs[r, 0]), np.uint64(runs[r, 1])):
            if open_[i]:
                edge_new[i] = in_old[i] + k[i] * (in_new[i] - edge_old[i])


@njit(cache=True, inline="always")
def _edge_rate(h_old, h, v, row, open_, runs, dt):  # pragma: no cover - compiled
    # v = (h - h_old) / dt on the open cells of ``row`` within ``runs`` (unsigned indices, as above)
    new, old, rate = h[row], h_old[row], v[row]
    for r in range(runs.shape[0]):
        for i in range(np.uint64(runs[r, 0]), np.uint64(runs[r, 1])):
            if open_[i]:
                rate[i] = (new[i] - old[i]) / dt


@njit(cache=True)
def _runs(flags, tile, n):  # pragma: no cover - compiled
    # The cells [start, end) of the runs of consecutive tiles marked in ``flags`` (tiles of ``tile``
    # cells over n cells), (runs, 2).
    out = np.empty((flags.size, 2), dtype=np.int64)
    k = 0
    t = 0
    while t < flags.size:
        if not flags[t]:
            t += 1
            continue
        start = t
        while t < flags.size and flags[t]:
            t += 1
        out[k, 0] = start * tile
        out[k, 1] = min(t * tile, n)
        k += 1
    return out[:k]


@njit(cache=True)
def _sponge_moving(h, v, sx, sy, width, dt, near, tile):  # pragma: no cover - compiled
    # The sponge layer over the cells of the tiles marked in ``near`` (nty, ntx) only: every other
    # tile is at rest (zeros) before and after the step, which the layer's factor leaves as they
    # are. Rows and columns go by tiles (no division per cell).
    ny, nx = h.shape
    nty, ntx = near.shape
    for tj in range(nty):
        for j in range(tj * tile, min(tj * tile + tile, ny)):
            whole = j < width or j >= ny - width
            for ti in range(ntx):
                if not near[tj, ti]:
                    continue
                i0 = ti * tile
                i1 = min(i0 + tile, nx)
                if not whole:  # the layer's columns only: [0, width) and [max(nx - width, width), nx)
                    a1 = min(i1, width)
                    for i in range(i0, a1):
                        _sponge_cell(h, v, sx, sy, j, i, dt)
                    i0 = max(i0, nx - width, width)
                for i in range(i0, i1):
                    _sponge_cell(h, v, sx, sy, j, i, dt)


@njit(cache=True)
def _one_way_moving(h_old, h, v, kl, kr, kb, kt, ol, orr, ob, ot, dt, near, tile):  # pragma: no cover - compiled
    # _one_way on the edge cells of the tiles marked in ``near`` (nty, ntx) only: the left and right
    # edges' open masks narrowed to those tiles, the bottom and top edges visited over their runs.
    # An edge cell reads its inner neighbour (and a corner, written twice, the cell diagonally
    # inside it through its neighbour's new value), which lie in the same tile or in one around
    # it; ``near`` marks every tile stepped and the eight around each (Tiles.moving), so where it
    # is not marked they are all at rest before and after the step (zeros) and the condition gives
    # zero again. On a lake most of the edge, whose rows lie on distinct memory pages, is then not
    # visited.
    ny, nx = h.shape
    nty, ntx = near.shape
    west, east = ol.copy(), orr.copy()
    for tj in range(nty):
        j0, j1 = tj * tile, min(tj * tile + tile, ny)
        if not near[tj, 0]:
            west[j0:j1] = False
        if not near[tj, ntx - 1]:
            east[j0:j1] = False
    _one_way_runs(h_old, h, v, kl, kr, kb, kt, west, east, ob, ot, dt, _runs(near[0], tile, nx),
                  _runs(near[nty - 1], tile, nx))


class NumbaKernels:
    """The compiled kernel set (same functions as :mod:`components.water.kernels_numpy`, and the
    ``*_moving`` variants of the edge conditions for the step by tiles, which has no numpy twin)."""

    def __init__(self, name: str, parallel: bool):
        self.NAME = name
        self.parallel = parallel

    def _threads(self, h: np.ndarray) -> bool:
        return self.parallel and h.size >= PARALLEL_MIN_CELLS

    def wave_uniform(self, h: np.ndarray, v: np.ndarray, h_out: np.ndarray, v_out: np.ndarray,
                     kdt: float, dt: float, damp: float) -> None:
        """See :func:`components.water.kernels_numpy.wave_uniform`."""
        fn = _wave_uniform_par if self._threads(h) else _wave_uniform_ser
        fn(h, v, h_out, v_out, kdt, dt, damp)

    def wave_faces(self, h: np.ndarray, v: np.ndarray, h_out: np.ndarray, v_out: np.ndarray,
                   ax: np.ndarray, ay: np.ndarray, dt: float, damp: float) -> None:
        """See :func:`components.water.kernels_numpy.wave_faces`."""
        fn = _wave_faces_par if self._threads(h) else _wave_faces_ser
        fn(h, v, h_out, v_out, ax, ay, dt, damp)

    def adi_x(self, h: np.ndarray, v: np.ndarray, dt: float, out: np.ndarray,
              lower: np.ndarray, inv: np.ndarray, upper: np.ndarray) -> None:
        """See :func:`components.water.kernels_numpy.adi_x`."""
        fn = _adi_x_par if self._threads(h) else _adi_x_ser
        fn(h, v, dt, out, lower, inv, upper)

    def adi_y(self, h: np.ndarray, dt: float, damp: float, out: np.ndarray, v_out: np.ndarray,
              lower: np.ndarray, inv: np.ndarray, upper: np.ndarray) -> None:
        """See :func:`components.water.kernels_numpy.adi_y`."""
        if self._threads(h):
            _adi_y_par(h, dt, damp, out, v_out, lower, inv, upper, COLUMN_BLOCK)
        else:
            _adi_y_ser(h, dt, damp, out, v_out, lower, inv, upper)

    def smooth(self, h: np.ndarray, h_out: np.ndarray, wx: np.ndarray, wy: np.ndarray, f: float) -> None:
        """See :func:`components.water.kernels_numpy.smooth`."""
        fn = _smooth_par if self._threads(h) else _smooth_ser
        fn(h, h_out, wx, wy, f)

    def smooth_open(self, h: np.ndarray, h_out: np.ndarray, f: float) -> None:
        """See :func:`components.water.kernels_numpy.smooth_open`."""
        fn = _smooth_open_par if self._threads(h) else _smooth_open_ser
        fn(h, h_out, f)

    def blur(self, d: np.ndarray, work: np.ndarray, passes: int, weight: float) -> None:
        """See :func:`components.water.kernels_numpy.blur` (a patch is small: one thread)."""
        _blur(d, work, passes, weight)

    def sponge(self, h: np.ndarray, v: np.ndarray, sx: np.ndarray, sy: np.ndarray, width: int,
               dt: float) -> None:
        """See :func:`components.water.kernels_numpy.sponge`."""
        _sponge(h, v, sx, sy, width, dt)

    def sponge_moving(self, h: np.ndarray, v: np.ndarray, sx: np.ndarray, sy: np.ndarray, width: int,
                      dt: float, near: np.ndarray, tile: int) -> None:
        """:meth:`sponge` over the tiles marked in ``near`` (nty, ntx) of ``tile`` cells only, the
        others being at rest before and after the step (the tiled step, components.water.tiles)."""
        _sponge_moving(h, v, sx, sy, width, dt, near, tile)

    def one_way_moving(self, h_old: np.ndarray, h: np.ndarray, v: np.ndarray, kl: np.ndarray, kr: np.ndarray,
                       kb: np.ndarray, kt: np.ndarray, ol: np.ndarray, orr: np.ndarray, ob: np.ndarray,
                       ot: np.ndarray, dt: float, near: np.ndarray, tile: int) -> None:
        """:meth:`one_way` on the edge cells of the tiles marked in ``near`` only (see
        :meth:`sponge_moving`)."""
        _one_way_moving(h_old, h, v, kl, kr, kb, kt, ol, orr, ob, ot, dt, near, tile)

    def one_way(self, h_old: np.ndarray, h: np.ndarray, v: np.ndarray, kl: np.ndarray, kr: np.ndarray,
                kb: np.ndarray, kt: np.ndarray, ol: np.ndarray, orr: np.ndarray, ob: np.ndarray,
                ot: np.ndarray, dt: float) -> None:
        """See :func:`components.water.kernels_numpy.one_way`."""
        _one_way(h_old, h, v, kl, kr, kb, kt, ol, orr, ob, ot, dt)


SERIAL = NumbaKernels("numba", parallel=False)
"""Compiled kernels on one thread (the default)."""
PARALLEL = NumbaKernels("numba", parallel=True)
"""Compiled kernels splitting large grids across threads (``parallel: true``)."""
