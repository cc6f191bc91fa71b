"""scenarios/sweeps/spin.yaml: the throws its description speaks of, taken from the sweep's own points
(the whole sweep, 56 throws, runs in about 50 s on 2 cores: `cosim sweep scenarios/sweeps/spin.yaml`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.sweep_points import skips_at

SWEEP = Path(__file__).resolve().parents[1] / "scenarios" / "sweeps" / "spin.yaml"


@pytest.mark.parametrize(("spin", "attack", "skips"), [
    (0, 35.0, 0),   # fig. 5: without spin it dives
    (5, 35.0, 0),   # a slow spin does not save it
    (30, 35.0, 1),  # a fast one does: it bounces
    (0, 20.0, 4),   # without spin its pitch rocks back at every contact
    (10, 20.0, 1),  # spun, its lean turns, and it does not bounce again
])
def test_the_throws_the_description_names(spin, attack, skips):
    assert skips_at(SWEEP, spin=spin, attack=attack) == skips
