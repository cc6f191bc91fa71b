"""The explicit water exactly at its stability bound, c dt / s = 1/sqrt(2), and just above it.

The bound is the water's own ``max_stable_step`` (Gershgorin on its 5-point operator): the wave speed
is chosen so that the water's step of 2 ms is that bound to the last bit. At the bound the scheme is
still stable (its highest mode, the checkerboard, is neutral), so a run must go through with
``on_unstable: error`` and stay bounded; a wave speed 0.1% higher must be refused at load time.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from components.water import WaterParams, WaterSurface
from cosim.errors import ScenarioError
from cosim.scenario import loads
from cosim.scheduler import BaseObserver, Simulation
from tests.stability.scenes import (
    assert_finite,
    assert_stone_never_gains_energy,
    assert_volume_kept,
    assert_water_energy_not_growing,
    run,
    scene,
)

CELL = 0.01  # [m]
STEP = 0.002  # the water's step [s]


def speed_at_bound(cell: float = CELL, step: float = STEP) -> float:
    """The largest wave speed [m/s] whose stable step is at least ``step``: c dt / s = 1/sqrt(2)."""
    c = cell / (math.sqrt(2.0) * step)
    while WaterSurface("probe", WaterParams(nx=4, ny=4, cell=cell, wave_speed=c)).max_stable_step() < step:
        c = math.nextafter(c, 0.0)
    return c


BASIN = """
name: cfl_bound
dt: {step!r}
until: 20.0
on_unstable: error
components:
  pond:
    type: WaterSurface
    nx: 60
    ny: 60
    cell: {cell!r}
    depth: 0.5
    wave_speed: {speed!r}
    boundary: reflecting
    initial: {{x: 0.2, y: 0.3, amplitude: 0.01, width: 0.04}}
connections: []
"""


class Energy(BaseObserver):
    """The pond's lattice energy every 100 steps."""

    def __init__(self) -> None:
        self.values: list[float] = []

    def on_step_complete(self, sim) -> None:
        if sim.tick % 100 == 0:
            self.values.append(sim.components["pond"].energy())


def test_the_bound_is_exactly_one_over_root_two():
    """The chosen speed puts c dt / s at 1/sqrt(2) to round-off and the stable step at 2 ms exactly."""
    c = speed_at_bound()
    assert c * STEP / CELL == pytest.approx(1.0 / math.sqrt(2.0), rel=1e-15)
    assert WaterSurface("p", WaterParams(nx=4, ny=4, cell=CELL, wave_speed=c)).max_stable_step() == STEP


def test_a_basin_at_the_bound_runs_10000_steps_and_stays_bounded():
    """A Gaussian bump in a closed basin at exactly the bound, with on_unstable: error, runs 20 s
    (10000 steps): the lattice energy stays within 5% of its start (it oscillates about the scheme's
    invariant), the volume to 1e-12 and the surface below the bump's height."""
    sc = loads(BASIN.format(step=STEP, cell=CELL, speed=speed_at_bound()))
    energy = Energy()
    sim = Simulation(sc, observers=[energy])
    pond = sim.components["pond"]
    e0, v0 = pond.energy(), pond.volume()
    assert sim.run().status == "ok"
    assert np.isfinite(pond.height).all()
    assert 0.95 * e0 < min(energy.values) and max(energy.values) < 1.05 * e0
    assert abs(pond.volume() - v0) <= 1e-12 * v0
    assert np.abs(pond.height).max() < 0.01


def test_a_stone_dropped_into_water_at_the_bound_runs_and_stays_bounded():
    """The pond stepping at exactly its bound (on_unstable: error for the water) takes a slate disk
    dropped flat at 3 m/s: the run goes through, the stone sinks, the volume is kept to 1e-9 and the
    water's energy does not grow once the splash is made (0.2 s on)."""
    r = run(scene(f"components.pond.wave_speed={speed_at_bound()!r}", "components.pond.on_unstable=error",
                  "components.stone.tilt_deg=0", "components.stone.position=[1.5, 0.5, 0.1]",
                  "components.stone.velocity=[0, 0, -3]", "components.stages.stop_after=0", "until=1.0"))
    assert r.result.status == "ok"
    assert_finite(r)
    assert_volume_kept(r)
    assert_stone_never_gains_energy(r)
    assert_water_energy_not_growing(r, after=0.2, factor=1.1)
    assert r.metrics["outcome"] == "sink"


def test_just_above_the_bound_is_refused_at_load_time():
    """A wave speed 0.1% above the bound (c dt / s = 0.7078) is refused before anything runs, with a
    message naming the component, its step and its stable step."""
    text = BASIN.format(step=STEP, cell=CELL, speed=speed_at_bound() * 1.001)
    with pytest.raises(ScenarioError, match=r"components\.pond: step 0\.002 s exceeds its stable step "
                                            r"0\.001998\d* s \(on_unstable: error\)"):
        loads(text)
