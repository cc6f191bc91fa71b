"""A stone started where it cannot be is refused, not accepted silently: 5 m inside the ground when
the scene loads (bad input), below the pond's bed at the water's first patch (a failed run naming it)."""

from __future__ import annotations

from pathlib import Path

import pytest

from cosim.errors import ScenarioError, SimulationError
from cosim.scenario import load
from cosim.scheduler import Simulation

SCENES = Path(__file__).resolve().parents[1] / "scenarios"


def test_a_body_starting_inside_the_ground_is_refused_when_the_scene_loads():
    with pytest.raises(ScenarioError, match=r"components\.floor_flat: the body starts 5 m inside the ground"):
        load(SCENES / "ground_bounce.yaml", ["components.disk_flat.position=[0, 0, -5]"])


def test_a_body_touching_the_ground_at_the_start_is_accepted():
    load(SCENES / "ground_bounce.yaml", ["components.disk_flat.position=[0, 0, 0.001]"])


def test_a_stone_starting_below_the_pond_bed_fails_at_the_first_patch_naming_the_bed():
    sim = Simulation(load(SCENES / "skip.yaml", ["components.stone.position=[0.3, 0.5, -10]",
                                                  "components.stone.velocity=[0, 0, 0]"]))
    with pytest.raises(SimulationError, match=r"coupler.*starts 9\.45 m below the water's bed"):
        sim.run()


def test_a_stone_starting_under_water_above_the_bed_runs():
    sim = Simulation(load(SCENES / "skip.yaml", ["components.stone.position=[0.3, 0.5, -0.2]",
                                                  "components.stone.velocity=[0, 0, 0]", "until=0.05"]))
    assert sim.run().status in ("ok", "stopped")


def test_a_component_that_cannot_be_built_from_its_values_is_named():
    """A radius of 1e-300 m passes each field's range check but gives a massless stone: the error
    names the component that cannot be built, not just 'components'."""
    with pytest.raises(ScenarioError, match=r"components\.stone: cannot be built from these values: .*mass"):
        load(SCENES / "skip.yaml", ["components.stone.radius=1e-300"])
