"""Volume conservation with reflecting walls, with and without displacement by bodies."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from components.messages import OccupiedHeight
from components.water import GaussianBump, WaterParams, WaterSurface
from components.water.models import MODELS

STEPS = 10_000


def pond(**kw) -> WaterSurface:
    defaults = dict(nx=48, ny=40, cell=0.01, depth=0.3,
                    initial=GaussianBump(x=0.2, y=0.15, amplitude=0.02, width=0.03))
    return WaterSurface("pond", WaterParams(**{**defaults, **kw}))


def dt_ns_of(p: WaterSurface) -> int:
    return round(0.7 * min(p.max_stable_step(), 0.01) * 1e9)


def moving_body(k: int) -> OccupiedHeight:
    """A body sliding across the pond and bobbing: a 5 x 6 occupied patch whose window moves."""
    b = np.full((5, 6), 0.004 * (1.0 + math.sin(0.01 * k)))
    b[0, :] = 0.001
    return OccupiedHeight(i0=5 + (k // 40) % 30, j0=8 + (k // 97) % 20, b=b)


@pytest.mark.parametrize("model", list(MODELS))
def test_volume_is_conserved_over_10000_steps(model):
    """With reflecting walls the water volume stays constant to 1e-12 (relative) over 10,000 steps."""
    p = pond(model=model)
    v0 = p.volume()
    dt_ns = dt_ns_of(p)
    for k in range(STEPS):
        p.step(k * dt_ns, dt_ns, {})
    assert abs(p.volume() - v0) <= 1e-12 * v0


@pytest.mark.parametrize("model", list(MODELS))
def test_volume_is_conserved_with_displacement_input(model):
    """A moving body's displacement (h += b - b_prev) keeps the water volume to 1e-12 over 10,000 steps."""
    p = pond(model=model, displacement_smoothing=1)
    v0 = p.volume()
    h0 = float(np.sum(p.get_state()["h"]))
    dt_ns = dt_ns_of(p)
    for k in range(STEPS):
        p.step(k * dt_ns, dt_ns, {"occupied": moving_body(k)})
    assert abs(p.volume() - v0) <= 1e-12 * v0
    # the body has left: the sum of the surface heights is back where it started
    p.step(STEPS * dt_ns, dt_ns, {"occupied": OccupiedHeight(i0=0, j0=0, b=np.zeros((0, 0)))})
    assert abs(p.volume() - v0) <= 1e-12 * v0
    assert float(np.sum(p.get_state()["h"])) == pytest.approx(h0, abs=1e-12 * v0 / p.grid.cell**2)


def test_displacement_raises_the_surface_by_the_occupied_volume():
    """Entering the water, a body raises the summed surface by exactly its occupied volume."""
    p = pond(initial=None, displacement_smoothing=3)
    b = np.full((4, 4), 0.01)
    dt_ns = dt_ns_of(p)
    p.step(0, dt_ns, {"occupied": OccupiedHeight(i0=10, j0=10, b=b)})
    assert float(np.sum(p.get_state()["h"])) == pytest.approx(float(b.sum()), rel=1e-13)
    assert p.volume() == pytest.approx(p.initial_volume, rel=1e-15)


def test_volume_is_conserved_over_a_sloped_bed_with_dry_cells():
    """A sloped bed with a dry shore also keeps the volume (dry cells are walls); airy water, whose
    modes are a flat bed's, refuses it (tests/test_airy_water.py)."""
    for model in (m for m in MODELS if m != "airy"):
        p = pond(model=model, bottom_slope=(0.5, 0.0), depth=0.05,
                 initial=GaussianBump(x=0.1, y=0.2, amplitude=0.01, width=0.03))
        assert not p.grid.wet.all()
        v0 = p.volume()
        dt_ns = dt_ns_of(p)
        for k in range(2000):
            p.step(k * dt_ns, dt_ns, {"occupied": moving_body(k)})
        assert abs(p.volume() - v0) <= 1e-12 * v0
        assert np.all(p.get_state()["h"][~p.grid.wet] == 0.0)  # nothing flows onto dry land


@pytest.mark.parametrize("model", [m for m in MODELS if m != "airy"])
def test_a_blurred_displacement_at_a_shore_stays_in_the_water(model):
    """A body on the last three wet columns before a shore, its displacement blurred over two
    passes: none of the water it pushes aside goes onto dry land, where it sat frozen (7% of it,
    0.41 mm over the bed), and the surface rises by exactly what the body displaces, the water's
    own volume unchanged."""
    p = pond(model=model, nx=60, ny=30, depth=0.05, bottom_slope=(0.2, 0.0), displacement_smoothing=2,
             initial=None)
    shore = int(np.argmax(~p.grid.wet[0]))  # the first dry column
    b = np.full((4, 3), 0.002)
    v0 = p.volume()
    p.step(0, dt_ns_of(p), {"occupied": OccupiedHeight(i0=shore - 3, j0=10, b=b)})
    h = p.get_state()["h"]
    assert np.all(h[~p.grid.wet] == 0.0)
    assert h.sum() == pytest.approx(b.sum(), rel=1e-12)
    assert p.volume() == pytest.approx(v0, rel=1e-15)


def test_smoothing_and_damping_keep_the_volume():
    """Positional smoothing and velocity damping change the waves, never the volume."""
    p = pond(smoothing=20.0, damping=2.0)
    v0 = p.volume()
    dt_ns = dt_ns_of(p)
    for k in range(2000):
        p.step(k * dt_ns, dt_ns, {})
    assert abs(p.volume() - v0) <= 1e-12 * v0
    assert p.energy() < 1e-3 * pond().energy()


window = st.tuples(st.integers(-6, 30), st.integers(-6, 26), st.integers(0, 7), st.integers(0, 7),
                   st.floats(0.0, 0.02))


@settings(max_examples=60, deadline=None)
@given(windows=st.lists(window, min_size=1, max_size=12), passes=st.integers(0, 2),
       model=st.sampled_from(list(MODELS)))
def test_any_sequence_of_occupied_windows_keeps_the_volume(windows, passes, model):
    """Whatever windows bodies occupy (moving, resizing, partly off the grid), the volume is kept."""
    p = WaterSurface("pond", WaterParams(nx=24, ny=20, cell=0.01, depth=0.1, model=model,
                                         displacement_smoothing=passes))
    v0 = p.volume()
    dt_ns = dt_ns_of(p)
    rng = np.random.default_rng(len(windows))
    for k, (i0, j0, ni, nj, top) in enumerate(windows):
        b = top * rng.random((nj, ni))
        p.step(k * dt_ns, dt_ns, {"occupied": OccupiedHeight(i0=i0, j0=j0, b=b)})
        assert abs(p.volume() - v0) <= 1e-12 * v0
