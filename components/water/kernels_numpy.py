"""Pure-numpy reference kernels of the water step.

Every function here has a compiled twin of the same name and signature in
:mod:`components.water.kernels_numba`; tests run both on the same data. The arithmetic is written
in the same order in both (west, east, south, north neighbours; the same products), so the two agree
to round-off, usually bit for bit. Arrays are float64, C-contiguous, indexed [j, i]; the ``*_out``
arguments are written, never read, and must not alias the inputs unless stated.
"""

from __future__ import annotations

import numpy as np

NAME = "numpy"


def wave_uniform(h: np.ndarray, v: np.ndarray, h_out: np.ndarray, v_out: np.ndarray,
                 kdt: float, dt: float, damp: float) -> None:
    """One semi-implicit Euler step of the wave equation with one coefficient, reflecting edges.

    v' = (v + kdt * lap(h)) * damp, h' = h + dt * v' with kdt = dt c^2 / s^2 and lap the 5-point
    sum of neighbours minus 4 h, a neighbour outside the grid taking the cell's own height.
    """
    p = np.pad(h, 1, mode="edge")
    lap = p[1:-1, :-2] + p[1:-1, 2:] + p[:-2, 1:-1] + p[2:, 1:-1] - 4.0 * h
    np.multiply(v + kdt * lap, damp, out=v_out)
    np.add(h, dt * v_out, out=h_out)


def _flux_sum(h: np.ndarray, ax: np.ndarray, ay: np.ndarray) -> np.ndarray:
    """sum over faces of a_f (h_nb - h), in the order west, east, south, north."""
    acc = np.zeros_like(h)
    acc[:, 1:] += ax * (h[:, :-1] - h[:, 1:])
    acc[:, :-1] += ax * (h[:, 1:] - h[:, :-1])
    acc[1:, :] += ay * (h[:-1, :] - h[1:, :])
    acc[:-1, :] += ay * (h[1:, :] - h[:-1, :])
    return acc


def wave_faces(h: np.ndarray, v: np.ndarray, h_out: np.ndarray, v_out: np.ndarray,
               ax: np.ndarray, ay: np.ndarray, dt: float, damp: float) -> None:
    """One semi-implicit Euler step with per-face coefficients ax (ny, nx-1), ay (ny-1, nx) [1/s^2].

    v' = (v + dt * sum_f a_f (h_nb - h)) * damp, h' = h + dt * v'.
    """
    acc = _flux_sum(h, ax, ay)
    np.multiply(v + dt * acc, damp, out=v_out)
    np.add(h, dt * v_out, out=h_out)


def adi_x(h: np.ndarray, v: np.ndarray, dt: float, out: np.ndarray,
          lower: np.ndarray, inv: np.ndarray, upper: np.ndarray) -> None:
    """Solve A_x out = h + dt v along every row (Thomas, with the factors of
    :func:`components.water.models.thomas_factors`, (ny, nx) or one row (1, nx) shared by all)."""
    nx = h.shape[1]
    rhs = h + dt * v
    out[:, 0] = rhs[:, 0] * inv[:, 0]
    for i in range(1, nx):
        out[:, i] = (rhs[:, i] - lower[:, i] * out[:, i - 1]) * inv[:, i]
    for i in range(nx - 2, -1, -1):
        out[:, i] -= upper[:, i] * out[:, i + 1]


def adi_y(h: np.ndarray, dt: float, damp: float, out: np.ndarray, v_out: np.ndarray,
          lower: np.ndarray, inv: np.ndarray, upper: np.ndarray) -> None:
    """Solve A_y x = out along every column, in place in ``out``; then v_out = (x - h) / dt * damp.

    Factors (ny, nx), or one column (ny, 1) shared by all columns.
    """
    ny = h.shape[0]
    out[0] *= inv[0]
    for j in range(1, ny):
        out[j] = (out[j] - lower[j] * out[j - 1]) * inv[j]
    for j in range(ny - 2, -1, -1):
        out[j] -= upper[j] * out[j + 1]
    np.multiply((out - h) / dt, damp, out=v_out)


def smooth(h: np.ndarray, h_out: np.ndarray, wx: np.ndarray, wy: np.ndarray, f: float) -> None:
    """Positional smoothing h' = h + f (mean of the 4 neighbours - h); wx, wy: 1 on open faces, 0 on walls."""
    acc = _flux_sum(h, wx, wy)
    np.add(h, (0.25 * f) * acc, out=h_out)


def smooth_open(h: np.ndarray, h_out: np.ndarray, f: float) -> None:
    """:func:`smooth` with every face open (wx, wy all 1): the grid of a pond without dry land."""
    acc = np.zeros_like(h)
    acc[:, 1:] += h[:, :-1] - h[:, 1:]
    acc[:, :-1] += h[:, 1:] - h[:, :-1]
    acc[1:, :] += h[:-1, :] - h[1:, :]
    acc[:-1, :] += h[1:, :] - h[:-1, :]
    np.add(h, (0.25 * f) * acc, out=h_out)


def blur(d: np.ndarray, work: np.ndarray, passes: int, weight: float,
         open_x: np.ndarray | None = None, open_y: np.ndarray | None = None) -> None:
    """``passes`` conservative 5-point blur passes of d (nj, ni), in place; closed edges, so the sum
    is kept to round-off. One pass: d' = d + weight * sum over the cell's faces of (d_nb - d).

    ``work``: scratch of d's shape (the compiled twin's ping-pong buffer; unused here). ``open_x``
    (nj, ni - 1), ``open_y`` (nj - 1, ni): which faces pass anything (bool; None: every one), so
    that nothing crosses a face onto dry land.
    """
    for _ in range(passes):
        acc = np.zeros_like(d)
        dx = d[:, 1:] - d[:, :-1]
        dy = d[1:, :] - d[:-1, :]
        if open_x is not None:
            dx *= open_x
        if open_y is not None:
            dy *= open_y
        acc[:, :-1] += dx
        acc[:, 1:] -= dx
        acc[:-1, :] += dy
        acc[1:, :] -= dy
        d[...] = d + weight * acc


def sponge(h: np.ndarray, v: np.ndarray, sx: np.ndarray, sy: np.ndarray, width: int, dt: float) -> None:
    """Absorbing layer, in place: h and v *= 1 / (1 + (sx[i] + sy[j]) dt) (rates sx (nx,), sy (ny,) [1/s]).

    The rates are zero outside the ``width`` cells along each edge, where the factor is exactly 1.
    """
    q = 1.0 / (1.0 + (sx[None, :] + sy[:, None]) * dt)
    h *= q
    v *= q


def one_way(h_old: np.ndarray, h: np.ndarray, v: np.ndarray, kl: np.ndarray, kr: np.ndarray,
            kb: np.ndarray, kt: np.ndarray, ol: np.ndarray, orr: np.ndarray, ob: np.ndarray,
            ot: np.ndarray, dt: float) -> None:
    """One-way (Mur) condition on the edge cells, in place: h0' = h1 + k (h1' - h0), v0' = (h0' - h0) / dt.

    k*: (ny,) coefficients of the left and right edges, (nx,) of the bottom and top edges; o*: the
    same shapes, True where the edge is open (elsewhere the cell keeps its reflecting update). The
    edges are done in the order left, right, bottom, top (a corner takes the last).
    """
    h[:, 0] = np.where(ol, h_old[:, 1] + kl * (h[:, 1] - h_old[:, 0]), h[:, 0])
    h[:, -1] = np.where(orr, h_old[:, -2] + kr * (h[:, -2] - h_old[:, -1]), h[:, -1])
    h[0, :] = np.where(ob, h_old[1, :] + kb * (h[1, :] - h_old[0, :]), h[0, :])
    h[-1, :] = np.where(ot, h_old[-2, :] + kt * (h[-2, :] - h_old[-1, :]), h[-1, :])
    v[:, 0] = np.where(ol, (h[:, 0] - h_old[:, 0]) / dt, v[:, 0])
    v[:, -1] = np.where(orr, (h[:, -1] - h_old[:, -1]) / dt, v[:, -1])
    v[0, :] = np.where(ob, (h[0, :] - h_old[0, :]) / dt, v[0, :])
    v[-1, :] = np.where(ot, (h[-1, :] - h_old[-1, :]) / dt, v[-1, :])
