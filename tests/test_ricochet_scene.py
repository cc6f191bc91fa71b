"""scenarios/ricochet.yaml: Johnson & Reid's sphere ricochet as a scene a user runs and watches. Up to
its first ricochet it is a throw of the validation's bisection (components.analysis.experiments),
and it ricochets below the critical angle and dives above it, as the description says."""

from __future__ import annotations

from pathlib import Path

from components.analysis import experiments as ex
from cosim.scenario import load
from cosim.scheduler import Simulation

SCENE = Path(__file__).resolve().parents[1] / "scenarios" / "ricochet.yaml"


def test_the_scene_is_the_validation_throw_at_15_deg():
    """Below Johnson & Reid's 18 deg: it ricochets, to the bit as the validation's sphere throw at 15 deg does
    (the scene's longer pond and its viewer field change nothing before the first ricochet)."""
    scene = ex.run_throw(load(SCENE))
    table = ex.run_throw(ex.sphere_throw_scene(20.0, 15.0, 1.0))
    assert scene == table
    assert scene.bounced


def test_it_ricochets_three_times_down_the_pond():
    sim = Simulation(load(SCENE))
    sim.run()
    records = sim.components["stages"].records
    assert len(records) == 3
    assert [r.contact_time for r in records] == sorted(r.contact_time for r in records)  # each longer
    assert [r.takeoff_angle_deg for r in records] == sorted((r.takeoff_angle_deg for r in records), reverse=True)


def test_above_the_critical_angle_it_dives():
    out = ex.run_throw(load(SCENE, overrides=["components.stone.velocity=[18.5437, 0, -7.4784]"]))  # 22 deg
    assert not out.bounced
