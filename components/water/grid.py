"""Grid geometry of the height field: cell centres, bed, rest depth, wet cells and face coefficients.

Cell (i, j) is centred at world (origin_x + i*cell, origin_y + j*cell); arrays are indexed [j, i],
shape (ny, nx). The dynamic state stores the surface *deviation* eta = z - surface0 (surface0 is the
undisturbed surface), so a rest level far from zero costs no precision in the Laplacian.

Cells whose bed is at or above the rest level are dry land: they keep no water and act as walls
(every face touching them carries no flux).

Both models advance v_t = (1/s^2) sum over faces K_f (h_nb - h): ``kx[j, i]`` is K of the face
between (j, i) and (j, i+1), ``ky[j, i]`` of the face between (j, i) and (j+1, i) [m^2/s^2].
K = c^2 when the wave speed is given, else g (d_a + d_b) / 2 from the rest depths on both sides
(the Kass-Miller coefficients). Faces at the grid edge are absent: that is the reflecting rule
("a neighbour outside the grid takes the cell's own height").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

GRAVITY = 9.81  # [m/s^2], as in physics.md
WATER_DENSITY = 1000.0  # [kg/m^3], rho_w of physics.md
# a column's side [m]: the model's arithmetic (areas s^2, volumes, the stable step s / c) stays exact
# to round-off over this range, which holds every water a stone meets, from sub-millimetre studies to
# lakes (a cell of 1e-300 m has a square of 0, one of 1e160 m an infinite one)
CELL_MIN, CELL_MAX = 1e-6, 1e4
DEPTH_MAX = 1e5  # [m] a rest depth of at most 100 km (the deepest ocean is 11 km): g d stays a float
INDEX_LIMIT = 2.0**62  # a cell index beyond any grid, as a float: farther requests are clipped to it
LEVEL_MAX = 1e6  # [m] |z| of a rest level: 1000 km, beyond any water; heights there still resolve 1e-10 m
WAVE_SPEED_MAX = 1e4  # [m/s] a fixed wave speed of at most 10 km/s (sqrt(g d) at DEPTH_MAX is 1 km/s)
WAVE_SPEED_MIN = 1e-6  # [m/s] and of at least a micrometre a second (three hours to cross a 1 cm column):
# at 1e-300 m/s its square was 0, the water stood still and the summary said its waves ran
SURFACE_TENSION = 0.072  # [N/m] water-air, gamma of physics.md
WAVE_LENGTH_MAX = 1e6  # [m] a wave of at most 1000 km sets the speed (longer ones all run at sqrt(g d))


def wave_speed_of(length: float, depth: float) -> float:
    """Phase speed [m/s] of a linear water wave ``length`` [m] long on water ``depth`` [m] deep,
    gravity and capillarity together: c^2 = (g / k + gamma k / rho_w) tanh(k d), k = 2 pi / length.

    Long waves (k d << 1) run at sqrt(g d); deep-water ripples at sqrt(g / k + gamma k / rho_w),
    0.40 m/s for 10 cm and the slowest, 0.23 m/s, at 1.7 cm.
    """
    k = 2.0 * np.pi / length
    return float(np.sqrt((GRAVITY / k + SURFACE_TENSION * k / WATER_DENSITY) * np.tanh(k * depth)))


@dataclass(frozen=True, eq=False)
class Grid:
    """Static geometry and coefficients of one water grid (built once, never mutated).

    bed, surface0, depth0: (ny, nx) bed elevation z, undisturbed surface z = max(rest_level, bed),
    rest depth max(rest_level - bed, 0) [m]; wet: (ny, nx) bool; kx: (ny, nx-1), ky: (ny-1, nx)
    face coefficients [m^2/s^2]; c2_uniform: the common K of every face when the grid is uniform
    (all wet, one wave speed), else None; column_mass: rho_w * depth * cell^2 [kg], the mass that
    turns the lattice energy into joules.
    """

    nx: int
    ny: int
    cell: float
    origin_x: float
    origin_y: float
    rest_level: float
    depth: float
    bed: np.ndarray
    surface0: np.ndarray
    depth0: np.ndarray
    wet: np.ndarray
    kx: np.ndarray
    ky: np.ndarray
    c2_uniform: float | None
    column_mass: float

    @property
    def shape(self) -> tuple[int, int]:
        return (self.ny, self.nx)

    @property
    def compact(self) -> bool:
        """The bed is flat and all wet: every per-cell array is one value seen at every cell (a
        read-only broadcast view, no memory per cell), as a lake of 10^7 columns needs."""
        return is_broadcast(self.bed)

    @property
    def c_max(self) -> float:
        """Largest wave speed on the grid [m/s] (0 when every cell is dry)."""
        k = max(float(self.kx.max(initial=0.0)), float(self.ky.max(initial=0.0)))
        return math.sqrt(k)

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """World x and y of every cell centre, each (ny, nx) [m]."""
        x = self.origin_x + self.cell * np.arange(self.nx)
        y = self.origin_y + self.cell * np.arange(self.ny)
        return np.meshgrid(x, y)

    def cell_at(self, x: float, y: float) -> tuple[int, int] | None:
        """(i, j) of the cell whose square holds the point (x, y) [m], or None off the grid."""
        i, j = _cell_index(x, self.origin_x, self.cell), _cell_index(y, self.origin_y, self.cell)
        return (i, j) if 0 <= i < self.nx and 0 <= j < self.ny else None

    def window(self, x_min: float, x_max: float, y_min: float, y_max: float,
               margin: int = 0) -> tuple[int, int, int, int] | None:
        """Index window (i0, i1, j0, j1), half-open, of the cells overlapping a world rectangle.

        A cell is included when its square [x - s/2, x + s/2] x [y - s/2, y + s/2] touches the
        rectangle; ``margin`` more cells are added on every side; the result is clipped to the grid.
        None when the rectangle is empty (x_min > x_max or y_min > y_max) or misses the grid.
        """
        if not all(math.isfinite(q) for q in (x_min, x_max, y_min, y_max)):
            raise ValueError(f"patch request must be finite (got x [{x_min}, {x_max}], y [{y_min}, {y_max}])")
        if x_min > x_max or y_min > y_max:
            return None
        s = self.cell
        i0 = _cell_index(x_min, self.origin_x, s) - margin
        i1 = _cell_index(x_max, self.origin_x, s) + margin + 1
        j0 = _cell_index(y_min, self.origin_y, s) - margin
        j1 = _cell_index(y_max, self.origin_y, s) + margin + 1
        i0, i1 = max(i0, 0), min(i1, self.nx)
        j0, j1 = max(j0, 0), min(j1, self.ny)
        if i0 >= i1 or j0 >= j1:
            return None
        return i0, i1, j0, j1


def _cell_index(q: float, origin: float, cell: float) -> int:
    """Index of the cell whose square holds coordinate ``q`` [m] (``origin``: the centre of cell 0),
    clipped to +-INDEX_LIMIT: a coordinate 1e308 m from the grid overflows to infinity."""
    return math.floor(min(max((q - origin) / cell + 0.5, -INDEX_LIMIT), INDEX_LIMIT))


def is_broadcast(a: np.ndarray) -> bool:
    """Whether ``a`` is one value seen at every index (a stride-0 view of more than one element)."""
    return a.size > 1 and all(stride == 0 for stride in a.strides)


def uniform_view(a: np.ndarray, shape: tuple[int, ...]) -> np.ndarray:
    """The first value of ``a`` seen at every index of ``shape`` (read-only, no memory per element)."""
    return np.broadcast_to(np.array(a.flat[0], dtype=a.dtype), shape)


def holds_one_value(nx: int, ny: int, bottom_slope: tuple[float, float]) -> bool:
    """Whether :func:`build_grid` holds each per-cell array as one value (a flat bed, larger than 2 x 2)."""
    return tuple(bottom_slope) == (0.0, 0.0) and (nx > 2 or ny > 2)


def build_grid(nx: int, ny: int, cell: float, depth: float, *, origin_x: float = 0.0,
               origin_y: float = 0.0, rest_level: float = 0.0,
               bottom_slope: tuple[float, float] = (0.0, 0.0),
               wave_speed: float | None = None) -> Grid:
    """The grid of a pond ``depth`` deep at its centre, its bed tilted by ``bottom_slope`` (dz/dx, dz/dy).

    ``wave_speed`` [m/s] fixes K = c^2 on every wet face; None gives the physical shallow-water
    speed sqrt(g d) from the local rest depth.

    A flat bed (every cell the same, all wet) is held as one value per array, seen at every cell:
    the values are those a dense grid would hold, computed by the same formulas on a 2 x 2 grid.
    """
    if holds_one_value(nx, ny, bottom_slope) and depth > 0.0:
        small = build_grid(2, 2, cell, depth, origin_x=origin_x, origin_y=origin_y, rest_level=rest_level,
                           wave_speed=wave_speed)
        return Grid(nx=nx, ny=ny, cell=cell, origin_x=origin_x, origin_y=origin_y, rest_level=rest_level,
                    depth=depth, bed=uniform_view(small.bed, (ny, nx)),
                    surface0=uniform_view(small.surface0, (ny, nx)), depth0=uniform_view(small.depth0, (ny, nx)),
                    wet=uniform_view(small.wet, (ny, nx)), kx=uniform_view(small.kx, (ny, nx - 1)),
                    ky=uniform_view(small.ky, (ny - 1, nx)), c2_uniform=small.c2_uniform,
                    column_mass=small.column_mass)
    x = origin_x + cell * np.arange(nx)
    y = origin_y + cell * np.arange(ny)
    xc = origin_x + cell * (nx - 1) / 2
    yc = origin_y + cell * (ny - 1) / 2
    sx, sy = bottom_slope
    bed = (rest_level - depth) + sx * (x[None, :] - xc) + sy * (y[:, None] - yc)
    bed = np.ascontiguousarray(np.broadcast_to(bed, (ny, nx)), dtype=np.float64)
    wet = bed < rest_level
    depth0 = np.where(wet, rest_level - bed, 0.0)
    surface0 = np.where(wet, rest_level, bed)
    wet_x = wet[:, :-1] & wet[:, 1:]
    wet_y = wet[:-1, :] & wet[1:, :]
    if wave_speed is not None:
        kx = np.where(wet_x, wave_speed**2, 0.0)
        ky = np.where(wet_y, wave_speed**2, 0.0)
    else:
        kx = np.where(wet_x, GRAVITY * 0.5 * (depth0[:, :-1] + depth0[:, 1:]), 0.0)
        ky = np.where(wet_y, GRAVITY * 0.5 * (depth0[:-1, :] + depth0[1:, :]), 0.0)
    c2_uniform = None
    if wet.all() and ((sx == 0.0 and sy == 0.0) or wave_speed is not None):
        c2_uniform = wave_speed**2 if wave_speed is not None else GRAVITY * depth
    for a in (depth0, surface0, kx, ky):
        a.setflags(write=False)
    bed.setflags(write=False)
    wet.setflags(write=False)
    return Grid(nx=nx, ny=ny, cell=cell, origin_x=origin_x, origin_y=origin_y, rest_level=rest_level,
                depth=depth, bed=bed, surface0=surface0, depth0=depth0, wet=wet,
                kx=np.ascontiguousarray(kx), ky=np.ascontiguousarray(ky), c2_uniform=c2_uniform,
                column_mass=WATER_DENSITY * depth * cell**2)
