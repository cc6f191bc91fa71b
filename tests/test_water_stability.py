"""Stability of the water: bounded energy without damping, the CFL guard, substeps, implicit steps."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from components.messages import OccupiedHeight, PatchRequest
from components.water import GaussianBump, WaterParams, WaterSurface
from components.water.diagnostics import shadow_energy
from components.water.grid import GRAVITY
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


def test_the_airy_model_with_absorbing_edges_is_stable_up_to_its_bound_and_refused_above():
    """Airy water between absorbing edges steps its modes exactly, but the edge's one-way condition
    cannot follow a mode that turns by about half a turn a step: its bound is 0.9 pi / w_max (29.7 ms
    on 1 cm cells here); noise in every mode at the bound drains away, at 1.2 times it grows without
    bound (a 40 ms step took a pulse's 3.85 mJ to 1e31 J and the run said ok); such a step is
    refused, the cause named. Between walls every step is stable."""
    assert math.isinf(pond(model="airy").max_stable_step())
    bound = pond(model="airy", boundary="absorbing").max_stable_step()
    assert bound == pytest.approx(0.9 * math.pi / pond(model="airy").model.omega.max(), rel=1e-12)
    for factor, drains in ((1.0, True), (1.2, False)):
        p = noisy(pond(model="airy", boundary="absorbing"))
        e0 = p.energy()
        for _ in range(5000):
            p.advance(factor * bound)
        assert (p.energy() < 1e-3 * e0) if drains else (p.energy() > 1e6 * e0)
    p = pond(model="airy", boundary="absorbing")
    with pytest.raises(SimulationError, match=r"exceeds the stable step"):
        p.step(0, math.ceil(1.01 * bound * NS), {}, on_unstable="error")
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
