"""The compiled water kernels agree with the pure-numpy reference to round-off."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import solve_banded

from components.messages import OccupiedHeight
from components.water import GaussianBump, WaterParams, WaterSurface, kernels_numba
from components.water import kernels_numpy as ref
from components.water.models import thomas_factors

EPS = np.finfo(float).eps
# a small and a large grid (the parallel set splits the large one across threads)
SHAPES = [(7, 5), (190, 200)]
COMPILED = [kernels_numba.SERIAL, kernels_numba.PARALLEL]


@pytest.fixture(params=COMPILED, ids=["serial", "parallel"])
def nb(request):
    """Each compiled kernel set in turn."""
    return request.param


def assert_roundoff(a: np.ndarray, b: np.ndarray, ulps: float = 8) -> None:
    scale = max(float(np.abs(b).max()), 1e-300)
    assert float(np.abs(a - b).max()) <= ulps * EPS * scale


def _random(shape, seed=0):
    rng = np.random.default_rng(seed)
    return rng.standard_normal(shape), rng.standard_normal(shape)


@pytest.mark.parametrize("shape", SHAPES)
def test_wave_uniform_matches_reference(nb, shape):
    """The fused one-coefficient wave step equals the numpy step (padded-edge Laplacian)."""
    h, v = _random(shape)
    out = [np.empty(shape) for _ in range(4)]
    nb.wave_uniform(h, v, out[0], out[1], 0.3, 0.01, 0.99)
    ref.wave_uniform(h, v, out[2], out[3], 0.3, 0.01, 0.99)
    assert_roundoff(out[0], out[2])
    assert_roundoff(out[1], out[3])


@pytest.mark.parametrize("shape", SHAPES)
def test_wave_faces_matches_reference(nb, shape):
    """The per-face wave step equals the numpy step, with walls (zero faces) inside."""
    h, v = _random(shape)
    rng = np.random.default_rng(1)
    ax = rng.random((shape[0], shape[1] - 1)) * (rng.random((shape[0], shape[1] - 1)) > 0.1)
    ay = rng.random((shape[0] - 1, shape[1]))
    out = [np.empty(shape) for _ in range(4)]
    nb.wave_faces(h, v, out[0], out[1], ax, ay, 0.01, 1.0)
    ref.wave_faces(h, v, out[2], out[3], ax, ay, 0.01, 1.0)
    assert_roundoff(out[0], out[2])
    assert_roundoff(out[1], out[3])


def test_uniform_and_face_kernels_agree():
    """With every face at c^2/s^2 the per-face step reproduces the one-coefficient step."""
    h, v = _random((9, 11))
    a = 2.5
    out = [np.empty(h.shape) for _ in range(4)]
    ref.wave_uniform(h, v, out[0], out[1], 0.01 * a, 0.01, 1.0)
    ref.wave_faces(h, v, out[2], out[3], np.full((9, 10), a), np.full((8, 11), a), 0.01, 1.0)
    assert_roundoff(out[0], out[2], ulps=64)
    assert_roundoff(out[1], out[3], ulps=64)


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("shared", [False, True])
def test_adi_sweeps_match_reference(nb, shape, shared):
    """Both Kass-Miller sweeps (per-line or shared factors) equal the numpy sweeps."""
    h, v = _random(shape)
    rng = np.random.default_rng(2)
    ny, nx = shape
    ax = rng.random((1 if shared else ny, nx - 1)) * 100
    ay = rng.random((ny - 1, 1 if shared else nx)) * 100
    fx = thomas_factors(ax, 0.05)
    fy = tuple(np.ascontiguousarray(f.T) for f in thomas_factors(np.ascontiguousarray(ay.T), 0.05))
    outs, vs = [np.empty(shape), np.empty(shape)], [np.empty(shape), np.empty(shape)]
    for k, kern in enumerate((nb, ref)):
        kern.adi_x(h, v, 0.05, outs[k], *fx)
        kern.adi_y(h, 0.05, 0.9, outs[k], vs[k], *fy)
    assert_roundoff(outs[0], outs[1])
    assert_roundoff(vs[0], vs[1])


def test_thomas_factors_solve_the_kass_miller_system():
    """The factored sweep solves A x = d with A = I - dt^2 D (the e_i, f_i of physics.md)."""
    rng = np.random.default_rng(3)
    n, dt = 12, 0.02
    a = rng.random((1, n - 1)) * 500
    f = -(dt**2) * a[0]
    diag = np.ones(n)
    diag[:-1] -= f
    diag[1:] -= f
    banded = np.zeros((3, n))
    banded[0, 1:] = f
    banded[1] = diag
    banded[2, :-1] = f
    d = rng.standard_normal((1, n))
    x = np.empty((1, n))
    ref.adi_x(d, np.zeros((1, n)), dt, x, *thomas_factors(a, dt))
    assert np.allclose(x[0], solve_banded((1, 1), banded, d[0]), rtol=1e-13, atol=1e-13)
    assert abs(x.sum() - d.sum()) <= 1e-13 * np.abs(d).sum()  # unit column sums keep the volume


@pytest.mark.parametrize("shape", SHAPES)
def test_smoothing_sponge_and_one_way_match_reference(nb, shape):
    """Smoothing, the sponge layer and the one-way edge condition equal their numpy twins."""
    h, v = _random(shape)
    h_old, _ = _random(shape, seed=5)
    ny, nx = shape
    rng = np.random.default_rng(4)
    wx = (rng.random((ny, nx - 1)) > 0.2).astype(float)
    wy = (rng.random((ny - 1, nx)) > 0.2).astype(float)
    s1, s2 = np.empty(shape), np.empty(shape)
    nb.smooth(h, s1, wx, wy, 0.4)
    ref.smooth(h, s2, wx, wy, 0.4)
    assert_roundoff(s1, s2)
    width = 2
    sx = np.r_[[5.0, 1.0], np.zeros(nx - 4), [1.0, 5.0]]
    sy = np.r_[[5.0, 1.0], np.zeros(ny - 4), [1.0, 5.0]]
    pairs = [(h.copy(), v.copy()), (h.copy(), v.copy())]
    nb.sponge(*pairs[0], sx, sy, width, 0.01)
    ref.sponge(*pairs[1], sx, sy, width, 0.01)
    assert_roundoff(pairs[0][0], pairs[1][0])
    assert_roundoff(pairs[0][1], pairs[1][1])
    coefs = [rng.uniform(-0.9, 0.9, n) for n in (ny, ny, nx, nx)]
    opens = [rng.random(n) > 0.3 for n in (ny, ny, nx, nx)]
    pairs = [(h.copy(), v.copy()), (h.copy(), v.copy())]
    nb.one_way(h_old, *pairs[0], *coefs, *opens, 0.01)
    ref.one_way(h_old, *pairs[1], *coefs, *opens, 0.01)
    assert_roundoff(pairs[0][0], pairs[1][0])
    assert_roundoff(pairs[0][1], pairs[1][1])


CONFIGS = [
    dict(model="wave"),
    dict(model="wave", boundary="absorbing", sponge_cells=4, bottom_slope=(0.3, 0.1), smoothing=3.0),
    dict(model="wave", bottom_slope=(0.3, 0.1), smoothing=3.0),  # smoothing by weights: a beach
    dict(model="wave", smoothing=3.0, displacement_smoothing=3),
    dict(model="shallow_water", damping=0.5),
    dict(model="shallow_water", boundary="absorbing", bottom_slope=(0.3, 0.0), displacement_smoothing=2),
]


@pytest.mark.parametrize("n", [24, 190])
@pytest.mark.parametrize("config", CONFIGS, ids=lambda c: "-".join(f"{k}={v}" for k, v in c.items()))
def test_component_runs_agree_across_kernels(n, config):
    """A whole run (displacement, model, boundary, smoothing) is the same with every kernel set. The
    serial kernels step a grid this large by tiles; only exact zeros rest there (``rest_below`` 0),
    so that they are the dense kernels' bits (tests/test_water_tiles.py holds the default)."""
    runs = {}
    for backend, parallel in (("numba", False), ("numba", True), ("numpy", False)):
        pond = WaterSurface("pond", WaterParams(
            nx=n, ny=n - 3, cell=0.01, depth=0.2, backend=backend, parallel=parallel, rest_below=0.0,
            initial=GaussianBump(x=0.08, y=0.1, amplitude=0.01, width=0.03), **config))
        dt_ns = round(0.6 * min(pond.max_stable_step(), 0.004) * 1e9)
        for k in range(60):
            b = np.full((3, 4), 1e-4 * k)
            body = OccupiedHeight(i0=4 + k % 3, j0=5, b=b)
            pond.step(k * dt_ns, dt_ns, {"occupied": body, "request": None})
        runs[backend, parallel] = pond.get_state()
    serial, threads, reference = runs.values()
    assert np.array_equal(serial["h"], threads["h"]) and np.array_equal(serial["v"], threads["v"])
    assert_roundoff(serial["h"], reference["h"], ulps=64)
    assert_roundoff(serial["v"], reference["v"], ulps=64)


def _straight_faces(h, v, ax, ay, dt, damp):
    """The per-face wave step written cell by cell, the plainest way (the rule, not a kernel)."""
    ny, nx = h.shape
    h_out, v_out = np.empty_like(h), np.empty_like(v)
    for j in range(ny):
        for i in range(nx):
            acc = 0.0
            if i > 0:
                acc += ax[j, i - 1] * (h[j, i - 1] - h[j, i])
            if i < nx - 1:
                acc += ax[j, i] * (h[j, i + 1] - h[j, i])
            if j > 0:
                acc += ay[j - 1, i] * (h[j - 1, i] - h[j, i])
            if j < ny - 1:
                acc += ay[j, i] * (h[j + 1, i] - h[j, i])
            v_out[j, i] = (v[j, i] + dt * acc) * damp
            h_out[j, i] = h[j, i] + dt * v_out[j, i]
    return h_out, v_out


@pytest.mark.parametrize("shape", [(2, 2), (3, 2), (2, 5), (6, 9)])
def test_face_kernel_equals_the_cell_by_cell_rule(nb, shape):
    """The row-wise face kernel (interior without branches, edges apart) gives the bits of the
    cell-by-cell rule, on grids down to 2 x 2 where every cell is an edge cell."""
    h, v = _random(shape)
    rng = np.random.default_rng(7)
    ax = rng.random((shape[0], shape[1] - 1)) * (rng.random((shape[0], shape[1] - 1)) > 0.2)
    ay = rng.random((shape[0] - 1, shape[1]))
    h_out, v_out = np.empty(shape), np.empty(shape)
    nb.wave_faces(h, v, h_out, v_out, ax, ay, 0.01, 0.97)
    want_h, want_v = _straight_faces(h, v, ax, ay, 0.01, 0.97)
    assert np.array_equal(h_out, want_h) and np.array_equal(v_out, want_v)


@pytest.mark.parametrize("shape", SHAPES)
def test_open_smoothing_equals_unit_weights(nb, shape):
    """Smoothing with every face open gives the bits of the weighted smoothing with weights 1."""
    h, _ = _random(shape)
    ny, nx = shape
    a, b, c = np.empty(shape), np.empty(shape), np.empty(shape)
    nb.smooth_open(h, a, 0.3)
    nb.smooth(h, b, np.ones((ny, nx - 1), np.uint8), np.ones((ny - 1, nx), np.uint8), 0.3)
    ref.smooth_open(h, c, 0.3)
    assert np.array_equal(a, b)
    assert_roundoff(a, c)


@pytest.mark.parametrize("shape", [(1, 1), (1, 4), (5, 1), (6, 7)])
@pytest.mark.parametrize("passes", [1, 2, 3])
def test_blur_matches_reference_and_keeps_the_sum(shape, passes):
    """The compiled displacement blur equals the numpy passes and keeps the displaced volume."""
    rng = np.random.default_rng(9)
    d = rng.standard_normal(shape)
    a, b = d.copy(), d.copy()
    kernels_numba.SERIAL.blur(a, np.empty_like(a), passes, 0.125)
    ref.blur(b, np.empty_like(b), passes, 0.125)
    assert np.array_equal(a, b)
    assert abs(a.sum() - d.sum()) <= 64 * EPS * np.abs(d).sum()


@pytest.mark.parametrize("ny", [1, 2, 3, 4, 5, 8, 9])
@pytest.mark.parametrize("shared", [False, True])
def test_adi_sweeps_in_groups_of_rows_equal_the_line_by_line_rule(nb, ny, shared):
    """The row sweep (four rows side by side, the rest one by one) and the column sweep (its
    velocity written during the backward pass) give the bits of the numpy sweeps, line by line."""
    shape = (ny, 6)
    h, v = _random(shape, seed=ny)
    rng = np.random.default_rng(10 + ny)
    ax = rng.random((1 if shared else ny, 5)) * 100
    fx = thomas_factors(ax, 0.05)
    outs = [np.empty(shape), np.empty(shape)]
    nb.adi_x(h, v, 0.05, outs[0], *fx)
    ref.adi_x(h, v, 0.05, outs[1], *fx)
    assert np.array_equal(outs[0], outs[1])
    if ny > 1:
        ay = rng.random((ny - 1, 1 if shared else 6)) * 100
        fy = tuple(np.ascontiguousarray(f.T) for f in thomas_factors(np.ascontiguousarray(ay.T), 0.05))
        vs = [np.empty(shape), np.empty(shape)]
        nb.adi_y(h, 0.05, 0.9, outs[0], vs[0], *fy)
        ref.adi_y(h, 0.05, 0.9, outs[1], vs[1], *fy)
        assert np.array_equal(outs[0], outs[1]) and np.array_equal(vs[0], vs[1])
