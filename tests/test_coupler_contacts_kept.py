"""Contacts the coupler must not miss. A water stepping much more slowly than the coupler answers its
requests late: a new window reaches the water only at its next step, and comes back at that step's
end. The coupler asks early enough for that (WaterCoupler._water_lag): the reference throw on a water
stepping every 15 ms (inside its stable range), and every 50 ms (the water substepped), skips as on
its own 2 ms water. And a contact met only within the coupler's substeps is reported as one."""

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


def test_a_contact_met_only_within_the_couplers_substeps_is_a_contact(tmp_path):
    """A 5 mm stone 0.5 mm thick on 5 ms steps, the coupler in up to 46 substeps: it bounces within one
    step, dry as the step begins and as it ends. The report of that step says it wetted, so the stage
    monitor counts the skip (it was told dry and gave the first skip 2 m further on, at 0.275 s)."""
    scene = load(SKIP, overrides=["record.visual_rate=0", "record.checkpoint_every=0", "until=0.15", "dt=0.005",
                                  "components.pond.every=1", "components.stone.radius=0.005",
                                  "components.stone.thickness=0.0005"])
    outcome = run_scene(scene, tmp_path / "tiny.mcap", progress=False)
    assert outcome.simulation.runners[2].comp.name == "coupler" and outcome.simulation.runners[2].most_substeps > 10
    (skip,) = [s for _, s in Recording(tmp_path / "tiny.mcap").messages("/stages/skip", SkipRecord)]
    assert skip.touchdown_time == pytest.approx(0.065) and skip.touchdown_x == pytest.approx(1.01, abs=0.01)
    assert skip.speed_out < skip.speed_in - 0.3  # the water took its toll in that step
