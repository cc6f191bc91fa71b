"""A stone that sinks through a shallow water's bed (no ground there) is said to have gone through
the bed, as soon as its own top is under it: not later, by its bounding sphere's, when the stage
monitor, seeing it dry below the water's level, had already said it left the pond."""

from __future__ import annotations

from pathlib import Path

from cosim.scenario import load
from cosim.scheduler import Simulation

SCENES = Path(__file__).resolve().parent.parent / "scenarios"


def test_a_stone_sinking_through_a_1_cm_bed_is_said_to_go_through_it_not_to_leave_the_pond():
    """The held skip on 1 cm of water: after its skips the slate sinks onto the bed and through it
    (7.6 m out on a pond 8 m long). The run stops with the coupler's reason; it said "left the pond
    at x = 7.66 m"."""
    scene = load(SCENES / "held_skip.yaml", ["components.pond.depth=0.01"])
    result = Simulation(scene).run(3_000_000_000)
    assert result.status == "stopped"
    assert result.reason.startswith("coupler: the body went through the water's bed at x = 7.6")
    assert "wholly under the bed at z = -0.01 m" in result.reason



def test_a_floating_ball_that_drifts_off_an_open_edge_falls_on_beside_the_water_without_failing():
    """The pine ball of float_sphere, pushed at 0.6 m/s towards the open edge 0.4 m away, floats
    there, goes over it and falls on beside the pond (nothing there holds it, and no stage monitor
    ends the run). Beside the water no water can meet it, so its step has no bound: bounded as a
    body near the water, it failed the run at 12.5 m/s, 8 m below the pond, its 1 ms step exceeding
    the stable 0.9995 ms."""
    scene = load(SCENES / "float_sphere.yaml", [
        "components.pine.velocity=[0.6, 0.0, 0.0]", "components.pine.position=[0.0, 0.0, -0.0067]", "until=3.5"])
    sim = Simulation(scene)
    result = sim.run()
    assert result.status == "ok", result.reason
    x, _, z = sim.components["pine"].get_state()["position"]
    assert x > 0.4 and z < -10.0  # past the edge, and fallen at 15 m/s and more: beyond the old failure
