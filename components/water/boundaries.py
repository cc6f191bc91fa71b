"""Boundaries by name: what happens to waves at the edge of the grid.

``reflecting`` (the proposal's rule): a neighbour outside the grid takes the cell's own height, so
no water crosses the edge, the volume is conserved and waves come back. This is built into the
spatial operator (edge faces are absent); the boundary adds nothing after the step.

``absorbing`` (an open lake): the outermost cells follow the one-way wave equation
h_t + c dh/dn = 0 (Engquist-Majda, discretised as Mur's first-order condition, i.e. the box scheme):

    h0' = h1 + (c dt - s) / (c dt + s) (h1' - h0)          v0' = (h0' - h0) / dt

with h0 the edge cell, h1 its inner neighbour, ' the new step. It lets a wave leave at its own speed
(exact for normal incidence in the continuum limit: on the grid a wave 10 cells long comes back with
about 2% of its amplitude, 20 cells 0.5%, 40 cells 0.13%; an oblique wave at angle theta keeps a
fraction ((1 - cos theta) / (1 + cos theta))^2 of its energy). The box scheme is stable for any c dt;
with the explicit model it adds no step limit beyond c dt / s <= 1/sqrt(2); with the airy model, whose
short modes turn nearly half a turn a step at long steps and are not drained by its exact rotation, the
rewrite feeds them unless c dt / s >= 1.5 (w dt / pi)^2 tan(w dt / 2) (w the checkerboard's frequency),
and the step must stay under 0.9 pi / w_max besides
(:meth:`components.water.models.AiryModel.max_stable_step`). Cells on dry faces stay closed.

Optionally, ``sponge_cells`` > 0 adds a layer relaxing h and v towards rest at a rate rising
quadratically to sigma_max at the edge, applied implicitly (h, v *= 1 / (1 + sigma dt), a factor in
(0, 1] for any dt, so it cannot destabilise the explicit model, where 1 - sigma dt would flip sign
once sigma dt > 1). The one-way condition alone reflects least for the explicit model (the sponge's
gradient reflects long waves); the sponge helps the implicit model at c dt / s > 1, whose numerical
dispersion the one-way condition does not match.

Water leaves (or enters) through an absorbing edge, so the volume is not conserved.
"""

from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from components.water.grid import Grid

SPONGE_STRENGTH = 1.0  # sigma_max = SPONGE_STRENGTH * c_max / (layer width [m]) [1/s]


class Boundary:
    """Edge treatment applied after each model step. Subclasses set ``name``."""

    name: ClassVar[str] = ""
    conserves_volume: ClassVar[bool] = True

    def __init__(self, grid: Grid, kernels: Any, sponge_cells: int = 0):
        self.grid = grid
        self.kernels = kernels
        # how many cells from each edge after_step may rewrite (0: none, and a tiled step then
        # does not call it); a tiled step reads those tiles again (components.water.tiles)
        self.rewritten_band = 0

    def after_step(self, h_old: np.ndarray, h: np.ndarray, v: np.ndarray, dt: float,
                   moving: tuple[np.ndarray, int] | None = None) -> None:
        """Modify the new state (h, v) in place; ``h_old`` is the state before the step. ``moving``,
        from a step by tiles (:meth:`components.water.tiles.Tiles.moving`): the tiles that may hold
        moving water, (nty, ntx) bool, and their side [cells]; every other tile, and every tile
        around it, is at rest (zeros) before and after the step."""


class Reflecting(Boundary):
    """Closed basin: the neighbour outside the grid takes the cell's own height."""

    name = "reflecting"


def sponge_profile(n: int, width: int, sigma_max: float) -> np.ndarray:
    """Damping rate [1/s] of each of n cells along one axis: sigma_max * xi^2 in the layers, 0 inside.

    xi in (0, 1) is how far the cell centre lies into the layer: (width - k - 1/2) / width for the
    k-th cell from either edge.
    """
    sigma = np.zeros(n)
    if width <= 0:
        return sigma
    k = np.arange(width)
    ramp = sigma_max * ((width - k - 0.5) / width) ** 2
    sigma[:width] = np.maximum(sigma[:width], ramp)
    sigma[n - width:] = np.maximum(sigma[n - width:], ramp[::-1])
    return sigma


class Absorbing(Boundary):
    """Open water: a one-way (Mur) condition on the edge cells, plus an optional sponge layer."""

    name = "absorbing"
    conserves_volume = False

    def __init__(self, grid: Grid, kernels: Any, sponge_cells: int = 0):
        super().__init__(grid, kernels, sponge_cells)
        # wave speed on the face between each edge cell and its inner neighbour (0: closed)
        self._speeds = (np.sqrt(grid.kx[:, 0]), np.sqrt(grid.kx[:, -1]),
                        np.sqrt(grid.ky[0, :]), np.sqrt(grid.ky[-1, :]))
        self._open = tuple(np.ascontiguousarray(c > 0) for c in self._speeds)
        self._coef_dt: float | None = None
        self._coefs: tuple[np.ndarray, ...] = ()
        self.width = sponge_cells
        self.rewritten_band = max(1, sponge_cells)
        self.sigma_max = SPONGE_STRENGTH * grid.c_max / (sponge_cells * grid.cell) if sponge_cells else 0.0
        self.sx = sponge_profile(grid.nx, sponge_cells, self.sigma_max)
        self.sy = sponge_profile(grid.ny, sponge_cells, self.sigma_max)

    def coefficients(self, dt: float) -> tuple[np.ndarray, ...]:
        """(c dt - s) / (c dt + s) on the left, right, bottom and top edges (cached per dt)."""
        if self._coef_dt != dt:
            s = self.grid.cell
            self._coefs = tuple((c * dt - s) / (c * dt + s) for c in self._speeds)
            self._coef_dt = dt
        return self._coefs

    def after_step(self, h_old: np.ndarray, h: np.ndarray, v: np.ndarray, dt: float,
                   moving: tuple[np.ndarray, int] | None = None) -> None:
        if moving is not None:
            # water at rest stays at rest under both: only the edges of tiles that may move are visited
            self.kernels.one_way_moving(h_old, h, v, *self.coefficients(dt), *self._open, dt, *moving)
            if self.width:
                self.kernels.sponge_moving(h, v, self.sx, self.sy, self.width, dt, *moving)
            return
        self.kernels.one_way(h_old, h, v, *self.coefficients(dt), *self._open, dt)
        if self.width:
            self.kernels.sponge(h, v, self.sx, self.sy, self.width, dt)


BOUNDARIES: dict[str, type[Boundary]] = {b.name: b for b in (Reflecting, Absorbing)}
"""Boundaries by name."""

