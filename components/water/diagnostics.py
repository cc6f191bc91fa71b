"""Volume and energy of the height field (for the viewer's WaterField, the run summary and tests).

Water volume: V = s^2 sum_ij (d0_ij + h_ij - b_ij) [m^3], the rest depth plus the surface deviation
minus the height occupied by bodies (a body pushing into the water raises h by the occupied height,
so V does not change).

Lattice energy: the columns are masses m = rho_w * depth * s^2 moving vertically at v, coupled by
the face springs of the spatial operator::

    E = m [ 1/2 sum_ij v_ij^2 + 1/2 sum_faces a_f (h_a - h_b)^2 ]      a_f = K_f / s^2 [1/s^2]

It is the wave model's own invariant, not the physical energy of the waves: a column of the
height field carries the mass of its whole depth moving vertically, so for a wave of wavenumber k it
exceeds the physical wave energy by about (k d)^2 (some 4000 times for 5 cm waves on 0.5 m of
water). :func:`surface_energy` gives the physical potential energy of the surface, 1/2 rho_w g
sum eta^2 s^2, for energy books that compare the water with a body.

This is the quantity the undamped semi-discrete model conserves exactly (v_t = -S h with S the
symmetric operator of the faces); it is zero at rest. The explicit `wave` step conserves instead the
shadow energy E + m dt/2 sum_ij v_ij a_ij (a the acceleration of h), to round-off, so E itself
oscillates about it but never drifts: a wave of frequency omega holds between 1 / (1 + omega dt / 2)
and 1 / (1 - omega dt / 2) times its share of the shadow energy, omega dt / 2 being at most
sqrt(2) c dt / s, for the grid's shortest waves. So E stays within a few percent for waves many
columns long (3% for a smooth bump at c dt / s = 0.42), but grid-scale noise near the stable step
swings it by several times (2.4 to 4.5 times its start, from random noise at c dt / s = 0.67).
"""

from __future__ import annotations

import numpy as np

from components.water.grid import GRAVITY, WATER_DENSITY, Grid


def volume(grid: Grid, h: np.ndarray, b: np.ndarray | None = None) -> float:
    """Water volume above the bed [m^3] (bodies' occupied height b excluded)."""
    column = grid.depth0 + h
    if b is not None:
        column = column - b
    return float(np.sum(column) * grid.cell**2)


def acceleration(grid: Grid, h: np.ndarray) -> np.ndarray:
    """a = (1/s^2) sum_f K_f (h_nb - h) [m/s^2], (ny, nx)."""
    s2 = grid.cell**2
    ax, ay = grid.kx / s2, grid.ky / s2
    acc = np.zeros_like(h)
    dx = h[:, 1:] - h[:, :-1]
    dy = h[1:, :] - h[:-1, :]
    acc[:, :-1] += ax * dx
    acc[:, 1:] -= ax * dx
    acc[:-1, :] += ay * dy
    acc[1:, :] -= ay * dy
    return acc


def energy(grid: Grid, h: np.ndarray, v: np.ndarray) -> float:
    """Lattice energy [J] (see the module docstring)."""
    s2 = grid.cell**2
    kinetic = 0.5 * float(np.sum(v * v))
    dx = h[:, 1:] - h[:, :-1]
    dy = h[1:, :] - h[:-1, :]
    potential = 0.5 * (float(np.sum(grid.kx * dx * dx)) + float(np.sum(grid.ky * dy * dy))) / s2
    return grid.column_mass * (kinetic + potential)


def surface_energy(grid: Grid, h: np.ndarray) -> float:
    """Physical potential energy of the surface deviation, 1/2 rho_w g sum eta^2 s^2 [J] (about half
    the waves' energy: kinetic and potential are equal on average in a travelling wave)."""
    return 0.5 * WATER_DENSITY * GRAVITY * float(np.sum(h * h)) * grid.cell**2


def shadow_energy(grid: Grid, h: np.ndarray, v: np.ndarray, dt: float) -> float:
    """The invariant of the undamped explicit `wave` step of size dt [J]: E + m dt/2 sum v a."""
    return energy(grid, h, v) + grid.column_mass * 0.5 * dt * float(np.sum(v * acceleration(grid, h)))
