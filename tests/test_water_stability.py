"""Stability of the water: bounded energy without damping, the CFL guard, substeps, implicit steps."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from components.messages import OccupiedHeight, PatchRequest
from components.water import GaussianBump, WaterParams, WaterSurface
from components.water.diagnostics import shadow_energy
from components.water.grid import GRAVITY, SURFACE_TENSION, WATER_DENSITY
from cosim.errors import SimulationError

DEPTH, CELL = 0.3, 0.01
C = math.sqrt(GRAVITY * DEPTH)
NS = 1_000_000_000


def pond(**kw) -> WaterSurface:
    return WaterSurface("pond", WaterParams(**{"nx": 16, "ny": 12, "cell": CELL, "depth": DEPTH, **kw}))


def noisy(p: WaterSurface, seed: int = 0) -> WaterSurface:
    """Fill h and v with white noise: every mode of the grid, up to the checkerboard, is excited.

    The mean of v is removed: in a closed basin the total vertical velocity is the rate of change
    of the volume, so it must be zero.
    """
    rng = np.random.default_rng(seed)
    shape = p.grid.shape
    v = 1e-3 * rng.standard_normal(shape)
    p.set_state({**p.get_state(), "h": 1e-3 * rng.standard_normal(shape), "v": v - v.mean(), "model": None})
    return p


def test_undamped_energy_is_bounded_over_100000_steps():
    """At c dt / s = 0.7 the explicit step conserves its shadow energy to round-off over 100,000 steps,
    and that invariant bounds the lattice energy: E <= E~ / (1 - sqrt(2) c dt / s)."""
    cfl = 0.7
    dt = cfl * CELL / C
    p = noisy(pond())
    s0 = shadow_energy(p.grid, p._h, p._v, dt)
    bound = s0 / (1 - math.sqrt(2) * cfl)
    worst_drift = peak = 0.0
    for k in range(100_000):
        p.advance(dt)
        if k % 500 == 0:
            worst_drift = max(worst_drift, abs(shadow_energy(p.grid, p._h, p._v, dt) / s0 - 1))
            peak = max(peak, p.energy())
    assert worst_drift < 1e-12
    assert peak <= bound


def test_undamped_smooth_wave_keeps_its_energy():
    """A smooth bump sloshing for 100,000 steps at c dt / s = 0.7 keeps its energy within 25%, no trend."""
    dt = 0.7 * CELL / C
    p = pond(initial=GaussianBump(x=0.05, y=0.05, amplitude=1e-3, width=0.02))
    e0 = p.energy()
    energies = []
    for k in range(100_000):
        p.advance(dt)
        if k % 250 == 0:
            energies.append(p.energy() / e0)
    energies = np.array(energies)
    assert 0.75 < energies.min() and energies.max() < 1.25
    assert abs(energies[-40:].mean() - energies[:40].mean()) < 0.05


@pytest.mark.parametrize("boundary", ["reflecting", "absorbing"])
@pytest.mark.parametrize("cfl", [5.0, 50.0])
def test_implicit_model_is_stable_at_any_step(boundary, cfl):
    """Kass-Miller at c dt / s of 5 and 50: the energy never exceeds its start and dies out."""
    dt = cfl * CELL / C
    p = noisy(pond(model="shallow_water", boundary=boundary))
    e0 = p.energy()
    peak = 0.0
    for _ in range(5000):
        p.advance(dt)
        peak = max(peak, p.energy())
    assert peak <= e0
    assert p.energy() < 1e-12 * e0


# (cell [m], depth [m]) of airy water between absorbing edges: centimetre cells on deep water, where
# 0.9 pi / w_max held; millimetre cells, whose fastest mode capillarity sets; shallow water. In the
# last two the edge's c dt / s is about 1 at 0.9 pi / w_max and the water grew there.
AIRY_REGIMES = [(0.01, 0.3), (0.001, 0.05), (0.05, 0.02)]


def step_matrix(p: WaterSurface, dt: float) -> np.ndarray:
    """The step of ``dt`` [s] as a matrix on the state (h, v) flattened, (2n, 2n): the model's step
    and the edges' rewrite are linear, so column j is the step of the j-th unit state."""
    n = p.grid.nx * p.grid.ny
    start = p.get_state()
    columns = []
    for j in range(2 * n):
        unit = np.zeros(2 * n)
        unit[j] = 1.0
        p.set_state({**start, "h": unit[:n].reshape(p.grid.shape), "v": unit[n:].reshape(p.grid.shape)})
        p.advance(dt)
        state = p.get_state()
        columns.append(np.concatenate([state["h"].ravel(), state["v"].ravel()]))
    p.set_state(start)
    return np.array(columns).T


@pytest.mark.parametrize("sponge", [0, 2])
@pytest.mark.parametrize(("cell", "depth"), AIRY_REGIMES)
def test_airy_water_between_absorbing_edges_grows_at_no_step_up_to_its_bound(cell, depth, sponge):
    """The step is linear, so the water stays bounded at a step exactly when the step's matrix has
    no eigenvalue outside the unit circle. On a 10 x 8 pond it has none at half, 0.8 times and at
    the bound; at 0.9 pi / w_max (the old bound) one grew 4.4% a step on 1 mm cells 5 cm deep and
    3% on 5 cm cells 2 cm deep."""
    p = pond(nx=10, ny=8, cell=cell, depth=depth, model="airy", boundary="absorbing", sponge_cells=sponge)
    bound = p.max_stable_step()
    for factor in (0.5, 0.8, 1.0):
        growth = float(np.abs(np.linalg.eigvals(step_matrix(p, factor * bound))).max())
        assert growth <= 1.0 + 1e-9, f"{factor} x the bound: {growth - 1:.2g} a step"


@pytest.mark.parametrize(("cell", "depth"), AIRY_REGIMES)
def test_airy_water_between_absorbing_edges_drains_at_its_bound(cell, depth):
    """White noise in every mode, stepped 3000 times at the bound, drains away through the edges in
    every regime (at 0.9 pi / w_max it grew a million-fold on 1 mm cells 5 cm deep and on 5 cm cells
    2 cm deep, and a run said ok). The edges' first rewrites of the noise (v = the change of h over
    a step) give the long modes up to 3.5 times its energy before it leaves."""
    p = noisy(pond(cell=cell, depth=depth, model="airy", boundary="absorbing"))
    dt, e0 = p.max_stable_step(), p.energy()
    peak = 0.0
    for k in range(3000):
        p.advance(dt)
        if k % 100 == 0:
            peak = max(peak, p.energy())
    assert peak < 5.0 * e0 and p.energy() < 1e-3 * e0


def test_the_airy_model_with_absorbing_edges_is_stable_up_to_its_bound_and_refused_above():
    """Airy water between absorbing edges steps its modes exactly, but the edges' one-way rewrite
    feeds the short modes at a step too long for them: the bound is the shorter of 0.9 pi / w_max
    and the step at which c dt / s reaches 1.5 (w dt / pi)^2 tan(w dt / 2), w the frequency of the
    grid's checkerboard (25.8 ms on 1 cm cells 0.3 m deep here, 0.66 ms on 1 mm cells 5 cm deep);
    1.5 times it grows without bound (a 40 ms step on 1 cm cells took a pulse's 3.85 mJ to 1e31 J
    and the run said ok); such a step is refused, the cause named. Between walls every step is
    stable."""
    assert math.isinf(pond(model="airy").max_stable_step())
    for cell, depth in AIRY_REGIMES:
        p = pond(cell=cell, depth=depth, model="airy", boundary="absorbing")
        bound = p.max_stable_step()
        k = math.sqrt(2) * math.pi / cell  # the checkerboard's wavenumber [1/m]
        w = math.sqrt((GRAVITY * k + SURFACE_TENSION * k**3 / WATER_DENSITY) * math.tanh(k * depth))
        c_dt_s = math.sqrt(GRAVITY * depth) * bound / cell
        need = 1.5 * (w * bound / math.pi) ** 2 * math.tan(w * bound / 2)
        assert c_dt_s == pytest.approx(need, rel=1e-9)  # here the edge, not the turn, sets it
        assert bound < 0.9 * math.pi / p.model.omega.max()
        e0 = noisy(p).energy()
        for _ in range(2000):
            p.advance(1.5 * bound)
        assert p.energy() > 1e6 * e0
    assert pond(model="airy", boundary="absorbing").max_stable_step() == pytest.approx(0.02578, abs=1e-5)
    lake = pond(cell=0.05, depth=10.0, model="airy", boundary="absorbing")  # c dt / s is 19 at 0.9 pi / w_max
    assert lake.max_stable_step() == 0.9 * math.pi / lake.model.omega.max()
    assert "half a turn" in lake.stable_step_cause()
    p = pond(model="airy", boundary="absorbing")
    with pytest.raises(SimulationError, match=r"exceeds the stable step"):
        p.step(0, math.ceil(1.01 * p.max_stable_step() * NS), {}, on_unstable="error")
    assert "absorbing edges" in p.stable_step_cause() and not pond(model="airy").stable_step_cause()


def test_absorbing_edges_keep_the_explicit_model_stable():
    """One-way edges (and a sponge) add no step limit: noise at c dt / s = 0.7 drains away."""
    dt = 0.7 * CELL / C
    for sponge in (0, 3):
        p = noisy(pond(boundary="absorbing", sponge_cells=sponge))
        e0 = p.energy()
        for _ in range(20_000):
            p.advance(dt)
        assert p.energy() < 1e-12 * e0


def test_step_above_the_stability_bound_is_refused():
    """With on_unstable: error a step above c dt / s = 1/sqrt(2) fails, naming bound and step."""
    p = pond()
    bound = p.max_stable_step()
    dt_ns = math.ceil(bound * 1.01 * NS)
    with pytest.raises(SimulationError, match=r"component 'pond' failed.*exceeds the stable step"):
        p.step(0, dt_ns, {}, on_unstable="error")


def test_a_step_a_nanosecond_over_the_bound_is_refused_in_numbers_that_differ():
    """A step 1 ns over the bound is refused with the step and the bound told apart, the bound
    rounded down: six digits said "step 0.00412183 s exceeds the stable step 0.00412183 s"."""
    p = pond()
    bound = p.max_stable_step()
    dt_ns = math.floor(bound * NS) + 1
    with pytest.raises(SimulationError) as failure:
        p.step(0, dt_ns, {}, on_unstable="error")
    said = re.search(r"step (\S+) s exceeds the stable step (\S+) s", str(failure.value))
    assert said is not None, str(failure.value)
    assert said[1] != said[2] and float(said[2]) <= bound


def test_step_at_the_stability_bound_is_accepted_and_stable():
    """A step right at the bound (c dt / s = 1/sqrt(2)) is taken, and stays bounded: the lattice
    energy of the noise swings up to 7.5 times its start there over 20,000 steps, without drifting
    (1.02 times the bound blows up)."""
    p = noisy(pond())
    dt_ns = math.floor(p.max_stable_step() * NS)
    e0 = p.energy()
    most = 0.0
    for k in range(20_000):
        p.step(k * dt_ns, dt_ns, {}, on_unstable="error")
        most = max(most, p.energy())
    assert most < 20.0 * e0
    assert np.isfinite(p.get_state()["h"]).all()


def test_step_above_the_bound_is_substepped():
    """With on_unstable: substep a long step becomes equal stable substeps, inputs applied once."""
    body = OccupiedHeight(i0=3, j0=4, b=np.full((2, 3), 1e-3))
    request = PatchRequest(0.02, 0.05, 0.03, 0.06)
    p = pond(initial=GaussianBump(x=0.08, y=0.06, amplitude=1e-3, width=0.02))
    q = pond(initial=GaussianBump(x=0.08, y=0.06, amplitude=1e-3, width=0.02))
    dt_ns = math.ceil(p.max_stable_step() * 2.5 * NS)
    out = p.step(0, dt_ns, {"occupied": body, "request": request}, on_unstable="substep")
    assert p.last_substeps == 3
    q.apply_occupied(body)
    for _ in range(3):
        q.advance(dt_ns / NS / 3)
    assert np.array_equal(p.get_state()["h"], q.get_state()["h"])
    assert np.array_equal(p.get_state()["v"], q.get_state()["v"])
    assert np.array_equal(out["patch"].height, q.patch(request).height)
