"""Water models by name: the explicit wave equation and Kass-Miller's implicit shallow water.

Both advance the same state, surface deviation h and vertical velocity v on the grid (see
:mod:`components.water.grid`), with the same spatial operator v_t = (1/s^2) sum_f K_f (h_nb - h),
which conserves volume exactly (each face flux leaves one cell and enters the other) and, without
damping, the lattice energy (:mod:`components.water.diagnostics`). They differ in time:

``wave`` (the proposal's semi-implicit Euler, Müller 2023), explicit::

    v += dt a(h);  v *= max(0, 1 - k_v dt);  h += dt v

Stable for c dt / s <= 1/sqrt(2) (bound reported by :meth:`Model.max_stable_step`); symplectic, so
the energy oscillates but never drifts.

``shallow_water`` (Kass & Miller 1990), implicit, one tridiagonal solve per row then per column::

    A_y A_x h' = h + dt v          (= 2 h(n-1) - h(n-2): v is (h(n-1) - h(n-2)) / dt)
    v' = (h' - h) / dt * max(0, 1 - k_v dt)

A_x = I - dt^2 D_x, D_x the row operator of the face coefficients (the e_i, f_i of physics.md). Each
A has unit row and column sums, so the solve keeps the volume; its eigenvalues are >= 1, so the
scheme is unconditionally stable (and numerically damped at large dt).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from components.water.grid import Grid


def damping_factor(rate: float, dt: float) -> float:
    """Velocity factor of one step for a damping rate [1/s]: max(0, 1 - rate dt) (1 when rate = 0)."""
    return max(0.0, 1.0 - rate * dt)


def thomas_factors(a: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """LU factors of A = I - dt^2 D along the last axis, for every line at once.

    ``a``: (m, n-1) face coefficients a_f = K_f / s^2 [1/s^2] between neighbours along the axis.
    A is tridiagonal with off-diagonals f = -dt^2 a_f and diagonal 1 + dt^2 (a_left + a_right).
    Returns (lower, inv, upper), each (m, n): the Thomas sweeps are then
    y_0 = d_0 inv_0, y_i = (d_i - lower_i y_{i-1}) inv_i, and x_i = y_i - upper_i x_{i+1}.
    """
    m, n1 = a.shape
    n = n1 + 1
    f = -(dt * dt) * a
    diag = np.ones((m, n))
    diag[:, :-1] -= f
    diag[:, 1:] -= f
    lower = np.zeros((m, n))
    lower[:, 1:] = f
    upper_raw = np.zeros((m, n))
    upper_raw[:, :-1] = f
    inv = np.empty((m, n))
    upper = np.empty((m, n))
    inv[:, 0] = 1.0 / diag[:, 0]
    upper[:, 0] = upper_raw[:, 0] * inv[:, 0]
    for i in range(1, n):
        inv[:, i] = 1.0 / (diag[:, i] - lower[:, i] * upper[:, i - 1])
        upper[:, i] = upper_raw[:, i] * inv[:, i]
    return lower, inv, upper


class Model:
    """A time integrator of the height field. Subclasses set ``name`` and ``explicit``."""

    name: ClassVar[str] = ""
    explicit: ClassVar[bool] = False

    def __init__(self, grid: Grid, kernels: Any, damping: float = 0.0):
        self.grid = grid
        self.kernels = kernels
        self.damping = damping
        s2 = grid.cell * grid.cell
        self.ax = np.ascontiguousarray(grid.kx / s2)  # (ny, nx-1) [1/s^2]
        self.ay = np.ascontiguousarray(grid.ky / s2)  # (ny-1, nx) [1/s^2]

    def max_stable_step(self) -> float:
        """Largest stable step [s] (inf for an unconditionally stable model)."""
        return math.inf

    def advance(self, h: np.ndarray, v: np.ndarray, h_out: np.ndarray, v_out: np.ndarray, dt: float) -> None:
        """Write the state after a step of ``dt`` [s] into ``h_out``, ``v_out`` (inputs unchanged)."""
        raise NotImplementedError


class WaveModel(Model):
    """The proposal's semi-implicit Euler wave equation (explicit)."""

    name = "wave"
    explicit = True

    def max_stable_step(self) -> float:
        # Gershgorin: the operator's eigenvalues are below max over cells of 2 sum_f a_f, and the
        # leapfrog needs dt^2 lambda <= 4. On a uniform grid (4 faces of c^2/s^2) this is exactly
        # c dt / s <= 1/sqrt(2).
        total = np.zeros(self.grid.shape)
        total[:, 1:] += self.ax
        total[:, :-1] += self.ax
        total[1:, :] += self.ay
        total[:-1, :] += self.ay
        peak = float(total.max())
        if peak <= 0.0:
            return math.inf
        return math.sqrt(2.0 / peak)

    def advance(self, h: np.ndarray, v: np.ndarray, h_out: np.ndarray, v_out: np.ndarray, dt: float) -> None:
        damp = damping_factor(self.damping, dt)
        c2 = self.grid.c2_uniform
        if c2 is not None:
            kdt = dt * c2 / (self.grid.cell * self.grid.cell)
            self.kernels.wave_uniform(h, v, h_out, v_out, kdt, dt, damp)
        else:
            self.kernels.wave_faces(h, v, h_out, v_out, self.ax, self.ay, dt, damp)


class ShallowWaterModel(Model):
    """Kass & Miller's implicit alternating-direction shallow-water scheme."""

    name = "shallow_water"
    explicit = False

    def __init__(self, grid: Grid, kernels: Any, damping: float = 0.0):
        super().__init__(grid, kernels, damping)
        self._factors_dt: float | None = None
        self._factors: tuple[np.ndarray, ...] = ()

    def factors(self, dt: float) -> tuple[np.ndarray, ...]:
        """Thomas factors of A_x (along rows) and A_y (along columns) for this dt (cached per dt)."""
        if self._factors_dt != dt:
            fx = thomas_factors(self.ax, dt)
            fy = tuple(np.ascontiguousarray(f.T) for f in thomas_factors(np.ascontiguousarray(self.ay.T), dt))
            self._factors = (*fx, *fy)
            self._factors_dt = dt
        return self._factors

    def advance(self, h: np.ndarray, v: np.ndarray, h_out: np.ndarray, v_out: np.ndarray, dt: float) -> None:
        lx, ix, ux, ly, iy, uy = self.factors(dt)
        self.kernels.adi_x(h, v, dt, h_out, lx, ix, ux)
        self.kernels.adi_y(h, dt, damping_factor(self.damping, dt), h_out, v_out, ly, iy, uy)


MODELS: dict[str, type[Model]] = {m.name: m for m in (WaveModel, ShallowWaterModel)}
"""Water models by name."""
