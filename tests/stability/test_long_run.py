"""Long runs with zero damping: the water's energy never grows without a source.

A small, coarse pond (1 m square) so a minute of simulated time costs seconds. The energy checked is
the one the water publishes for viewers (``WaterField.energy``, the lattice energy of
:mod:`components.water.diagnostics`), once a second.
"""

from __future__ import annotations

import numpy as np
import pytest

from components.messages import WaterField
from cosim.scenario import loads
from cosim.scheduler import BaseObserver, Simulation
from tests.stability.scenes import BOTTOM, scene

BUMP = """
name: quiet_basin
dt: 0.005
until: {until}
on_unstable: error
components:
  pond:
    type: WaterSurface
    nx: 40
    ny: 40
    cell: 0.025              # c dt / s = 0.44
    depth: 0.5
    model: {model}
    boundary: {boundary}
    damping: 0.0
    initial: {{x: 0.3, y: 0.6, amplitude: 0.01, width: 0.08}}
    field_rate: 1
connections: []
"""


class Fields(BaseObserver):
    """(time [s], energy [J], volume [m^3]) of every WaterField published."""

    def __init__(self) -> None:
        self.rows: list[tuple[float, float, float]] = []

    def on_exchange(self, time_ns, component, port, msg) -> None:
        if isinstance(msg, WaterField):
            self.rows.append((time_ns / 1e9, msg.energy, msg.volume))


def fields(sc) -> np.ndarray:
    watch = Fields()
    result = Simulation(sc, observers=[watch]).run()
    assert result.status == "ok", result.reason
    return np.array(watch.rows)


@pytest.mark.parametrize(("model", "boundary"), [("wave", "reflecting"), ("shallow_water", "reflecting"),
                                                 ("wave", "absorbing")])
def test_a_minute_of_free_waves_never_gains_energy(model, boundary):
    """A bump released in an undamped basin, 60 s (about 130 crossings): with walls the explicit model's
    energy oscillates within 6% of its start (about its exact invariant, the shadow energy) with no
    drift (the last 10 s within 2% of the first 10 s on average) and its volume is kept to 1e-12; the
    implicit model only loses energy (its numerical damping); through open edges it only leaves (any
    rise below 1e-9 of the start, round-off)."""
    rows = fields(loads(BUMP.format(until=60.0, model=model, boundary=boundary)))
    t, energy, volume = rows.T
    assert len(t) == 61 and np.isfinite(rows).all()
    if boundary == "reflecting":
        assert np.abs(volume - volume[0]).max() <= 1e-12 * volume[0]
    if model == "wave" and boundary == "reflecting":
        assert np.abs(energy / energy[0] - 1.0).max() < 0.06
        assert energy[-10:].mean() == pytest.approx(energy[:10].mean(), rel=0.02)
    else:
        assert (np.diff(energy) <= 1e-9 * energy[0]).all()
        assert energy[-1] < 0.5 * energy[0]


def coupled(until: float):
    """A lead sphere thrown into the 1 m pond (2 cm cells, water step 5 ms) with a bed to rest on."""
    return scene("dt=0.001", f"until={until}", "components.pond.nx=50", "components.pond.ny=50",
                 "components.pond.cell=0.02", "components.pond.every=5", "components.pond.damping=0.0",
                 "components.pond.field_rate=1", "components.stone.shape=sphere",
                 "components.stone.radius=0.02", "components.stone.density=11340",
                 "components.stone.position=[0.3, 0.5, 0.1]", "components.stone.velocity=[2.0, 0.0, -1.0]",
                 "components.stages.stop_after=0", text=BOTTOM)


@pytest.mark.parametrize("until", [10.0, pytest.param(60.0, marks=pytest.mark.slow)])
def test_water_left_alone_by_a_stone_at_rest_never_gains_energy(until):
    """A lead sphere thrown in sinks and rests on the bed within a second; from then on (2 s) the water,
    undamped and closed, holds its volume to 1e-9 and never exceeds 1.1 times its energy then, to the
    end of the run (10 s; 60 s in the slow run)."""
    sc = coupled(until)
    watch = Fields()
    sim = Simulation(sc, observers=[watch])
    result = sim.run()
    assert result.status == "ok", result.reason
    assert sim.components["stages"].metrics()["outcome"] == "rest"
    t, energy, volume = np.array(watch.rows).T
    assert np.isfinite(energy).all() and energy.max() > 0.0
    assert np.abs(volume - volume[0]).max() <= 1e-9 * volume[0]
    calm = t >= 2.0
    assert energy[calm].max() <= 1.1 * energy[calm][0]
