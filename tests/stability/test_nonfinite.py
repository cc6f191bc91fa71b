"""A non-finite value anywhere stops the run with an error naming the component, the field and the time.

The framework checks every output of every step (``Component._check_outputs``); these cases prove it
on the physics: a stone so fast that its speed overflows, a coupler whose water is so dense that its
force overflows. A non-finite number in the scene itself is refused before anything runs.
"""

from __future__ import annotations

import numpy as np
import pytest

from cosim.cli import main
from cosim.errors import ScenarioError, SimulationError
from cosim.runner import run_scene
from cosim.scheduler import Simulation
from tests.stability.scenes import POND, scene

OVERFLOWS = [
    # (override, component, port, field, time of the failing step [s])
    # a gravity of 1e307 m/s^2 gives a finite velocity whose square (the speed's) overflows in the
    # first step; a start whose own energy overflows is refused at load (test_rigid_body)
    ("components.stone.gravity=[0.0, 0.0, -1.0e+307]", "stone", "state", "speed", 0.0),
    ("components.coupler.rho=1.0e+307", "coupler", "wrench", "force", 0.074),
]


@pytest.mark.parametrize(("override", "component", "port", "field", "t"), OVERFLOWS)
def test_an_overflow_in_a_physics_component_stops_the_run_naming_it(override, component, port, field, t):
    """The step whose output holds an infinity fails: the run ends 'failed' with a SimulationError
    naming the component, the output port and field, and the step's start time."""
    outcome = run_scene(scene(override), None, progress=False)
    assert outcome.failed and outcome.result.status == "failed"
    error = outcome.result.error
    assert isinstance(error, SimulationError)
    assert error.component == component
    assert error.time_ns == pytest.approx(t * 1e9, abs=1.0)
    assert f"non-finite value in output {port!r} field {field!r}" in error.reason
    assert outcome.result.time_ns <= error.time_ns + 1_000_000  # stopped there, not run on


def test_the_command_line_reports_the_overflow_and_exits_1(tmp_path, capsys):
    """`cosim run` on the dense-water scene exits 1 and prints the component, field and time."""
    path = tmp_path / "dense.yaml"
    path.write_text(POND.replace("effects: [", "rho: 1.0e+307\n    effects: ["), encoding="utf-8")
    assert main(["run", str(path), "--no-record", "-q"]) == 1
    err = capsys.readouterr().err
    assert "component 'coupler' failed at t = 0.074 s: non-finite value in output 'wrench' field 'force'" in err


def test_a_nan_in_the_scene_is_refused_at_load_time():
    """A NaN initial velocity never reaches a step: loading fails naming the value's YAML path."""
    with pytest.raises(ScenarioError, match=r"components\.stone\.velocity\[0\]: must be finite \(got nan\)"):
        scene("components.stone.velocity=[.nan, 0.0, 0.0]")


def test_a_bad_parameter_is_the_only_problem_reported():
    """A scene whose only mistake is the stone's NaN velocity reports that one problem, not edges
    that are in fact connected."""
    with pytest.raises(ScenarioError) as info:
        scene("components.stone.velocity=[.nan, 0.0, 0.0]")
    assert info.value.problems == ["components.stone.velocity[0]: must be finite (got nan)"]


@pytest.mark.filterwarnings("ignore:overflow encountered:RuntimeWarning")
def test_a_non_finite_initial_output_stops_the_run_at_t_0():
    """A water surface so high that its energy overflows (set from outside: a scene's bump is at most
    1 km) fails at t = 0, where the value first appears, naming the water's field output."""
    sim = Simulation(scene("components.pond.field_rate=30"))
    pond = sim.components["pond"]
    state = pond.get_state()
    h = np.zeros_like(np.asarray(state["h"]))
    h[h.shape[0] // 2, h.shape[1] // 2] = 1.0e200  # one column: its faces' squares overflow
    pond.set_state({**state, "h": h})
    with pytest.raises(SimulationError) as info:
        sim.run()
    assert info.value.component == "pond" and info.value.time_ns == 0
    assert "non-finite value in output 'field' field 'energy'" in info.value.reason


def test_a_step_needing_too_many_substeps_says_how_many_in_a_few_digits():
    """A stone thrown at 1e150 m/s (its energy still a float) makes the coupler's stable step
    absurdly small: the run fails naming the substeps it would need in three digits, not 150."""
    outcome = run_scene(scene("components.stone.velocity=[1.0e+150, 0.0, 0.0]"), None, progress=False)
    assert outcome.failed
    error = outcome.result.error
    assert isinstance(error, SimulationError) and error.component == "coupler"
    assert "needs 1.6e+148 substeps (stable step 1.25e-152 s), more than the limit 10000" in error.reason
