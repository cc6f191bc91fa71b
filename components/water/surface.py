"""The WaterSurface component: a height field of water columns on an nx x ny grid.

Ports::

    occupied (OccupiedHeight) --> +--------------+ --> patch (HeightPatch), every step
    request  (PatchRequest)   --> | WaterSurface | --> field (WaterField), at field_rate
                                  +--------------+

One step, from t to t + dt:

1. displacement: h += b - b_prev over the union of the previous and the new occupied windows (the
   change optionally spread by ``displacement_smoothing`` conservative blur passes), then b_prev = b;
   an input that did not change adds exactly nothing, so a water component stepping slower than its
   source still sees the right total change;
2. the model step (``wave`` or ``shallow_water``, see :mod:`components.water.models`);
3. the boundary (``reflecting`` or ``absorbing``, see :mod:`components.water.boundaries`);
4. optional positional smoothing (Müller): h += (mean of 4 neighbours - h) min(1/2, k_p dt);
5. outputs: the patch over the requested window plus ``patch_margin`` cells, with the occupied
   height applied in step 1 over it (so the body that sent it knows what the water already holds;
   empty when nothing is requested: then no column work is done), and the field when a frame is
   due: the whole surface, or with ``field_window`` a window of that size that follows the water the
   bodies last asked for (a lake's viewer shows the stone, not a decimated lake).

A lake: the ``wave`` model on a flat bed is stepped by tiles of ``tile`` x ``tile`` columns
(:mod:`components.water.tiles`); water at rest, with its neighbours at rest, is not stepped and (its
pages never written) takes no memory. A stepped tile moving by no more than ``rest_below`` (1e-30 m,
far below any wave's round-off) is set to rest, so the explicit step's vanishing precursor ahead of
each wave costs nothing; the result is the dense step's to round-off (bit for bit with
``rest_below: 0``). ``tile: 0``, ``shallow_water``, ``airy``, smoothing, a sloped bed whose waves run at
its depth's speed or that dries, and the numpy or parallel kernels step every column (a sloped bed
under one set ``wave_speed`` or ``wave_length`` is uniform, and tiled). The summary and the field's
``active_fraction`` say how much of the water moved.

Several bodies on one pond: ``bodies: [stone, ball]`` gives each body its own three ports,
``occupied_<name>``, ``request_<name>`` and ``patch_<name>`` (in place of ``occupied``, ``request`` and
``patch``), for its own coupler. The water holds every body's displacement (step 1 for each, in the
order named), so each body meets the waves of the others; each patch covers its own body's request
and echoes that body's own occupied height, which is what its coupler needs to tell its own
displacement from the water's.

A step longer than the explicit model's stable step is refused by the framework
(on_unstable: error) or split into equal substeps (on_unstable: substep); with substeps the inputs
are applied once and the outputs built once, at the end of the whole step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from components import compiled
from components.messages import HeightPatch, OccupiedHeight, PatchRequest, WaterField
from components.water import kernels_numba, kernels_numpy, sparse
from components.water.boundaries import BOUNDARIES
from components.water.diagnostics import surface_energy, volume
from components.water.grid import (
    CELL_MAX,
    CELL_MIN,
    DEPTH_MAX,
    GRAVITY,
    LEVEL_MAX,
    WAVE_LENGTH_MAX,
    WAVE_SPEED_MAX,
    WAVE_SPEED_MIN,
    build_grid,
    holds_one_value,
    wave_speed_of,
)
from components.water.models import MODELS, WaveModel
from components.water.tiles import DEFAULT_TILE, REST_BELOW, Tiles, tiling_applies
from components.water.windows import apply_window, patch_arrays, window_top
from cosim.component import Component, Port
from cosim.errors import counted
from cosim.messages import Message
from cosim.params import param, require_valid
from cosim.timebase import NS_PER_S

KERNELS: dict[str, Any] = {"numba": kernels_numba.SERIAL, "numpy": kernels_numpy}
"""Kernel sets by name: the compiled one and the pure-numpy reference."""

MAX_BUMP = 1000.0  # [m] the highest initial bump taken: far above any pond's, far below where squares overflow
MAX_SLOPE = 1000.0  # [m/m] the steepest bed: a cliff, far below where the bed's heights overflow (1e308 did)
SMOOTHING_MAX = 0.5  # cap of k_p dt per step: keeps the smoothing a contraction on every mode
FIELD_WINDOW_STEP = 32  # [cells] the field window's corner moves in steps of this many cells
DAMPING_STEP = 0.5  # the largest damping rate times step, k_v dt, the water steps with (max_stable_step)
CREST_RESOLUTION = 1000.0  # [1/m] the crest a patch says is rounded up to 1 / this (a millimetre)
SHORE_CHECK_EVERY = 2  # [steps] how often a sloped bed's shallows are looked at for a surface under the bed
SHALLOWS = 0.25  # the shallows: water at rest less deep than this share of the depth at the grid's centre
BLUR_WEIGHT = 0.125  # weight of each neighbour difference in one displacement blur pass (<= 1/8: monotone)


def _choices(registry: dict[str, Any]) -> str:
    return ", ".join(repr(k) for k in registry)


@dataclass(frozen=True)
class GaussianBump:
    """A Gaussian bump of the surface, at rest: h += amplitude * exp(-r^2 / (2 width^2))."""

    x: float = param(unit="m", doc="centre x")
    y: float = param(unit="m", doc="centre y")
    amplitude: float = param(unit="m", doc="peak height above the rest level")
    # (at least a micrometre, as a cell is: at 1e-300 m its square underflowed and the water filled with NaN)
    width: float = param(unit="m", ge=CELL_MIN, doc="standard deviation of the bump (at least 1 um)")


@dataclass(frozen=True)
class WaterParams:
    """Parameters of :class:`WaterSurface` (SI units)."""

    nx: int = param(128, ge=2, doc="cells along x")
    ny: int = param(128, ge=2, doc="cells along y")
    cell: float = param(0.01, unit="m", ge=CELL_MIN, le=CELL_MAX, doc="cell size s (1 um to 10 km)")
    depth: float = param(0.5, unit="m", gt=0, le=DEPTH_MAX, doc="rest depth at the centre of the grid (at most 100 km)")
    origin_x: float = param(0.0, unit="m", ge=-LEVEL_MAX, le=LEVEL_MAX,
                            doc="x of the centre of cell (0, 0) (within 1000 km of x = 0)")
    origin_y: float = param(0.0, unit="m", ge=-LEVEL_MAX, le=LEVEL_MAX,
                            doc="y of the centre of cell (0, 0) (within 1000 km of y = 0)")
    rest_level: float = param(0.0, unit="m", ge=-LEVEL_MAX, le=LEVEL_MAX,
                              doc="z of the undisturbed surface (within 1000 km of z = 0)")
    bottom_slope: tuple[float, float] = param(
        (0.0, 0.0), unit="m/m",
        doc="bed slope (dz/dx, dz/dy), each at most 1000 in size; cells with the bed above rest level are dry")
    model: str = param("wave", doc="wave (explicit), shallow_water (implicit, Kass-Miller) or airy (water's "
                                   "dispersion, each basin mode stepped exactly; a flat bed only; slower)")
    wave_speed: float | None = param(None, unit="m/s", ge=WAVE_SPEED_MIN, le=WAVE_SPEED_MAX,
                                     doc="fixed wave speed c; default sqrt(g d) (1 um/s to 10 km/s)")
    wave_length: float | None = param(
        None, unit="m", gt=0, le=WAVE_LENGTH_MAX,
        doc="or the speed of water waves this long at the rest depth (gravity and capillarity, "
            "grid.wave_speed_of): the one speed given to the waves that matter, a skipping stone's "
            "ripples as long as it is wide instead of the long waves' sqrt(g d); model airy, which runs "
            "every length at its own speed, has no use for it")
    boundary: str = param("reflecting", doc="reflecting (closed basin) or absorbing (open water)")
    sponge_cells: int = param(0, ge=0, doc="absorbing boundary: width of an extra sponge layer [cells]")
    damping: float = param(0.0, unit="1/s", ge=0, doc="velocity damping rate k_v: v *= 1 - k_v dt, the water's step "
                                                      "at most 0.5 / k_v (a stability bound: substeps, or refused)")
    smoothing: float = param(0.0, unit="1/s", ge=0, doc="positional smoothing rate k_p")
    displacement_smoothing: int = param(0, ge=0, le=1000, doc="blur passes spreading each displacement change")
    initial: GaussianBump | None = param(None, doc="initial bump {x, y, amplitude, width}")
    patch_margin: int = param(1, ge=0, doc="cells added around the requested window")
    field_every: int = param(0, ge=0, doc="publish the whole field every N steps (0: never)")
    field_rate: float = param(0.0, unit="Hz", ge=0, le=1e6,
                              doc="or publish it at this frame rate (0: never; at most 1 MHz)")
    field_window: tuple[float, float] | None = param(
        None, unit="m", doc="the published field covers this (x, y) size around the bodies, following the "
                            "last water they asked for, its first frame when one first asks (none: the "
                            "whole surface, its first frame at t = 0)")
    backend: str = param("numba", doc="numba (compiled) or numpy (reference)")
    parallel: bool = param(False, doc="compiled kernels split large grids across threads")
    tile: int = param(DEFAULT_TILE, ge=0, doc="side of the tiles the wave model steps by [cells]: a tile at rest "
                                              "with its neighbours at rest costs nothing (0: every column every "
                                              "step; shallow_water, smoothing, a sloped bed whose waves run at "
                                              "its depth's speed or that dries, and the numpy or parallel "
                                              "kernels always step every column)")
    rest_below: float = param(
        REST_BELOW, unit="m", ge=0, le=1e-6,  # a micrometre; more would put real ripples to rest
        doc="the tiled step sets a stepped tile to rest once every column moves by at most this (|h| [m], "
            "|v| [m/s]): the explicit step's vanishing precursor ahead of each wave then costs nothing; "
            "1e-30 m is far below any wave's round-off (0: only exact zeros rest, and the tiled step is "
            "the dense one bit for bit); the water put to rest leaves the pond, so above the default the "
            "volume is no longer kept (at 1e-6 m, 1.7e-7 of a closed 256 x 256 pond over 4000 steps)")
    bodies: list[str] = param([], doc="bodies sharing this water, each on its own ports occupied_<name>, "
                                      "request_<name>, patch_<name>, the patch going back to the coupler that "
                                      "sends the request (empty: one body on occupied, request, patch)")

    def check(self) -> list[tuple[str, str]]:
        """Rules across fields and registry names, as (field, problem) pairs."""
        problems = []
        for name, registry in (("model", MODELS), ("boundary", BOUNDARIES), ("backend", KERNELS)):
            value = getattr(self, name)
            if value not in registry:
                problems.append((name, f"must be one of {_choices(registry)} (got {value!r})"))
        if self.field_every and self.field_rate:
            problems.append(("field_rate", "give field_every or field_rate, not both (got field_every "
                                           f"{self.field_every}, field_rate {self.field_rate:g})"))
        for k, name in enumerate(self.bodies):
            if not isinstance(name, str) or not name.isidentifier():
                problems.append(("bodies", f"each must be a name of letters, digits and _ (got {name!r} at {k})"))
        if len(set(self.bodies)) != len(self.bodies):
            problems.append(("bodies", f"must not repeat a name (got {list(self.bodies)})"))
        if self.initial is not None and not self.initial.amplitude > -self.depth:
            problems.append(("initial", f"a trough must be shallower than the depth {self.depth:g} m: one reaching "
                                        f"the bed leaves no water (got amplitude {self.initial.amplitude:g} m)"))
        elif self.initial is not None and not self.initial.amplitude <= MAX_BUMP:
            problems.append(("initial", f"a bump must be at most {MAX_BUMP:g} m high, no pond's waves are higher "
                                        f"(got amplitude {self.initial.amplitude:g} m)"))
        if self.field_window is not None and min(self.field_window) <= 0:
            problems.append(("field_window", f"must be two sizes > 0 [m] (got {list(self.field_window)})"))
        if not all(abs(float(c)) <= MAX_SLOPE for c in self.bottom_slope):  # (NaN too)
            problems.append(("bottom_slope", f"each part at most {MAX_SLOPE:g} m/m, a cliff, in size (got "
                                             f"{list(self.bottom_slope)})"))
        elif self.model == "airy" and tuple(self.bottom_slope) != (0.0, 0.0):
            problems.append(("bottom_slope", f"must be [0, 0] with model airy, whose modes are those of a "
                                             f"flat bed (got {list(self.bottom_slope)})"))
        if self.model == "airy" and self.wave_speed is not None:
            problems.append(("wave_speed", f"must be left out with model airy: each wave's speed comes from "
                                           f"its length and the depth (got {self.wave_speed:g} m/s)"))
        if self.wave_length is not None and self.wave_length < 2.0 * self.cell:
            problems.append(("wave_length", f"must be at least two columns, {2.0 * self.cell:g} m: no shorter wave "
                                            f"exists on the grid (got {self.wave_length:g} m)"))
        if self.wave_speed is not None and self.wave_length is not None:
            problems.append(("wave_length", f"give wave_speed or wave_length, not both (got wave_speed "
                                            f"{self.wave_speed:g} m/s, wave_length {self.wave_length:g} m)"))
        if self.boundary == "absorbing" and min(self.nx, self.ny) < 3:
            # each edge's one-way condition reads the column inside it: two columns across, that is the
            # opposite edge, rewritten in the same pass, and the water's energy grew without bound
            # (4.5e119 J in 4 s from a 2 mJ bump, the run "ok")
            side = "nx" if self.nx < 3 else "ny"
            problems.append((side, f"must be at least 3 for an absorbing boundary, whose edges each need a column "
                                   f"inside them (got {getattr(self, side)})"))
        elif self.boundary == "absorbing" and 2 * self.sponge_cells >= min(self.nx, self.ny):
            problems.append(("sponge_cells", f"must be < min(nx, ny) / 2 = {min(self.nx, self.ny) / 2:g} "
                                             f"for an absorbing boundary (got {self.sponge_cells})"))
        elif self.boundary != "absorbing" and self.sponge_cells:
            # the sponge is the absorbing edges' layer: a closed basin has none, and took the value
            # without a word (a run with sponge_cells 40 was the same as with 0)
            problems.append(("sponge_cells", f"must be 0 with boundary {self.boundary}: the sponge is a layer "
                                             f"of absorbing edges (got {self.sponge_cells})"))
        return problems


FOLLOW_HOLD = 0.5  # [s] the field's window leaves the body it follows once that has asked for nothing new this long


class WaterSurface(Component):
    """Height-field water: columns of height and vertical velocity, waves, displacement by bodies."""

    start_only_params = frozenset({"initial"})

    Params = WaterParams
    inputs = {
        "occupied": Port(OccupiedHeight, doc="absolute occupied height b of bodies over a window"),
        "request": Port(PatchRequest, doc="world rectangle whose columns the consumer needs next"),
    }
    outputs = {
        "patch": Port(HeightPatch, doc="columns over the requested window (+ margin), every step"),
        "field": Port(WaterField, doc="the whole surface, at field_rate or every field_every steps (viewers only)"),
    }

    # the ports of each body: (occupied input, request input, patch output); one unnamed body by default
    body_ports: tuple[tuple[str, str, str], ...] = (("occupied", "request", "patch"),)

    @classmethod
    def one_source(cls, port: str) -> str:
        if port in ("occupied", "request"):  # the one unnamed body's ports (named ones are each one body's)
            return ("for several bodies on one water, name them in its bodies: [a, b], each body's coupler "
                    "then on its own ports occupied_a, request_a, patch_a, ... (scenarios/two_stones.yaml)")
        return ""

    @classmethod
    def configure(cls, params: Any, path: str, base_dir: Any, problems: list[str]) -> type[Component] | None:
        """With ``bodies`` named, a class with each body's own occupied, request and patch ports."""
        if params is None:  # a parameter refused: the ports are not known, the edges not checked (each
            return None     # one-body port name was a false "no output port 'patch_left'")
        if not params.bodies:
            return cls
        if any(name for name, _ in params.check() if name == "bodies"):
            return None  # the problem is reported with the parameters
        names = list(params.bodies)
        ports = tuple((f"occupied_{n}", f"request_{n}", f"patch_{n}") for n in names)
        inputs: dict[str, Port] = {}
        outputs: dict[str, Port] = {}
        for n, (occupied, request, patch) in zip(names, ports, strict=True):
            inputs[occupied] = Port(OccupiedHeight, doc=f"absolute occupied height b of body {n} over a window")
            inputs[request] = Port(PatchRequest, doc=f"world rectangle whose columns body {n}'s coupler needs next")
            outputs[patch] = Port(HeightPatch, doc=f"columns over body {n}'s requested window (+ margin), "
                                                   f"with its own occupied height")
        outputs["field"] = cls.outputs["field"]
        return type(cls.__name__, (cls,), {"__module__": cls.__module__, "__doc__": cls.__doc__,
                                           "inputs": inputs, "outputs": outputs, "body_ports": ports})

    # --- construction -----------------------------------------------------------------------

    # float64 arrays of the grid's shape it holds: height, velocity and their spare buffers, the
    # occupied height, the bed, rest depth and surface, two wave-speed coefficients and two masks,
    # plus the model's and the boundary's work arrays
    ARRAYS_PER_CELL = 16
    # on a flat bed the bed, depths, coefficients and masks are one value each (grid.holds_one_value):
    # height, velocity, their spare buffers and the occupied height, a checkpoint's copies of height
    # and velocity, one temporary. Tiled, only the pages of water that has moved are ever touched,
    # so this is the bound for a lake whose every column moves.
    FLAT_ARRAYS_PER_CELL = 8

    @staticmethod
    def wave_speed(params: WaterParams) -> float | None:
        """The one wave speed [m/s] the parameters fix (``wave_speed``, or that of waves
        ``wave_length`` long at the rest depth); None: each face's sqrt(g d), or airy's own speeds."""
        if params.wave_length is not None and params.model != "airy":
            return wave_speed_of(params.wave_length, params.depth)
        return params.wave_speed

    @classmethod
    def estimate_bytes(cls, params: WaterParams) -> int:
        flat = holds_one_value(int(params.nx), int(params.ny), params.bottom_slope)
        arrays = cls.FLAT_ARRAYS_PER_CELL if flat else cls.ARRAYS_PER_CELL
        model = MODELS.get(params.model)
        arrays += model.extra_arrays_per_cell if model is not None else 0  # the model's own
        arrays += len(params.bodies) if len(params.bodies) > 1 else 0  # each body's own occupied height
        return int(params.nx) * int(params.ny) * arrays * 8

    @classmethod
    def memory_advice(cls, params: WaterParams) -> str:
        bodies = len(params.bodies) if len(params.bodies) > 1 else 0
        if bodies and bodies >= cls.estimate_bytes(params) / (int(params.nx) * int(params.ny) * 8) / 2:
            # most of it is the bodies' own occupied heights, a whole grid each
            grid = int(params.nx) * int(params.ny) * 8
            return (f"most of it is the {bodies} bodies' occupied heights, each over the whole grid "
                    f"({grid / 1e6:.3g} MB each): fewer bodies on one pond, or a smaller grid")
        return "use a smaller grid"

    def setup(self) -> None:
        p = self.params
        require_valid(p)
        self.grid = g = build_grid(p.nx, p.ny, p.cell, p.depth, origin_x=p.origin_x, origin_y=p.origin_y,
                                   rest_level=p.rest_level, bottom_slope=p.bottom_slope,
                                   wave_speed=self.wave_speed(p))
        self.kernels = kernels_numba.PARALLEL if p.parallel and p.backend == "numba" else KERNELS[p.backend]
        if p.backend == "numba":
            compiled.start()
        self.boundary = BOUNDARIES[p.boundary](g, self.kernels, p.sponge_cells)
        self.model = MODELS[p.model](g, self.kernels, p.damping, closed=self.boundary.conserves_volume)
        # smoothing weights: 1 on open faces, 0 on walls; bytes, as they are read every step (a
        # weight times a float64 is exact either way). A pond without dry land smooths with every
        # weight 1: the same sums without reading them.
        self._smoothing_weights = None
        if p.smoothing > 0 and not g.wet.all():
            self._smoothing_weights = (np.ascontiguousarray(g.kx > 0, dtype=np.uint8),
                                       np.ascontiguousarray(g.ky > 0, dtype=np.uint8))
        shape = g.shape
        self._h = np.zeros(shape)
        self._v = np.zeros(shape)
        self.tiles = Tiles(shape, p.tile, p.rest_below) if tiling_applies(
            tile=p.tile, model=p.model, uniform=g.c2_uniform is not None, smoothing=p.smoothing,
            backend=p.backend, parallel=p.parallel) else None
        self._rest_sum: float | None = None  # sum of the rest depths [m] (_tile_sums), once asked for
        # a sloped bed's shallows, which the linear models cannot dry (the shoreline stays where it is
        # at rest): where a wave takes the surface under the bed there is watched, and said (_check_shore)
        self._shore = None
        if not holds_one_value(int(p.nx), int(p.ny), p.bottom_slope):
            cells = np.flatnonzero(g.wet & (g.depth0 < SHALLOWS * p.depth))
            if cells.size:
                self._shore = (cells, np.ascontiguousarray(g.depth0.ravel()[cells]))
        self._under_bed: tuple[float, float, float, float] | None = None  # (depth < 0 [m], x, y, t) at its lowest
        self._all_wet = bool(g.wet.all())  # (once: on a flat bed the mask is one value seen everywhere, and
        # .all() over it read the whole grid, 2 ms on the lake, at every displacement blurred)
        # spare buffers: each step writes into them, then they swap. Tiled, a tile left at rest
        # must find zeros there; np.zeros maps its pages lazily, so a lake's far water costs no memory
        self._h2 = np.zeros(shape) if self.tiles is not None else np.empty(shape)
        self._v2 = np.zeros(shape) if self.tiles is not None else np.empty(shape)
        self._h3 = np.empty(shape) if p.smoothing > 0 else self._h2
        if p.initial is not None:
            x, y = g.centres()
            bump = p.initial
            with np.errstate(over="ignore"):  # a bump 1e308 m off: its square is inf, its height exactly 0
                r2 = (x - bump.x) ** 2 + (y - bump.y) ** 2
                self._h += np.where(g.wet, bump.amplitude * np.exp(-r2 / (2.0 * bump.width**2)), 0.0)
        self.model.reset(self._h, self._v)
        if self.tiles is not None:
            self.tiles.reset(self._h, self._v)
        self._b = np.zeros(shape)  # occupied height of the last inputs (all bodies), zero outside their windows
        # each body's own occupied height and window; one body's is the total itself
        shared = len(self.body_ports) > 1
        self._occupants = [_Occupant(np.zeros(shape) if shared else self._b) for _ in self.body_ports]
        self._displaced_before = 0.0  # [m^3] pushed aside by bodies in the water when the run began
        self._steps = 0
        self._next_frame = 1
        self._first_frame_waits = False  # the frame of t = 0 withheld until a body asks (initial_outputs)
        self._follow: tuple[float, float] | None = None  # centre of the last water a body asked for [m]
        self._following = 0  # the body whose water the field's window follows (its index in the bodies)
        self._asked_at = [-math.inf] * len(self.body_ports)  # when each body's request last moved [s]
        # the centre of each body's request when last seen [m]: the one that changes is the one followed
        self._asked: list[tuple[float, float] | None] = [None] * len(self.body_ports)
        # each body's last request and its index window (patch): requests are immutable
        self._windows: dict[int, tuple[PatchRequest, tuple[int, int, int, int] | None]] = {}
        self._empty_patch = HeightPatch(
            i0=0, j0=0, cell=g.cell, origin_x=g.origin_x, origin_y=g.origin_y, rest_level=g.rest_level,
            height=np.zeros((0, 0)), velocity=np.zeros((0, 0)), bottom=np.zeros((0, 0)))
        self._off_grid_patch = replace(self._empty_patch, off_grid=True)
        self._crests: dict[int, HeightPatch] = {}  # each body's last crest-only patch (PatchRequest.columns)
        self.initial_volume = self.volume()

    # --- diagnostics --------------------------------------------------------------------------

    @property
    def height(self) -> np.ndarray:
        """Surface elevation z of every cell, (ny, nx) [m] (a new array)."""
        return self.grid.surface0 + self._h

    @property
    def velocity(self) -> np.ndarray:
        """Vertical velocity of every column, (ny, nx) [m/s] (a copy)."""
        return self._v.copy()

    def volume(self) -> float:
        """Water volume above the bed, bodies excluded [m^3] (stepped by tiles: see :meth:`_tile_sums`),
        with the water bodies in it when the run began had pushed aside (see :meth:`_register_at_rest`)."""
        if self.tiles is not None:
            return self._tile_sums()[0] + self._displaced_before
        return volume(self.grid, self._h, self._b) + self._displaced_before

    def energy(self) -> float:
        """The energy [J] the model keeps (:meth:`Model.energy`: the lattice energy of
        :mod:`components.water.diagnostics`, or airy's modes' energy; by tiles: :meth:`_tile_sums`)."""
        if self.tiles is not None:
            return self._tile_sums()[1]
        return self.model.energy(self._h, self._v)

    def _tile_sums(self) -> tuple[float, float]:
        """Volume [m^3] and lattice energy [J] summed over the water not at rest only (the rest
        volume added, the bodies' windows subtracted), so that a lake's figures cost what its moving
        water costs and make no array of the grid's size; they equal the dense sums of
        :mod:`components.water.diagnostics` up to the order of the additions (round-off)."""
        g = self.grid
        c2: float = g.c2_uniform  # type: ignore[assignment]  # tiles need a uniform grid
        s2 = g.cell * g.cell
        sum_h, sum_v2, sum_dx2, sum_dy2 = self.tiles.sums(self._h, self._v)  # type: ignore[union-attr]
        occupied = sum(float(np.sum(o.b[o.window[2]:o.window[3], o.window[0]:o.window[1]]))
                       for o in self._occupants if o.window is not None)
        if self._rest_sum is None:  # the rest water's columns, summed once (a sloped bed's are not all alike)
            self._rest_sum = float(np.sum(g.depth0))
        volume = (self._rest_sum + sum_h - occupied) * s2
        energy = g.column_mass * (0.5 * sum_v2 + 0.5 * c2 * (sum_dx2 + sum_dy2) / s2)
        return volume, energy

    @property
    def rest_level(self) -> float:
        """z of the undisturbed surface [m] (the ``rest_level`` parameter)."""
        return float(self.grid.rest_level)

    def bed_at(self, x: float, y: float) -> float | None:
        """The bed's height z [m] under (x, y) (its cell's), or None off the grid."""
        cell = self.grid.cell_at(x, y)
        return None if cell is None else float(self.grid.bed[cell[1], cell[0]])

    def check_start(self, inputs: dict[str, Message | None]) -> list[str]:
        """An initial trough that reaches the bed where the water is shallower than at the centre (a
        sloped bed): the parameters compare it with the centre's depth only, and a trough of 4 cm on
        a beach started 10.5 mm below the bed there."""
        bump, g = self.params.initial, self.grid
        if bump is None or bump.amplitude >= 0.0 or not g.wet.any():
            return []
        depth = np.where(g.wet, g.depth0 + self._h, np.inf)
        j, i = np.unravel_index(int(np.argmin(depth)), depth.shape)
        if depth[j, i] > 0.0:
            return []
        x, y = g.origin_x + i * g.cell, g.origin_y + j * g.cell
        return [f"initial: the trough reaches the bed at x = {x:.4g} m, y = {y:.4g} m, where the water is "
                f"{float(g.depth0[j, i]):.3g} m deep and the trough {float(self._h[j, i]):.3g} m: a trough "
                "shallower than the water wherever it reaches"]

    def check_start_sources(self, inputs: dict[str, Message | None], sources: dict[str, Component]) -> list[str]:
        """A source of occupied height that places its window by a grid of its own (a DropSource's
        ``cell``, ``origin_x``, ``origin_y``, ``nx``, ``ny``: :meth:`assumed_grid`) must assume this
        water's grid: with the pond's cell doubled, a drop meant at (0, 0) landed at (1.27, 1.27) m
        with four times its volume, and the run said nothing."""
        g = self.grid
        mine = {"cell": g.cell, "origin_x": g.origin_x, "origin_y": g.origin_y, "nx": g.nx, "ny": g.ny}
        problems = []
        for occupied, _, _ in self.body_ports:
            source = sources.get(occupied)
            assumed = getattr(source, "assumed_grid", None)
            if not callable(assumed):
                continue
            theirs = assumed()
            wrong = [f"{key} {theirs[key]:g} (the water's {mine[key]:g})" for key in mine
                     if not math.isclose(theirs[key], mine[key], rel_tol=1e-12, abs_tol=1e-12)]
            if wrong:
                problems.append(f"{occupied}: its source {source.name} places its window on another grid: "
                                f"{', '.join(wrong)}; set them as the water's")
        return problems

    def max_stable_step(self) -> float:
        """The model's stable step [s], and with damping at most DAMPING_STEP / k_v: the step's factor
        1 - k_v dt stays at least a half, within a fifth of the exact decay exp(-k_v dt). (At k_v dt = 1
        and above it is 0: every step stopped the water dead, and a bump stood frozen where it was.)"""
        bound = self.model.max_stable_step()
        if self.params.damping > 0.0:
            bound = min(bound, DAMPING_STEP / self.params.damping)
        return bound

    def stable_step_cause(self) -> str:
        if self.max_stable_step() < self.model.max_stable_step():  # (the damping's bound is the lower)
            return f"set by its damping {self.params.damping:g} 1/s: a step of at most {DAMPING_STEP:g} / damping"
        return self.model.stable_step_cause()

    def summary(self) -> list[str]:
        g, p = self.grid, self.params
        change = (self.volume() - self.initial_volume) / self.initial_volume
        return [f"{self.name}: {p.model} on {g.nx} x {g.ny} cells of {g.cell:g} m, {self._waves()}, "
                f"{p.boundary} edges; volume change {change:+.3g} (relative); surface energy "
                f"{surface_energy(self.grid, self._h):.3g} J (1/2 rho g sum eta^2 s^2; the model's "
                f"{self.model.invariant} {self.energy():.3g} J); {self._activity()}{self._shore_said()}"]

    def _shore_said(self) -> str:
        """What the summary says of a surface that went under the bed (:meth:`_check_shore`), if one did."""
        if self._under_bed is None:
            return ""
        depth, x, y, t = self._under_bed
        return (f"; the surface went {-depth * 1e3:.3g} mm under the bed at x = {x:.4g} m, y = {y:.4g} m "
                f"(t = {t:.4g} s): a wave too large for the shallows of this bed, where the model, linear "
                "about the water at rest, keeps the shoreline fixed")

    def _waves(self) -> str:
        """At what speed the water ran its waves, and why that speed."""
        p = self.params
        if p.model == "airy":
            return "each wave length at its own speed"
        c = self.wave_speed(p)
        if c is None:
            return f"waves at sqrt(g d) = {math.sqrt(GRAVITY * p.depth):.2g} m/s (at the rest depth)"
        if p.wave_length is not None:
            return f"waves at {c:.2g} m/s (those {p.wave_length:g} m long)"
        return f"waves at {c:.2g} m/s (set)"

    def _activity(self) -> str:
        """How much of the water was stepped: the share of tiles, peak and mean over the steps."""
        t = self.tiles
        if t is None:
            return "every column stepped every step (active fraction 1)"
        return (f"active water {100 * t.peak_fraction():.3g}% at most, {100 * t.mean_fraction():.3g}% on "
                f"average (of {counted(t.count, 'tile')} of {self._tile_shape()} cells, "
                f"over {counted(t.steps, 'step')})")

    def _tile_shape(self) -> str:
        """A tile's columns along x and y, as the summary says them: no more than the grid's (a tile of
        10^12 on a 60 x 60 pond was said to be 10^12 x 10^12 cells)."""
        t, g = self.tiles, self.grid
        return f"{min(t.tile, g.nx)} x {min(t.tile, g.ny)}"

    def active_fraction(self) -> float:
        """Fraction of the water stepped in the last step (1 on the dense path)."""
        return 1.0 if self.tiles is None else self.tiles.active_fraction()

    # --- state ----------------------------------------------------------------------------------

    def get_state(self) -> dict[str, Any]:
        return {"h": self._h.copy(), "v": self._v.copy(), **self._state_but_surface()}

    def checkpoint_state(self) -> dict[str, Any]:
        """The state with the surface packed (``surface``: the blocks of columns not at rest, see
        :mod:`components.water.sparse`): a checkpoint of a pond mostly at rest is mostly not written."""
        tile = self.tiles.tile if self.tiles is not None else sparse.BLOCK
        return {"surface": sparse.pack(self._h, self._v, tile), **self._state_but_surface()}

    def _state_but_surface(self) -> dict[str, Any]:
        # one body: its window of the occupied height; several: each body's own (their sum is the total)
        w = self._occupants[0].window if len(self._occupants) == 1 else None
        return {
            **_window_state(self._b, w),
            "steps": self._steps,
            "next_frame": self._next_frame,
            "first_frame_waits": self._first_frame_waits,
            "displaced_before": self._displaced_before,
            "follow": list(self._follow) if self._follow is not None else None,
            "following": self._following,
            "asked_at": [t if math.isfinite(t) else None for t in self._asked_at],
            "asked": [list(c) if c is not None else None for c in self._asked],
            "model": self.model.get_state(),
            "under_bed": list(self._under_bed) if self._under_bed is not None else None,
        } | ({"tiles": self.tiles.get_state()} if self.tiles is not None else {}) | (
            {"bodies": [_window_state(o.b, o.window) for o in self._occupants]} if len(self._occupants) > 1 else {})

    def set_state(self, state: dict[str, Any]) -> None:
        shape = self.grid.shape
        # (checked before anything is restored: a state refused leaves the water as it was)
        kept = len(state["bodies"]) if "bodies" in state else 1
        if kept != len(self._occupants):  # (a restart with bodies added or taken away by --set)
            raise ValueError(f"it holds the occupied heights of {kept} {'body' if kept == 1 else 'bodies'} on "
                             f"the water, which now takes {len(self._occupants)}: a restart keeps the bodies the "
                             "run had")
        if "surface" in state:  # a checkpoint's packed surface (checkpoint_state)
            sparse.unpack(state["surface"], self._h, self._v)
        else:
            for key in ("h", "v"):
                arr = np.asarray(state[key])
                if arr.shape != shape:
                    raise ValueError(f"state {key!r} has shape {arr.shape}, the grid is {shape}")
            np.copyto(self._h, state["h"])
            np.copyto(self._v, state["v"])
        self._b[:] = 0.0
        if len(self._occupants) == 1:
            self._occupants[0].window = _put_window(self._b, state["b_window"], state["b"])
        else:  # each body's own, and the total as their sum
            for occupant, saved in zip(self._occupants, state["bodies"], strict=True):
                occupant.b[:] = 0.0
                occupant.window = _put_window(occupant.b, saved["b_window"], saved["b"])
            self._b[:] = sum(o.b for o in self._occupants)
        if self.tiles is not None:
            # the spare buffers afresh (zeros, as a tile left at rest needs them), the flags from the state
            self._h2 = np.zeros(shape)
            self._v2 = np.zeros(shape)
            self.tiles.reset(self._h, self._v)
            self.tiles.set_state(state.get("tiles", {}))
        self._steps = int(state["steps"])
        self._next_frame = int(state["next_frame"])
        self._first_frame_waits = bool(state.get("first_frame_waits", False))
        self._displaced_before = float(state.get("displaced_before", 0.0))
        under = state.get("under_bed")
        self._under_bed = tuple(float(c) for c in under) if under is not None else None  # type: ignore[assignment]
        follow = state.get("follow")
        self._follow = (float(follow[0]), float(follow[1])) if follow is not None else None
        self._following = int(state.get("following", 0))  # (saved before it was kept: the first body)
        # (per body; saved before they were kept: each body new again)
        self._asked_at = self._per_body([float(t) if t is not None else -math.inf
                                         for t in state.get("asked_at") or []], -math.inf)
        self._asked = self._per_body([(float(c[0]), float(c[1])) if c is not None else None
                                      for c in state.get("asked") or []], None)
        if state.get("model"):
            self.model.set_state(state["model"])
        else:  # a state built by hand, or saved by a model that keeps none (a restart with another model):
            self.model.reset(self._h, self._v)  # the model starts from the columns

    # --- the step -------------------------------------------------------------------------------

    def _per_body(self, values: list, missing: Any) -> list:
        """``values`` saved one per body, fitted to this water's bodies (``missing`` for those past
        the saved ones)."""
        n = len(self.body_ports)
        return values[:n] + [missing] * (n - len(values))

    def answers(self) -> dict[str, str]:
        """Each body's patch goes back to the coupler that asks on the request port beside it."""
        return {patch: request for _, request, patch in self.body_ports}

    def needed_outputs(self) -> dict[str, str]:
        """Each named body's patch: its coupler reads the water only through it (a body named and left
        without a coupler fell 2 m through the pond, its monitor saying "approach")."""
        if not self.params.bodies:
            return {}  # (the one unnamed body's: a pond without bodies is a scene of its own)
        return {patch: (f"body {patch.removeprefix('patch_')!r} is named in bodies: its coupler reads the water "
                        f"only through it: connect {self.name}.{patch} -> <its coupler>.water, or leave the body "
                        "out of bodies")
                for _, _, patch in self.body_ports}

    def same_senders(self) -> dict[str, str]:
        """Each body's occupied height comes from the coupler asking for its patch (swapped, each
        patch echoed the other body's displacement as its own)."""
        return {occupied: request for occupied, request, _ in self.body_ports}

    def initial_outputs(self) -> dict[str, Message]:
        # at t = 0, nothing asked yet, the whole water's crest: a body let go inside a wave meets it at once
        g = self.grid
        crest = _said_crest(window_top(self._h, 0, g.nx, 0, g.ny))
        start = replace(self._empty_patch, crest=crest)
        out: dict[str, Message] = {patch_port: start for _, _, patch_port in self.body_ports}
        if self.params.field_every or self.params.field_rate:
            if self.params.field_window is not None and self.body_ports and self._follow is None:
                # a window around the bodies, none of which has asked yet: its first frame waits for
                # the first that asks (a step or two), instead of showing the grid's middle, away from
                # the stone, until the next frame (the reference skip's first 0.1 s)
                self._first_frame_waits = True
            else:
                out["field"] = self._field()
        return out

    def _step_impl(self, t: float, dt: float, inputs: dict[str, Message | None]) -> dict[str, Message]:
        return self._substep(t, dt, 1, inputs)

    def _substep(self, t: float, dt: float, n: int, inputs: dict[str, Message | None]) -> dict[str, Message]:
        for k, (occupied_port, _, _) in enumerate(self.body_ports):
            occupied = inputs.get(occupied_port)
            if occupied is not None:
                self.apply_occupied(occupied, k)  # type: ignore[arg-type]
        sub = dt / n
        for _ in range(n):
            self.advance(sub)
        self._steps += 1
        if self._shore is not None and self._steps % SHORE_CHECK_EVERY == 0:
            self._check_shore(t + dt)
        return self._outputs(t + dt, inputs)

    def _check_shore(self, t: float) -> None:
        """Keep where the surface of the shallows lies lowest under the bed, if anywhere (a wave running
        up a beach: the linear models keep their shoreline at rest and let a column's water go below
        nothing; 7 mm under the bed for a 1 cm wave on a 1:10 beach), said by :meth:`summary`. Every
        SHORE_CHECK_EVERY steps, over the shallows only: a trough lasts several steps, and only where
        the water is shallow beside the waves does it reach the bed."""
        cells, depth0 = self._shore
        depth = self._h.ravel()[cells] + depth0
        k = int(np.argmin(depth))
        lowest = float(depth[k])
        if lowest < 0.0 and (self._under_bed is None or lowest < self._under_bed[0]):
            g = self.grid
            j, i = divmod(int(cells[k]), g.nx)
            self._under_bed = (lowest, g.origin_x + i * g.cell, g.origin_y + j * g.cell, t)

    def advance(self, dt: float) -> None:
        """Advance the field by dt [s] with no input (model, boundary, smoothing)."""
        if self.tiles is not None:
            self._advance_tiles(dt)
            return
        self.model.advance(self._h, self._v, self._h2, self._v2, dt)
        self.boundary.after_step(self._h, self._h2, self._v2, dt)
        if self.params.smoothing > 0:
            f = min(SMOOTHING_MAX, self.params.smoothing * dt)
            weights = self._smoothing_weights
            if weights is None:
                self.kernels.smooth_open(self._h2, self._h3, f)
            else:
                self.kernels.smooth(self._h2, self._h3, *weights, f)
            self._h2, self._h3 = self._h3, self._h2
        self._h, self._h2 = self._h2, self._h
        self._v, self._v2 = self._v2, self._v

    def _advance_tiles(self, dt: float) -> None:
        """:meth:`advance` by tiles: only the tiles not at rest (and their neighbours) are stepped."""
        model: WaveModel = self.model  # type: ignore[assignment]  # tiling_applies admits only it
        tiles: Tiles = self.tiles  # type: ignore[assignment]
        kdt, damp = model.uniform_factors(dt)
        tiles.wave_step(self._h, self._v, self._h2, self._v2, kdt, dt, damp)
        if self.boundary.rewritten_band:  # else the boundary writes nothing (reflecting): no call
            self.boundary.after_step(self._h, self._h2, self._v2, dt, moving=tiles.moving())
            tiles.rescan_edges(self._h2, self._v2, self.boundary.rewritten_band)
        tiles.finish_step()
        self._h, self._h2 = self._h2, self._h
        self._v, self._v2 = self._v2, self._v

    def apply_occupied(self, msg: OccupiedHeight, body: int = 0) -> None:
        """h += b - b_prev over the union of the old and new windows of ``body`` (its index in
        ``bodies``; the part off the grid is ignored)."""
        occupant = self._occupants[body]
        g = self.grid
        b = np.asarray(msg.b, dtype=np.float64)
        if b.size == 0:
            b = b.reshape(0, 0)
        elif b.ndim != 2:
            raise ValueError(f"occupied height b must be a 2D (nj, ni) array (got shape {b.shape})")
        nj, ni = b.shape
        i0, i1 = max(msg.i0, 0), min(msg.i0 + ni, g.nx)
        j0, j1 = max(msg.j0, 0), min(msg.j0 + nj, g.ny)
        new = (i0, i1, j0, j1) if i0 < i1 and j0 < j1 else None
        old = occupant.window
        if new is None and old is None:
            return
        if old is None or new is None:
            u0, u1, v0, v1 = new if old is None else old
        else:
            u0, u1 = min(old[0], new[0]), max(old[1], new[1])
            v0, v1 = min(old[2], new[2]), max(old[3], new[3])
        passes = self.params.displacement_smoothing
        if not passes and not (msg.already_displaced and old is None):
            # the usual step: the change of the occupied height into the surface in one pass
            # (the same operations as below, column by column)
            apply_window(self._h, occupant.b, self._b, occupant.b is not self._b, b, msg.i0, msg.j0,
                         u0, u1, v0, v1)
            if self.tiles is not None:
                self.tiles.touch(u0, u1, v0, v1)
            occupant.window = new
            return
        if passes:
            u0, u1 = max(u0 - passes, 0), min(u1 + passes, g.nx)
            v0, v1 = max(v0 - passes, 0), min(v1 + passes, g.ny)
        b_new = np.zeros((v1 - v0, u1 - u0))
        if new is not None:
            b_new[j0 - v0:j1 - v0, i0 - u0:i1 - u0] = b[j0 - msg.j0:j1 - msg.j0, i0 - msg.i0:i1 - msg.i0]
        if msg.already_displaced and old is None:
            # the body was in the water when the run began: its displacement is part of the water
            # at rest (nothing raised), and of the water's volume from the start
            self._register_at_rest(occupant, b_new, (u0, u1, v0, v1), new)
            return
        delta = b_new - occupant.b[v0:v1, u0:u1]
        if occupant.b is not self._b:  # one of several bodies: the total takes its change
            self._b[v0:v1, u0:u1] += delta
        if passes and self._all_wet:
            self.kernels.blur(delta, np.empty_like(delta), passes, BLUR_WEIGHT)
        elif passes:  # only across faces between wet cells: blurred onto dry land, 7% of a body's
            # water pushed aside at a shore sat frozen on the beach, 0.4 mm over its bed
            kernels_numpy.blur(delta, delta, passes, BLUR_WEIGHT,
                               self.grid.kx[v0:v1, u0:u1 - 1] > 0.0, self.grid.ky[v0:v1 - 1, u0:u1] > 0.0)
        self._h[v0:v1, u0:u1] += delta
        if self.tiles is not None:
            self.tiles.touch(u0, u1, v0, v1)
        occupant.b[v0:v1, u0:u1] = b_new
        occupant.window = new

    def _register_at_rest(self, occupant: _Occupant, b_new: np.ndarray, box: tuple[int, int, int, int],
                          window: tuple[int, int, int, int] | None) -> None:
        """Take ``b_new`` over ``box`` (i0, i1, j0, j1) as a body's occupied height the water already
        holds: the surface stays. The water the body pushed aside before the run is counted as water
        (its displaced volume, spread over the whole pond, raised the level by far less than a
        column's round-off), so the water's volume is the same before and after."""
        u0, u1, v0, v1 = box
        if occupant.b is not self._b:
            self._b[v0:v1, u0:u1] += b_new - occupant.b[v0:v1, u0:u1]
        occupant.b[v0:v1, u0:u1] = b_new
        occupant.window = window
        self._displaced_before += float(b_new.sum()) * self.grid.cell ** 2

    # --- outputs --------------------------------------------------------------------------------

    def _outputs(self, t_end: float, inputs: dict[str, Message | None]) -> dict[str, Message]:
        # the field's window follows the water a body last asked for anew, its columns or the crest where
        # it goes (a stone in flight is followed): with several bodies, one whose window moved, not the
        # first of them (a floating ball, whose window stays, held it for the whole run), and the same
        # one while its window moves (two stones in flight took it in turns: the viewer's water
        # jumped between them at every frame)
        moved = []
        for k, (_, request_port, _) in enumerate(self.body_ports):
            request = inputs.get(request_port)
            if isinstance(request, PatchRequest) and request.x_min <= request.x_max and request.y_min <= request.y_max:
                centre = (0.5 * (request.x_min + request.x_max), 0.5 * (request.y_min + request.y_max))
                if centre != self._asked[k]:
                    if self._asked[k] is not None:  # (its first request is no motion: a ball floating still)
                        self._asked_at[k] = t_end
                    self._asked[k] = centre
                    moved.append(k)
        followed = False
        if self._following in moved:
            self._follow, followed = self._asked[self._following], True
        elif moved and not t_end - self._asked_at[self._following] < FOLLOW_HOLD:
            # (a request is held while it still covers its body: a stone in flight asks anew every few steps)
            self._following = moved[0]
            self._follow, followed = self._asked[self._following], True
        out: dict[str, Message] = {
            patch_port: self.patch(inputs.get(request_port), k)  # type: ignore[arg-type]
            for k, (_, request_port, patch_port) in enumerate(self.body_ports)}
        if self._field_due(t_end) or (self._first_frame_waits and followed):
            self._first_frame_waits = False
            out["field"] = self._field()
        return out

    def patch(self, request: PatchRequest | None, body: int = 0) -> HeightPatch:
        """The columns over a requested rectangle plus the margin (empty when nothing is requested),
        with the occupied height of ``body`` (its index in ``bodies``)."""
        if request is None:
            return self._empty_patch
        g = self.grid
        cached = self._windows.get(body)
        if cached is not None and cached[0] is request:
            win = cached[1]  # a body's request is held over many steps: its window with it
        else:
            win = g.window(request.x_min, request.x_max, request.y_min, request.y_max, self.params.patch_margin)
            self._windows[body] = (request, win)
        if win is None:
            asked = request.x_min <= request.x_max and request.y_min <= request.y_max
            return self._off_grid_patch if asked else self._empty_patch
        i0, i1, j0, j1 = win
        crest = _said_crest(window_top(self._h, i0, i1, j0, j1))
        if not request.columns:  # the crest alone, held while it stays within its millimetre
            held = self._crests.get(body)
            if held is None or held.crest != crest or (held.i0, held.j0) != (i0, j0):
                held = self._crests[body] = replace(self._empty_patch, i0=i0, j0=j0, crest=crest)
            return held
        height, velocity, bottom, occupied = patch_arrays(g.surface0, self._h, self._v, g.bed,
                                                          self._occupants[body].b, win)
        return HeightPatch(i0=i0, j0=j0, cell=g.cell, origin_x=g.origin_x, origin_y=g.origin_y,
                           rest_level=g.rest_level, height=height, velocity=velocity, bottom=bottom,
                           occupied=occupied, crest=crest)

    def _field_due(self, t_end: float) -> bool:
        p = self.params
        if p.field_every:
            return self._steps % p.field_every == 0
        if p.field_rate:
            # frame k is due at k / field_rate; frames that fell inside one long step are merged
            end_ns = round(t_end * NS_PER_S)
            elapsed = math.floor(end_ns * p.field_rate / NS_PER_S + 1e-9)
            if elapsed >= self._next_frame:
                self._next_frame = elapsed + 1
                return True
        return False

    def field_window(self) -> tuple[int, int, int, int]:
        """Index window (i0, i1, j0, j1) of the published field: the whole grid, or with
        ``field_window`` that size around the last water a body asked for (before any, the grid's
        centre), kept inside the grid. Its corner moves in whole steps of FIELD_WINDOW_STEP cells (a
        quarter of a smaller window), so a viewer's mesh keeps its grid while the body moves less than
        that."""
        g, size = self.grid, self.params.field_window
        if size is None:
            return 0, g.nx, 0, g.ny
        # sizes and places clipped to the grid before rounding: 1e308 m over a cell overflows to inf
        ni = min(g.nx, max(2, round(min(size[0] / g.cell, g.nx))))
        nj = min(g.ny, max(2, round(min(size[1] / g.cell, g.ny))))
        if self._follow is not None:  # (a centre this far off the grid puts the window at its edge anyway)
            far_i, far_j = g.nx + ni + FIELD_WINDOW_STEP, g.ny + nj + FIELD_WINDOW_STEP
            ci = min(max((self._follow[0] - g.origin_x) / g.cell, -far_i), g.nx + far_i)
            cj = min(max((self._follow[1] - g.origin_y) / g.cell, -far_j), g.ny + far_j)
        else:
            ci, cj = (g.nx - 1) / 2, (g.ny - 1) / 2
        # steps of at most a quarter of the window: the body stays in its middle half (steps of 32
        # cells left a 10-cell window 10 cells away from the body it follows)
        step_i, step_j = min(FIELD_WINDOW_STEP, max(1, ni // 4)), min(FIELD_WINDOW_STEP, max(1, nj // 4))
        i0 = min(max(step_i * round((ci - ni / 2) / step_i), 0), g.nx - ni)
        j0 = min(max(step_j * round((cj - nj / 2) / step_j), 0), g.ny - nj)
        return i0, i0 + ni, j0, j0 + nj

    def _field(self) -> WaterField:
        g = self.grid
        i0, i1, j0, j1 = self.field_window()
        sl = (slice(j0, j1), slice(i0, i1))
        if self.tiles is not None:
            volume, energy = self._tile_sums()
            volume += self._displaced_before
        else:
            volume, energy = self.volume(), self.energy()
        return WaterField(cell=g.cell, origin_x=g.origin_x + i0 * g.cell, origin_y=g.origin_y + j0 * g.cell,
                          height=g.surface0[sl] + self._h[sl], volume=volume, energy=energy,
                          active_fraction=self.active_fraction())


@dataclass
class _Occupant:
    """One body's occupied height b [m] over the whole grid (zero outside its window) and its window
    (i0, i1, j0, j1), None when it occupies nothing."""

    b: np.ndarray
    window: tuple[int, int, int, int] | None = None


def _said_crest(top: float) -> float:
    """A highest column ``top`` [m] as a patch says it: rounded up to the millimetre; a NaN or an
    infinity as it is, for the outputs' finiteness check to name (rounding it raised ValueError)."""
    return math.ceil(top * CREST_RESOLUTION) / CREST_RESOLUTION if math.isfinite(top) else top


def _window_state(b: np.ndarray, w: tuple[int, int, int, int] | None) -> dict[str, Any]:
    return {"b_window": list(w) if w is not None else None,
            "b": b[w[2]:w[3], w[0]:w[1]].copy() if w is not None else np.zeros((0, 0))}


def _put_window(b: np.ndarray, w: list[int] | None, part: Any) -> tuple[int, int, int, int] | None:
    """Write a saved window ``part`` into ``b``; the window as a tuple (None when empty)."""
    if w is None:
        return None
    i0, i1, j0, j1 = (int(k) for k in w)
    b[j0:j1, i0:i1] = part
    return i0, i1, j0, j1
