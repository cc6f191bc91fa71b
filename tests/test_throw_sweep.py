"""scenarios/sweeps/throw.yaml: the throws its description speaks of, taken from the sweep's own points
(the whole sweep, 48 throws, runs in about 35 s on 2 cores: `cosim sweep scenarios/sweeps/throw.yaml`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.sweep_points import skips_at

SWEEP = Path(__file__).resolve().parents[1] / "scenarios" / "sweeps" / "throw.yaml"


@pytest.mark.parametrize(("spin", "attack", "skips"), [
    (0, 8, 1),    # without spin, once
    (10, 8, 3),   # the scene's own throw: three times
    (30, 8, 3),   # and still three times at 30 rev/s ...
    (65, 8, 3),   # ... and at 65
    (10, 4, 3),   # flatter, at 10 rev/s: three times
    (14, 4, 4),   # at 14 rev/s four times
    (65, 4, 1),   # and at 65 rev/s once: the count scatters rather than grows
])
def test_the_throws_the_description_names(spin, attack, skips):
    assert skips_at(SWEEP, spin=spin, attack=attack) == skips
