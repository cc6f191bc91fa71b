"""scenarios/sweeps/throw.yaml: the throws its description speaks of, taken from the sweep's own points
(the whole sweep, 48 throws, runs in about 35 s on 2 cores: `cosim sweep scenarios/sweeps/throw.yaml`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cosim.scenario import loads
from cosim.scheduler import Simulation
from cosim.sweep.plan import load_sweep

SWEEP = Path(__file__).resolve().parents[1] / "scenarios" / "sweeps" / "throw.yaml"


def _skips(spin: float, attack: float) -> int:
    sweep = load_sweep(SWEEP)
    point = next(p for p in sweep.points if p.values == {"spin": spin, "attack": attack})
    sim = Simulation(loads(sweep.scene_text, source=sweep.scene_source, overrides=[*sweep.fixed, *point.overrides]))
    sim.run()
    return sim.components["stages"].track.skips


@pytest.mark.parametrize(("spin", "attack", "skips"), [
    (0, 8, 1),    # without spin, once
    (10, 8, 3),   # the scene's own throw: three times
    (14, 4, 4),   # flatter, at 14 rev/s: four times
    (65, 4, 1),   # and at 65 rev/s once: the count scatters rather than grows
])
def test_the_throws_the_description_names(spin, attack, skips):
    assert _skips(spin, attack) == skips
