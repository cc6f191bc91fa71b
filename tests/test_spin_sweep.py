"""scenarios/sweeps/spin.yaml: the throws its description speaks of, taken from the sweep's own points
(the whole sweep, 56 throws, runs in about 50 s on 2 cores: `cosim sweep scenarios/sweeps/spin.yaml`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cosim.scenario import loads
from cosim.scheduler import Simulation
from cosim.sweep.plan import load_sweep

SWEEP = Path(__file__).resolve().parents[1] / "scenarios" / "sweeps" / "spin.yaml"


def _skips(spin: float, attack: float) -> int:
    sweep = load_sweep(SWEEP)
    point = next(p for p in sweep.points if p.values == {"spin": spin, "attack": attack})
    sim = Simulation(loads(sweep.scene_text, source=sweep.scene_source, overrides=[*sweep.fixed, *point.overrides]))
    sim.run()
    return sim.components["stages"].track.skips


@pytest.mark.parametrize(("spin", "attack", "skips"), [
    (0, 35.0, 0),   # fig. 5: without spin it dives
    (5, 35.0, 0),   # a slow spin does not save it
    (30, 35.0, 1),  # a fast one does: it bounces
    (0, 20.0, 4),   # without spin its pitch rocks back at every contact
    (10, 20.0, 1),  # spun, its lean turns, and it does not bounce again
])
def test_the_throws_the_description_names(spin, attack, skips):
    assert _skips(spin, attack) == skips
