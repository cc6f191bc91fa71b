"""The water where its edges, its bed and its viewer window met the audit of its numerics: an absorbing
edge needs a column inside it, a tiled sloped bed counts its own rest volume, and a small field window
holds the body it follows.
"""

from __future__ import annotations

import numpy as np
import pytest

from components.messages import PatchRequest
from components.water import GaussianBump, WaterParams, WaterSurface
from components.water.diagnostics import volume
from cosim.params import build


@pytest.mark.parametrize(("nx", "ny", "side"), [(64, 2, "ny"), (2, 64, "nx"), (2, 2, "nx")])
def test_an_absorbing_edge_needs_a_column_inside_it(nx, ny, side):
    """Two columns across, each edge's one-way condition read the opposite edge, rewritten in the same
    pass: a 2 mJ bump grew to 4.5e119 J in 4 s and the run said "ok". Refused at load, naming the
    side; three columns are taken, and a reflecting basin two columns wide is too."""
    def problems(**values) -> list[str]:
        found: list[str] = []
        build(WaterParams, values, "pond", found)
        return found

    assert problems(nx=nx, ny=ny, boundary="absorbing") == [
        f"pond.{side}: must be at least 3 for an absorbing boundary, whose edges each need a column inside them "
        f"(got 2)"]
    assert problems(nx=max(nx, 3), ny=max(ny, 3), boundary="absorbing") == []
    assert problems(nx=nx, ny=ny, boundary="reflecting") == []


def test_a_sloped_bed_stepped_by_tiles_counts_its_own_rest_volume():
    """A bed sloping 1:2 under 0.3 m of water at its centre, wet everywhere, with one wave speed: it is
    stepped by tiles (its stencil is uniform), and its volume is the sum of its columns (it was one
    corner's depth times the grid: 0.1874 m^3 for 0.1229)."""
    params = WaterParams(nx=64, ny=64, cell=0.01, depth=0.3, bottom_slope=(0.5, 0.0), wave_speed=1.0,
                         initial=GaussianBump(x=0.3, y=0.3, amplitude=0.01, width=0.03))
    pond = WaterSurface("pond", params)
    assert pond.tiles is not None
    exact = volume(pond.grid, pond.get_state()["h"])
    assert pond.volume() == pytest.approx(exact, rel=1e-12)
    dt_ns = round(0.5 * pond.max_stable_step() * 1e9)
    for k in range(10):
        pond.step(k * dt_ns, dt_ns, {})
    assert pond.volume() == pytest.approx(volume(pond.grid, pond.get_state()["h"]), rel=1e-12)


@pytest.mark.parametrize("x", [0.5, 0.8, 1.1])
def test_a_small_field_window_holds_the_body_it_follows(x):
    """A 10 cm field window on 1 cm columns around a body asking for water at (x, x): the body lies in
    the window's middle half (its corner moved in steps of 32 columns, and the window sat beside the
    body, 0.635-0.735 m for a body at 0.8 m)."""
    pond = WaterSurface("pond", WaterParams(nx=200, ny=200, cell=0.01, depth=0.3, field_every=1,
                                            field_window=(0.1, 0.1)))
    request = PatchRequest(x_min=x - 0.02, x_max=x + 0.02, y_min=x - 0.02, y_max=x + 0.02)
    field = pond.step(0, 2_000_000, {"request": request})["field"]
    nj, ni = field.height.shape
    centre = np.array([field.origin_x, field.origin_y]) + 0.5 * (np.array([ni, nj]) - 1) * field.cell
    assert np.all(np.abs(centre - x) <= 0.25 * ni * field.cell)


def test_a_damping_rate_bounds_the_waters_step_instead_of_freezing_it():
    """v *= 1 - k dt is 0 at k dt = 1 and below 0 past it (clipped to 0): a damping of 500 /s on a
    2 ms water step stopped the water dead at every step, the bump standing where it was. The step
    is bounded by 0.5 / k (a stable step: refused with on_unstable error, substepped with substep),
    and a bump so damped sinks back (overdamped), losing energy."""
    bump = GaussianBump(x=0.0, y=0.0, amplitude=0.01, width=0.05)
    pond = WaterSurface("pond", WaterParams(nx=40, ny=40, cell=0.01, depth=0.1, origin_x=-0.195, origin_y=-0.195,
                                            damping=500.0, initial=bump))
    assert pond.max_stable_step() == pytest.approx(0.001)
    start, peak = pond.energy(), pond.get_state()["h"].max()
    for k in range(20):
        pond.step(k * 2_000_000, 2_000_000, {}, "substep")
    assert pond.energy() < start and pond.get_state()["h"].max() < 0.99 * peak  # sinking back, slowly
    assert np.abs(pond.get_state()["v"]).max() > 0.0  # not stopped dead


def test_a_step_over_the_dampings_bound_is_refused_naming_the_damping():
    """Refused at load, the step's bound is said to be the damping's (the line said only "exceeds its
    stable step 0.001 s", with no word of what set it)."""
    from pathlib import Path

    from cosim.errors import ScenarioError
    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "wave_pulse.yaml"
    with pytest.raises(ScenarioError) as info:
        load(scene, ["components.pond.damping=500"])
    assert info.value.problems == [
        "components.pond: step 0.002 s exceeds its stable step 0.001 s (set by its damping 500 1/s: a step of at most "
        "0.5 / damping) (on_unstable: error); lower dt or every, or set on_unstable: substep"]
