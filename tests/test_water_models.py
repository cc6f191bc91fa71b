"""Water models against exact discrete references: basin modes, wave speed, stability bound."""

from __future__ import annotations

import math

import numpy as np
import pytest

from components.water import WaterParams, WaterSurface
from components.water.grid import GRAVITY
from components.water.models import MODELS

# the models whose waves all run at one speed on their lattice (airy's dispersion: tests/test_airy_water.py)
ONE_SPEED = [m for m in MODELS if m != "airy"]


def pond(**kw) -> WaterSurface:
    return WaterSurface("pond", WaterParams(**kw))


def basin_mode(nx: int, ny: int, m: int, n: int) -> np.ndarray:
    """Eigenmode of the reflecting basin: cos(pi m (i + 1/2) / nx) cos(pi n (j + 1/2) / ny)."""
    i, j = np.arange(nx), np.arange(ny)
    return np.cos(np.pi * n * (j[:, None] + 0.5) / ny) * np.cos(np.pi * m * (i[None, :] + 0.5) / nx)


def discrete_frequency(model: str, c: float, s: float, dt: float, nx: int, ny: int, m: int, n: int) -> float:
    """Exact angular frequency [rad/s] of mode (m, n) for each time scheme on the 5-point grid."""
    wx2 = 4 * c**2 / s**2 * math.sin(math.pi * m / (2 * nx)) ** 2
    wy2 = 4 * c**2 / s**2 * math.sin(math.pi * n / (2 * ny)) ** 2
    if model == "wave":  # leapfrog: cos(W dt) = 1 - dt^2 w^2 / 2
        return 2 / dt * math.asin(dt * math.sqrt(wx2 + wy2) / 2)
    # Kass-Miller: r^2 - 2 lam r + lam = 0, lam = 1 / ((1 + dt^2 wx^2)(1 + dt^2 wy^2)): cos(W dt) = sqrt(lam)
    lam = 1 / ((1 + dt**2 * wx2) * (1 + dt**2 * wy2))
    return math.acos(math.sqrt(lam)) / dt


def measured_frequency(series: np.ndarray, dt: float) -> float:
    """Angular frequency from the zero crossings of a sampled oscillation (linear interpolation)."""
    k = np.nonzero(np.sign(series[:-1]) * np.sign(series[1:]) < 0)[0]
    crossings = (k + series[k] / (series[k] - series[k + 1])) * dt
    half_period = (crossings[-1] - crossings[0]) / (len(crossings) - 1)
    return math.pi / half_period


@pytest.mark.parametrize("model", ONE_SPEED)
@pytest.mark.parametrize("mode", [(1, 0), (2, 1), (3, 3)])
def test_standing_mode_oscillates_at_its_discrete_frequency(model, mode):
    """A basin eigenmode keeps its shape and oscillates at the scheme's exact frequency within 0.1%."""
    nx, ny, s, depth = 32, 24, 0.02, 0.1
    c = math.sqrt(GRAVITY * depth)
    dt = 0.2 * s / c
    p = pond(nx=nx, ny=ny, cell=s, depth=depth, model=model)
    shape = basin_mode(nx, ny, *mode)
    p.set_state({**p.get_state(), "h": 1e-3 * shape})
    omega = discrete_frequency(model, c, s, dt, nx, ny, *mode)
    steps = int(6 * 2 * math.pi / omega / dt)
    amp = np.empty(steps + 1)
    amp[0] = 1e-3
    for n in range(steps):
        p.advance(dt)
        amp[n + 1] = float(np.sum(p.get_state()["h"] * shape) / np.sum(shape * shape))
    residual = p.get_state()["h"] - amp[-1] * shape
    assert np.abs(residual).max() <= 1e-12
    assert measured_frequency(amp, dt) == pytest.approx(omega, rel=1e-3)


@pytest.mark.parametrize("model", ONE_SPEED)
def test_pulse_travels_at_sqrt_g_depth(model):
    """A long-wave pulse in a channel travels at c = sqrt(g d) within 2% (speed taken by default)."""
    nx, s, depth = 800, 0.01, 0.5
    c = math.sqrt(GRAVITY * depth)
    dt = 0.5 * s / c
    p = pond(nx=nx, ny=3, cell=s, depth=depth, model=model)
    x = s * np.arange(nx)
    x0 = x[nx // 2]
    h0 = 1e-3 * np.exp(-((x - x0) ** 2) / (2 * (10 * s) ** 2))
    p.set_state({**p.get_state(), "h": np.tile(h0, (3, 1))})

    def centroid() -> float:
        h = p.get_state()["h"][1]
        right = x > x0
        return float(np.sum(x[right] * h[right]) / np.sum(h[right]))

    t1_steps, t2_steps = 200, 600  # pulses separated by t1; far from the walls at t2
    for _ in range(t1_steps):
        p.advance(dt)
    x1 = centroid()
    for _ in range(t2_steps - t1_steps):
        p.advance(dt)
    speed = (centroid() - x1) / ((t2_steps - t1_steps) * dt)
    assert speed == pytest.approx(c, rel=0.02)


def test_wave_stable_step_is_the_2d_cfl_bound():
    """The explicit model reports dt_max = s / (c sqrt(2)), i.e. c dt / s <= 1/sqrt(2)."""
    p = pond(nx=16, ny=16, cell=0.01, depth=0.4)
    assert p.max_stable_step() == pytest.approx(0.01 / (math.sqrt(GRAVITY * 0.4) * math.sqrt(2)), rel=1e-14)
    q = pond(nx=16, ny=16, cell=0.01, wave_speed=2.0)
    assert q.max_stable_step() == pytest.approx(0.01 / (2.0 * math.sqrt(2)), rel=1e-14)


def test_shallow_water_has_no_step_bound():
    """The implicit model is unconditionally stable: its stable step is infinite."""
    assert pond(nx=8, ny=8, model="shallow_water").max_stable_step() == math.inf


def test_sloped_bed_bound_uses_the_deepest_faces():
    """On a sloped bed the explicit bound follows the fastest (deepest) faces."""
    p = pond(nx=40, ny=4, cell=0.01, depth=0.3, bottom_slope=(0.005, 0.0))
    c_max = p.grid.c_max
    assert 0.01 / (c_max * math.sqrt(2)) <= p.max_stable_step() <= 1.01 * 0.01 / (c_max * math.sqrt(2))


def test_sloped_bed_steps_with_single_precision_face_coefficients():
    """A sloped bed's wave step reads K / s^2 per face rounded to float32 (half the bytes) and gives
    the double-precision step to round-off: the change of h and v differs by under 1e-6 of itself."""
    p = pond(nx=30, ny=20, cell=0.01, depth=0.3, bottom_slope=(0.4, 0.1))
    model = p.model
    s2 = p.grid.cell**2
    assert model.ax.dtype == np.float32 and model.ay.dtype == np.float32
    assert np.array_equal(model.ax, (p.grid.kx / s2).astype(np.float32))
    assert np.array_equal(model.ay, (p.grid.ky / s2).astype(np.float32))
    rng = np.random.default_rng(3)
    h = p.grid.surface0 + 1e-3 * rng.standard_normal(p.grid.surface0.shape) * p.grid.wet
    v = 1e-2 * rng.standard_normal(h.shape) * p.grid.wet
    dt = 0.5 * model.max_stable_step()
    got = [np.empty_like(h), np.empty_like(h)]
    want = [np.empty_like(h), np.empty_like(h)]
    model.advance(h, v, got[0], got[1], dt)
    model.kernels.wave_faces(h, v, want[0], want[1], p.grid.kx / s2, p.grid.ky / s2, dt, 1.0)
    for new, ref, old in ((got[0], want[0], h), (got[1], want[1], v)):
        change = np.abs(ref - old).max()
        assert change > 0
        assert np.abs(new - ref).max() <= 1e-6 * change
