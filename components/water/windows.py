"""The water's per-step window work for its bodies, each in one compiled pass.

Every step the water takes each body's occupied height over a small window and sends each body a
patch of columns around it. As numpy slices, each of those is a handful of operations on arrays
of a few hundred values, and the calls, not the arithmetic, cost the time. These passes do the
same operations, value by value (so the results are the same bit for bit), in one call each.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from components import kernel_cache

kernel_cache.install()  # before the cached kernels below: their cache keyed on every kernel source


@njit(cache=True)
def apply_window(h, occupied, total, shared, b, b_i0, b_j0, u0, u1, v0, v1):
    """A body's new occupied height into the water over the box [v0:v1, u0:u1] (grid indices, inside
    the grid): per column, b_new = ``b`` (nj, ni) [m] at (j - b_j0, i - b_i0), zero off it; h (the
    surface [m]) += b_new - occupied, and occupied = b_new (the body's occupied height over the
    grid); when ``shared`` (one of several bodies), ``total`` (all bodies' occupied height) takes
    the change too."""
    nj, ni = b.shape
    for j in range(v0, v1):
        jb = j - b_j0
        inside_j = 0 <= jb < nj
        for i in range(u0, u1):
            ib = i - b_i0
            new = b[jb, ib] if inside_j and 0 <= ib < ni else 0.0
            delta = new - occupied[j, i]
            if shared:
                total[j, i] += delta
            h[j, i] += delta
            occupied[j, i] = new


@njit(cache=True)
def read_window(surface0, h, v, bed, occupied, i0, i1, j0, j1, out):
    """out (4, j1 - j0, i1 - i0): the surface elevation surface0 + h [m], the vertical velocity v
    [m/s], the bed [m] and the occupied height [m] over the grid's window [j0:j1, i0:i1]."""
    for j in range(j0, j1):
        for i in range(i0, i1):
            out[0, j - j0, i - i0] = surface0[j, i] + h[j, i]
            out[1, j - j0, i - i0] = v[j, i]
            out[2, j - j0, i - i0] = bed[j, i]
            out[3, j - j0, i - i0] = occupied[j, i]


def patch_arrays(surface0: np.ndarray, h: np.ndarray, v: np.ndarray, bed: np.ndarray, occupied: np.ndarray,
                 window: tuple[int, int, int, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(height, velocity, bottom, occupied) over ``window`` (i0, i1, j0, j1): new arrays (views of one
    new block), as surface0[w] + h[w], v[w].copy(), bed[w].copy() and occupied[w].copy() would be."""
    i0, i1, j0, j1 = window
    out = np.empty((4, j1 - j0, i1 - i0))
    read_window(surface0, h, v, bed, occupied, i0, i1, j0, j1, out)
    return out[0], out[1], out[2], out[3]


_MAGNITUDE = 0x7FFF_FFFF_FFFF_FFFF  # a float64's bits but its sign
_INF_BITS = 0x7FF0_0000_0000_0000  # +inf's bits: a magnitude above them is a NaN's
_NAN_BITS = 0x7FF8_0000_0000_0000  # a quiet NaN's, sign clear: above every number's


@njit(cache=True)
def _top_bits(row, lo, hi):  # pragma: no cover - compiled
    # The highest of row[lo:hi] and 0, as the bits of a float64, or a NaN's if the row holds one.
    # Doubles of one sign order as their bits do, and a negative one's bits are negative, below those
    # of 0: the integer maximum of the bits is the one wanted, and unlike a float maximum (held to one
    # lane by NaN's comparisons) it vectorises. A NaN with its sign bit clear is above every number,
    # but one with it set (what x86 makes of inf - inf or 0 * inf) is below 0: NaNs of either sign are
    # found by a second maximum, of the bits without the sign (above infinity's: a NaN).
    bits = row.view(np.int64)
    top = 0
    magnitude = 0
    for i in range(lo, hi):
        b = bits[i]
        top = b if b > top else top
        m = b & _MAGNITUDE
        magnitude = m if m > magnitude else magnitude
    return top if magnitude <= _INF_BITS else _NAN_BITS


@njit(cache=True)
def window_top(h, i0, i1, j0, j1):  # pragma: no cover - compiled
    """The highest h [m] over the window [j0:j1, i0:i1] of the C-ordered grid ``h``, or 0 if none is
    higher: the crest a patch says (HeightPatch.crest)."""
    top = 0
    for j in range(j0, j1):
        top = max(top, _top_bits(h[j], i0, i1))
    return np.array([top], dtype=np.int64).view(np.float64)[0]

