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
scheme is unconditionally stable, and numerically damped at every step: a wave of frequency omega
loses about a factor exp(-pi omega dt) of its amplitude a period, first order in the step. Undamped
(damping 0), a Gaussian hump 1 cm high and 5 cm wide (``initial: {amplitude: 0.01, width: 0.05}``)
in the middle of a 2 m square basin 0.5 m deep on 1 cm cells keeps 28% of its energy after 1 s at
c dt / s = 0.1 and 3.4% at 0.5, where the explicit ``wave`` model keeps it (100% and 101%): for
waves that must keep their energy, ``wave``.

In a closed basin the total vertical velocity sum(v) is an invariant (zero for water started at
rest): the volume changes at that rate. The Thomas factors are rounded, so each solve misses the
exact sum by about an ulp, with a consistent sign; sum(v) would take up that error every step and the
volume would drift as the square of the step count. So with reflecting edges the implicit model
holds sum(v) at its exact value (the previous one times the damping factor), shifting v by the tiny
mean defect: a feedback, so rounding cannot accumulate.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from components.water.diagnostics import energy as lattice_energy
from components.water.grid import GRAVITY, SURFACE_TENSION, WATER_DENSITY, Grid, is_broadcast, uniform_view


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


def _per_face(k: np.ndarray, s2: float, dtype: type = np.float64) -> np.ndarray:
    """Face coefficients K / s^2 [1/s^2], worked out in double precision and held as ``dtype``;
    one value for a compact grid's one value."""
    if is_broadcast(k):
        return uniform_view(np.array([k.flat[0] / s2], dtype=dtype), k.shape)
    return np.ascontiguousarray(k / s2, dtype=dtype)


class Model:
    """A time integrator of the height field. Subclasses set ``name`` and ``explicit``."""

    name: ClassVar[str] = ""
    explicit: ClassVar[bool] = False
    # what :meth:`energy` is, for the run summary: the semi-discrete model's invariant, about which the
    # explicit step oscillates (its own invariant is the shadow energy: diagnostics), so not called one
    invariant: ClassVar[str] = "lattice energy"
    # arrays of the grid's size the model holds or makes in a step beyond the surface's own (its
    # memory estimate, WaterSurface.estimate_bytes)
    extra_arrays_per_cell: ClassVar[int] = 0

    def __init__(self, grid: Grid, kernels: Any, damping: float = 0.0, closed: bool = True):
        self.grid = grid
        self.kernels = kernels
        self.damping = damping
        self.closed = closed
        s2 = grid.cell * grid.cell
        dtype = self.face_dtype(grid)
        self.ax = _per_face(grid.kx, s2, dtype)  # (ny, nx-1) [1/s^2]
        self.ay = _per_face(grid.ky, s2, dtype)  # (ny-1, nx) [1/s^2]

    def face_dtype(self, grid: Grid) -> type:
        """The type the face coefficients are held in (the arithmetic is double either way)."""
        return np.float64

    def max_stable_step(self) -> float:
        """Largest stable step [s] (inf for an unconditionally stable model)."""
        return math.inf

    def stable_step_cause(self) -> str:
        """What sets :meth:`max_stable_step`, when it is more than the model's own stencil ('' else)."""
        return ""

    def advance(self, h: np.ndarray, v: np.ndarray, h_out: np.ndarray, v_out: np.ndarray, dt: float) -> None:
        """Write the state after a step of ``dt`` [s] into ``h_out``, ``v_out`` (inputs unchanged)."""
        raise NotImplementedError

    def reset(self, h: np.ndarray, v: np.ndarray) -> None:
        """Start from a new state (h, v) given from outside."""

    def energy(self, h: np.ndarray, v: np.ndarray) -> float:
        """The model's energy [J]: the lattice energy of :mod:`components.water.diagnostics` unless
        the model says otherwise, about which the undamped explicit model oscillates without drift
        (by a factor 1 / (1 -+ omega dt / 2) for a wave of frequency omega: diagnostics), and which
        the implicit one's own numerical damping takes (see the module's docstring)."""
        return lattice_energy(self.grid, h, v)

    def get_state(self) -> dict[str, Any]:
        """The model's own dynamic state, as plain data."""
        return {}

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore :meth:`get_state`."""


class WaveModel(Model):
    """The proposal's semi-implicit Euler wave equation (explicit)."""

    name = "wave"
    explicit = True

    def face_dtype(self, grid: Grid) -> type:
        # The per-face step (a grid that is not uniform) is limited by memory traffic: at 512 x 512
        # its two coefficient arrays are a third of the bytes it moves. Held in single precision (a
        # relative rounding of at most 6e-8 on g d, far below what the bed's own resolution means),
        # they cut that step by about a fifth.
        return np.float32 if grid.c2_uniform is None else np.float64

    def __init__(self, grid: Grid, kernels: Any, damping: float = 0.0, closed: bool = True):
        super().__init__(grid, kernels, damping, closed)
        # Gershgorin: the operator's eigenvalues are below max over cells of 2 sum_f a_f, and the
        # leapfrog needs dt^2 lambda <= 4. On a uniform grid (4 faces of c^2/s^2) this is exactly
        # c dt / s <= 1/sqrt(2). Computed once: the bound depends only on the grid. A compact grid's
        # corner of 3 x 3 cells holds every case (edge, corner, interior), summed in the same order.
        ax, ay = self.ax, self.ay
        if grid.compact:
            ny, nx = min(grid.ny, 3), min(grid.nx, 3)
            ax, ay = ax[:ny, :nx - 1], ay[:ny - 1, :nx]
        total = np.zeros((ax.shape[0], ay.shape[1]))
        total[:, 1:] += ax
        total[:, :-1] += ax
        total[1:, :] += ay
        total[:-1, :] += ay
        peak = float(total.max())
        self._bound = math.sqrt(2.0 / peak) if peak > 0.0 else math.inf

    def max_stable_step(self) -> float:
        return self._bound

    def uniform_factors(self, dt: float) -> tuple[float, float]:
        """(kdt, damp) of a step of dt [s] on a uniform grid: kdt = dt c^2 / s^2 [1/s], damp the
        velocity factor; the tiled step (:mod:`components.water.tiles`) takes the very same ones."""
        c2 = self.grid.c2_uniform
        if c2 is None:
            raise ValueError("uniform_factors: the grid is not uniform (a sloped bed or dry cells)")
        return dt * c2 / (self.grid.cell * self.grid.cell), damping_factor(self.damping, dt)

    def advance(self, h: np.ndarray, v: np.ndarray, h_out: np.ndarray, v_out: np.ndarray, dt: float) -> None:
        damp = damping_factor(self.damping, dt)
        if self.grid.c2_uniform is not None:
            kdt, damp = self.uniform_factors(dt)
            self.kernels.wave_uniform(h, v, h_out, v_out, kdt, dt, damp)
        else:
            self.kernels.wave_faces(h, v, h_out, v_out, self.ax, self.ay, dt, damp)


class ShallowWaterModel(Model):
    """Kass & Miller's implicit alternating-direction shallow-water scheme."""

    name = "shallow_water"
    explicit = False

    def __init__(self, grid: Grid, kernels: Any, damping: float = 0.0, closed: bool = True):
        super().__init__(grid, kernels, damping, closed)
        self._factors_dt: float | None = None
        self._factors: tuple[np.ndarray, ...] = ()
        self._all_wet = bool(grid.wet.all())
        self._n_wet = int(grid.wet.sum())
        self.sum_v = 0.0  # the exact total vertical velocity of a closed basin [m/s]

    def reset(self, h: np.ndarray, v: np.ndarray) -> None:
        self.sum_v = self._sum_wet(v)

    def get_state(self) -> dict[str, Any]:
        return {"sum_v": self.sum_v}

    def set_state(self, state: dict[str, Any]) -> None:
        self.sum_v = float(state["sum_v"])

    def _sum_wet(self, v: np.ndarray) -> float:
        return float(np.sum(v)) if self._all_wet else float(np.sum(v[self.grid.wet]))

    def factors(self, dt: float) -> tuple[np.ndarray, ...]:
        """Thomas factors of A_x (along rows) and A_y (along columns) for this dt (cached per dt).

        Shapes (ny, nx) each, or (1, nx) for x and (ny, 1) for y on a uniform grid.
        """
        if self._factors_dt != dt:
            ax, ay = self.ax, self.ay
            if self.grid.c2_uniform is not None:
                # every row (column) has the same matrix: factor one, shared by all (less memory traffic)
                ax, ay = ax[:1], ay[:, :1]
            fx = thomas_factors(ax, dt)
            fy = tuple(np.ascontiguousarray(f.T) for f in thomas_factors(np.ascontiguousarray(ay.T), dt))
            self._factors = (*fx, *fy)
            self._factors_dt = dt
        return self._factors

    def advance(self, h: np.ndarray, v: np.ndarray, h_out: np.ndarray, v_out: np.ndarray, dt: float) -> None:
        lx, ix, ux, ly, iy, uy = self.factors(dt)
        damp = damping_factor(self.damping, dt)
        self.kernels.adi_x(h, v, dt, h_out, lx, ix, ux)
        self.kernels.adi_y(h, dt, damp, h_out, v_out, ly, iy, uy)
        if self.closed and self._n_wet:
            self.sum_v *= damp
            defect = (self._sum_wet(v_out) - self.sum_v) / self._n_wet
            if self._all_wet:
                v_out -= defect
            else:
                v_out[self.grid.wet] -= defect


AIRY_EDGE_TURN = 0.9  # [half turns] the most the fastest mode may turn a step between absorbing edges
# [-] the margin on airy_edge_need: the exact threshold is up to 1.05 times it on long strips and,
# measured against the checkerboard's turn, 1.42 times it on a 3 x 3 pond (0.6 on 4 x 4 to 8 x 8)
AIRY_EDGE_SLACK = 1.5


def airy_frequency(k: np.ndarray | float, depth: float) -> np.ndarray:
    """Airy's angular frequency [rad/s] of waves of wavenumber ``k`` [1/m] on water ``depth`` [m]
    deep, with the surface tension's restoring force: sqrt((g k + gamma k^3 / rho_w) tanh(k d))."""
    k = np.asarray(k, dtype=np.float64)
    return np.sqrt((GRAVITY * k + SURFACE_TENSION * k**3 / WATER_DENSITY) * np.tanh(k * depth))


def airy_edge_need(turn: float) -> float:
    """The least c dt / s [-] at which absorbing edges keep airy water bounded when the lattice's
    fastest wave turns by ``turn`` [rad] a step: (turn / pi)^2 tan(turn / 2), endless at pi.

    A fit to the exact threshold: the c dt / s below which the step's matrix (the modes' rotation,
    then the edges' one-way rewrite) has an eigenvalue outside the unit circle. On strips of 24
    cells of 1 mm to 5 cm, 1 cm to 1 m deep, that threshold is at most 1.045 times the fit: 0.94
    to 1.045 times it from turn = 0.3 pi to 0.98 pi on millimetre cells, whose capillary waves need
    the most (0.26 at pi / 2, 1.9 at 0.8 pi, 5.0 at 0.9 pi), down to 0.6 at 0.98 pi for gravity
    waves on deep water; the turn matters, the dispersion's shape little. The turn is the checkerboard's
    (k = sqrt(2) pi / s), the frequency a large grid's fastest mode tends to: a small grid's own
    fastest mode is slower and its edge cells more of the water, and it needs more at its own turn
    (4 times on 3 x 3), but less than AIRY_EDGE_SLACK times the fit at the checkerboard's.
    """
    return (turn / math.pi) ** 2 * math.tan(turn / 2.0)


def airy_edge_step(speed: float, cell: float, fastest: float) -> float:
    """The longest step [s] at which absorbing edges of one-way speed ``speed`` [m/s] keep airy water
    bounded on cells of ``cell`` [m] whose fastest wave has frequency ``fastest`` [rad/s]: the dt
    with c dt / s = AIRY_EDGE_SLACK airy_edge_need(fastest dt). Every shorter step holds too:
    airy_edge_need(w dt) / dt rises with dt, from 0 to infinity at w dt = pi."""
    low, high = 0.0, math.pi / fastest
    for _ in range(60):  # bisection to the double's resolution
        mid = 0.5 * (low + high)
        if speed * mid / cell >= AIRY_EDGE_SLACK * airy_edge_need(fastest * mid):
            low = mid
        else:
            high = mid
    return low


class AiryModel(Model):
    """Linear water waves with water's dispersion, omega^2 = (g k + gamma k^3 / rho) tanh(k d) (Airy,
    with capillarity), stepped exactly.

    The ``wave`` and ``shallow_water`` models carry waves of every length at one speed, sqrt(g d):
    on a pond 0.5 m deep a 5 cm wave runs at 2.2 m/s instead of the 0.30 m/s of real water (gravity
    and capillarity), and a body moving near that one speed resonates with every wave it makes
    (docs/accuracy.md, "The glide is where the water model is weakest"). Here each standing mode of
    the basin (a cosine in x times a cosine in y: the walls reflect) turns at its own frequency: in
    the mode's coefficients (H, V) of the height and the vertical velocity, one step of dt is the
    exact rotation

        H' = H cos(w dt) + V sin(w dt) / w,   V' = (-H w sin(w dt) + V cos(w dt)) damp

    with w = sqrt((g k + gamma k^3 / rho_w) tanh(k d)), gravity and capillarity together, as
    grid.wave_speed_of gives every speed elsewhere (without capillarity a 2 cm ripple ran 24% slow,
    0.18 m/s against 0.23; at the stones' 10 cm, 2%). The mean
    (k = 0) only takes H' = H + V dt, so the volume is kept; the lattice energy is not this model's
    invariant, the modes' own energy is. Between walls any step is stable; with absorbing edges, see
    :meth:`max_stable_step`. The transforms are scipy's (type-II
    cosine transforms of h and v each way, O(n log n)): about 40 ms a step for the reference skip's
    1400 x 250 pond, tens of times the explicit model's tiled step, and every column is stepped. It
    needs a flat bed at one depth and no set wave speed (a scene asking otherwise is refused). The
    absorbing edges' one-way condition is the explicit model's, made for sqrt(g d): the short, slow
    waves that reach them are partly reflected.
    """

    name = "airy"
    explicit = False
    invariant = "modes' energy"
    # each mode's frequency and its step's three factors, and within a step the transforms of height
    # and velocity, the new height's and scipy's work arrays; it steps every column, so a lake's
    # pages are all touched. Measured with tracemalloc over a 600 x 400 pond's steps: 13 arrays'
    # worth at the peak with the flat bed's 8 (tests/test_airy_water.py)
    extra_arrays_per_cell = 8

    def __init__(self, grid: Grid, kernels: Any, damping: float = 0.0, closed: bool = True):
        super().__init__(grid, kernels, damping, closed)
        if grid.c2_uniform is None or not bool(grid.wet.all()):
            raise ValueError("model airy needs a flat bed wet everywhere (no bottom_slope, no dry cells)")
        ny, nx = grid.shape
        kx = np.pi * np.arange(nx) / (nx * grid.cell)
        ky = np.pi * np.arange(ny) / (ny * grid.cell)
        k = np.hypot(ky[:, None], kx[None, :])
        self.omega = airy_frequency(k, grid.depth)  # (ny, nx) [rad/s]
        # each mode's restoring stiffness per area [N/m^3]: gravity's and the surface tension's
        self._stiffness = WATER_DENSITY * GRAVITY + SURFACE_TENSION * k * k
        self._dt: float | None = None
        # the step in which the fastest mode turns AIRY_EDGE_TURN half turns: found once, not over
        # every mode at each step the scheduler asks for the bound
        self._turn_step = AIRY_EDGE_TURN * math.pi / float(self.omega.max())
        # the absorbing edges' one-way speed is the grid's sqrt(g d) (components.water.boundaries)
        checkerboard = float(airy_frequency(math.sqrt(2.0) * math.pi / grid.cell, grid.depth))
        self._edge_step = airy_edge_step(math.sqrt(grid.c2_uniform), grid.cell, checkerboard)

    def max_stable_step(self) -> float:
        """inf between walls (each mode's step is an exact rotation); with absorbing edges the shorter
        of AIRY_EDGE_TURN pi / w_max (w_max the fastest mode's frequency; noise in every mode grows
        from 0.94 pi / w_max on, on 16 x 12 cells of 1 cm 0.3 m deep) and :func:`airy_edge_step`.

        The edges rewrite their cells after the modes' rotation by the one-way law
        h0' = h1 + k (h1' - h0), k = (c dt - s) / (c dt + s), c = sqrt(g d), v0' = (h0' - h0) / dt.
        A short standing mode, turning nearly w_max dt a step, takes energy from that rewrite unless
        k is near enough 1 (c dt / s >= :func:`airy_edge_need`), and the exact rotation has nothing to
        drain it: the bound depends on c dt / s as well as on w_max dt. On centimetre cells and deep
        water c dt / s is 4 to 8 at 0.9 pi / w_max and the water held there; on millimetre cells
        (capillarity sets w_max) or shallow water it is about 1, and the water grew from 0.65 pi /
        w_max on (1 mm cells 5 cm deep; 0.67 on 5 cm cells 2 cm deep): at 0.9 pi / w_max by 2.7% and
        1.8% a step, a pulse on 40 x 40 mm cells stepped at 1.15 ms ended with 2.6e6 J and the run said
        ok. The bound there is now 0.51 and 0.53 pi / w_max (0.66 ms, 58 ms); on 1 cm cells 0.3 m deep
        0.87 of 0.9 pi / w_max on 16 x 12 cells, and 0.97 of it (26.7 ms) on the reference skip's
        1400 x 350, whose water steps every 2 ms."""
        if self.closed:
            return math.inf
        return min(self._turn_step, self._edge_step)

    def stable_step_cause(self) -> str:
        if self.closed:
            return ""
        if self._edge_step < self._turn_step:
            return ("set by its absorbing edges: their one-way rewrite feeds the short wave modes unless "
                    f"c dt / s >= {AIRY_EDGE_SLACK:g} (w dt / pi)^2 tan(w dt / 2), c = sqrt(g d), w the "
                    "frequency of the grid's checkerboard")
        return ("set by its absorbing edges: the edge cannot follow a wave mode that turns about half a turn "
                f"a step ({AIRY_EDGE_TURN:g} pi / its fastest mode's frequency)")

    def _rotation(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self._dt != dt:
            w = self.omega
            phase = w * dt
            sin_over_w = np.where(w > 0.0, np.sin(phase) / np.where(w > 0.0, w, 1.0), dt)  # the mean: dt
            self._cos, self._sin_over_w, self._w_sin = np.cos(phase), sin_over_w, w * np.sin(phase)
            self._dt = dt
        return self._cos, self._sin_over_w, self._w_sin

    def energy(self, h: np.ndarray, v: np.ndarray) -> float:
        """The modes' energy [J], 1/2 s^2 sum (rho g + gamma k^2) (H^2 + V^2 / w^2): each mode's
        potential energy, gravity's and the surface tension's (the transform keeps sum h^2), and the
        kinetic energy of its flow, 1/2 rho V^2 / (k tanh kd) = 1/2 (rho g + gamma k^2) V^2 / w^2 by
        the dispersion relation. (Counted with gravity's stiffness alone, a ripple near c_min, 1.7 cm
        long, reported half its energy.) A mode turns on its ellipse, so the undamped step keeps it to
        round-off. The mean's vertical velocity (w = 0) is a change of volume, not a wave: left out."""
        from scipy import fft

        modes_h = fft.dctn(h, type=2, norm="ortho")
        modes_v = fft.dctn(v, type=2, norm="ortho")
        w = self.omega
        kinetic = np.divide(modes_v * modes_v, w * w, out=np.zeros_like(w), where=w > 0.0)
        return 0.5 * self.grid.cell**2 * float(np.sum(self._stiffness * (modes_h * modes_h + kinetic)))

    def advance(self, h: np.ndarray, v: np.ndarray, h_out: np.ndarray, v_out: np.ndarray, dt: float) -> None:
        from scipy import fft

        cos, sin_over_w, w_sin = self._rotation(dt)
        modes_h = fft.dctn(h, type=2, norm="ortho")
        modes_v = fft.dctn(v, type=2, norm="ortho")
        # the rotation in place, as few arrays of the grid's size as it takes (a lake's is large)
        new_h = modes_h * cos
        new_h += modes_v * sin_over_w
        modes_v *= cos
        modes_h *= w_sin
        modes_v -= modes_h
        modes_v *= damping_factor(self.damping, dt)
        h_out[...] = fft.idctn(new_h, type=2, norm="ortho", overwrite_x=True)
        v_out[...] = fft.idctn(modes_v, type=2, norm="ortho", overwrite_x=True)


MODELS: dict[str, type[Model]] = {m.name: m for m in (WaveModel, ShallowWaterModel, AiryModel)}
"""Water models by name."""
