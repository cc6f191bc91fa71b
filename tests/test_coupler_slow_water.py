"""A water stepping much more slowly than the coupler answers its requests late: a new window reaches
the water only at its next step, and comes back at that step's end. The coupler asks early enough
for that (WaterCoupler._water_lag): the reference throw on a water stepping every 15 ms (inside its
stable range), and every 50 ms (the water substepped), skips as on its own 2 ms water."""

from __future__ import annotations

from pathlib import Path

import pytest

from components.messages import SkipRecord
from cosim.record.reader import Recording
from cosim.runner import run_scene
from cosim.scenario import load

SKIP = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
UNTIL = "until=0.6"  # the first two skips
FAST = ["record.visual_rate=0", "record.checkpoint_every=0", UNTIL]


def _skips(path: Path, every: int) -> list[SkipRecord]:
    scene = load(SKIP, overrides=[*FAST, f"components.pond.every={every}"])
    assert run_scene(scene, path, progress=False).result.status == "ok"
    return [skip for _, skip in Recording(path).messages("/stages/skip", SkipRecord)]


@pytest.fixture(scope="module")
def own_water(tmp_path_factory) -> list[SkipRecord]:
    return _skips(tmp_path_factory.mktemp("slow") / "own.mcap", 4)


@pytest.mark.parametrize("every", [30, 100])
def test_a_slow_water_keeps_the_contact_the_coupler_asked_for(tmp_path, own_water, every):
    """At every 30 (15 ms) the window ran out 15 ms before the water answered: from 0.0815 s the
    stone, 1.5 cm under the surface, was dry to the coupler, and the summary gave one skip for three
    flights. At every 100 (50 ms, the water in substeps) the first window of columns came 50 ms
    late, and the stone fell through the water 5.7 m into the pond ("left the pond")."""
    skips = _skips(tmp_path / f"every{every}.mcap", every)
    assert [s.touchdown_time for s in skips] == [s.touchdown_time for s in own_water] == [0.0595, 0.5415]
    for slow, own in zip(skips, own_water, strict=True):
        assert slow.contact_time == pytest.approx(own.contact_time, abs=1e-9)
        assert slow.takeoff_angle_deg == pytest.approx(own.takeoff_angle_deg, abs=0.05)
        assert slow.speed_out == pytest.approx(own.speed_out, rel=5e-4)
