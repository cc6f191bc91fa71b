"""DropSource: a scripted body entering the water, publishing the occupied height it would cause.

It stands in for a coupler in scenes about the water alone (``type:
components.water.sources:DropSource``), through the same port and message, so the water sees
exactly what it would see from a real body::

    +------------+ occupied -> occupied +--------------+
    | DropSource | -------------------> | WaterSurface |
    +------------+                      +--------------+

The occupied height is a smooth cap over a disk, b(r) = height * (1 + cos(pi r / radius)) / 2 for
r < radius, scaled in time by a smoothstep from 0 (at ``start``) to 1 (at ``start + rise``); with
``hold`` set, the body leaves again over another ``rise`` after holding for ``hold`` seconds. The
grid settings (cell, origin, nx, ny) must be those of the water it feeds, which refuses others.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from components.messages import OccupiedHeight
from components.water.grid import CELL_MAX, CELL_MIN
from cosim.component import Component, Port
from cosim.messages import Message
from cosim.params import param, require_valid


@dataclass(frozen=True)
class DropParams:
    """Parameters of :class:`DropSource` (SI units)."""

    x: float = param(0.0, unit="m", doc="centre x of the displacement")
    y: float = param(0.0, unit="m", doc="centre y")
    radius: float = param(0.03, unit="m", ge=CELL_MIN, le=1000,  # 1e308 overflowed its window's cell count
                          doc="radius of the occupied disk (1 um to 1 km)")
    height: float = param(0.01, unit="m", ge=0, le=1000,  # 1e308 overflowed the water to inf mid-run
                          doc="peak occupied height at the centre")
    start: float = param(0.0, unit="s", ge=0, doc="time the body starts entering")
    rise: float = param(0.02, unit="s", gt=0, doc="time to enter fully (and to leave)")
    hold: float | None = param(None, unit="s", ge=0, doc="time spent fully in before leaving; none: stays")
    cell: float = param(0.01, unit="m", ge=CELL_MIN, le=CELL_MAX,
                        doc="cell size of the water grid (as WaterSurface's)")
    origin_x: float = param(0.0, unit="m", doc="x of the centre of the water's cell (0, 0)")
    origin_y: float = param(0.0, unit="m", doc="y of the centre of the water's cell (0, 0)")
    nx: int = param(128, ge=1, doc="cells of the water grid along x")
    ny: int = param(128, ge=1, doc="cells of the water grid along y")

    def check(self) -> list[tuple[str, str]]:
        """A drop whose disk misses the water grid would displace nothing: refused, with the grid's extent
        and the parameters that set it (a grid moved away by origin_x is refused under x: both are named)."""
        half = 0.5 * self.cell
        x_lo, x_hi = self.origin_x - half, self.origin_x + (self.nx - 0.5) * self.cell
        y_lo, y_hi = self.origin_y - half, self.origin_y + (self.ny - 0.5) * self.cell
        if (self.x + self.radius <= x_lo or self.x - self.radius >= x_hi
                or self.y + self.radius <= y_lo or self.y - self.radius >= y_hi):
            return [("x", f"the drop at ({self.x:g}, {self.y:g}) m, radius {self.radius:g} m, misses the water "
                          f"grid, x {x_lo:g} to {x_hi:g} m and y {y_lo:g} to {y_hi:g} m (as its origin_x, origin_y, "
                          "cell, nx and ny place it)")]
        return []


def _smoothstep(u: float) -> float:
    u = min(max(u, 0.0), 1.0)
    return u * u * (3.0 - 2.0 * u)


class DropSource(Component):
    """A scripted displacement: a body entering the water at a point (and optionally leaving)."""

    Params = DropParams
    outputs = {"occupied": Port(OccupiedHeight, doc="occupied height b over the disk's window")}

    def setup(self) -> None:
        p = self.params
        require_valid(p)
        i0 = max(math.floor((p.x - p.radius - p.origin_x) / p.cell), 0)
        i1 = min(math.ceil((p.x + p.radius - p.origin_x) / p.cell) + 1, p.nx)
        j0 = max(math.floor((p.y - p.radius - p.origin_y) / p.cell), 0)
        j1 = min(math.ceil((p.y + p.radius - p.origin_y) / p.cell) + 1, p.ny)
        i0, j0 = min(i0, i1), min(j0, j1)
        x = p.origin_x + p.cell * np.arange(i0, i1)
        y = p.origin_y + p.cell * np.arange(j0, j1)
        r = np.hypot(x[None, :] - p.x, y[:, None] - p.y)
        self._i0, self._j0 = i0, j0
        self._shape = np.where(r < p.radius, 0.5 * p.height * (1.0 + np.cos(np.pi * r / p.radius)), 0.0)

    def level(self, t: float) -> float:
        """Fraction of the full displacement at time t [s] (0..1)."""
        p = self.params
        up = _smoothstep((t - p.start) / p.rise)
        if p.hold is None:
            return up
        return up - _smoothstep((t - p.start - p.rise - p.hold) / p.rise)

    def _message(self, t: float) -> OccupiedHeight:
        return OccupiedHeight(i0=self._i0, j0=self._j0, b=self.level(t) * self._shape)

    def assumed_grid(self) -> dict[str, float]:
        """The water grid its window's indices are of (the water it feeds refuses another at load)."""
        p = self.params
        return {"cell": p.cell, "origin_x": p.origin_x, "origin_y": p.origin_y, "nx": p.nx, "ny": p.ny}

    def initial_outputs(self) -> dict[str, Message]:
        return {"occupied": self._message(0.0)}

    def _step_impl(self, t: float, dt: float, inputs: dict[str, Message | None]) -> dict[str, Message]:
        return {"occupied": self._message(t + dt)}
