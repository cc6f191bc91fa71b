"""A non-finite value anywhere stops the run with an error naming the component, the field and the time.

The framework checks every output of every step (``Component._check_outputs``); these cases prove it
on the physics: a stone so fast that its speed overflows, a coupler whose water is so dense that its
force overflows. A non-finite number in the scene itself is refused before anything runs.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from cosim.cli import main
from cosim.errors import ScenarioError, SimulationError
from cosim.runner import run_scene
from cosim.scheduler import Simulation
from tests.stability.scenes import POND, scene

OVERFLOWS = [
    # (component, parameter, value, port, field, time of the failing step [s]): values a scene refuses
    # (gravity at most 1e4 m/s^2, a water at most 1e5 kg/m^3), set past the scene's checks to reach the
    # run's own: a gravity of 1e307 m/s^2 gives a finite velocity whose square (the speed's) overflows
    # in the first step; a water of 1e307 kg/m^3 a force that overflows at the first contact
    ("stone", "gravity", (0.0, 0.0, -1.0e307), "state", "speed", 0.0),
    ("coupler", "rho", 1.0e307, "wrench", "force", 0.074),
]


def _past_the_checks(component: str, name: str, value, monkeypatch=None) -> Simulation:
    """The hard-case scene built, then ``component``'s parameter ``name`` set to ``value`` and the
    component set up again: a value the scene would refuse, to test what the run does with it. With
    ``monkeypatch``, the checks that would catch it before its overflow are taken out: the body's
    gravity bound, the coupler's bound for the body's first wet step (which substeps, or stops the
    run, before the force can overflow) and its own parameters' bounds, which it checks as it is set
    up."""
    import dataclasses
    import math

    import components.coupler.component
    import components.rigid_body
    from components.coupler.component import WaterCoupler

    if monkeypatch is not None:
        monkeypatch.setattr(components.rigid_body, "GRAVITY_MAX", math.inf)
        monkeypatch.setattr(WaterCoupler, "_approach_bound", lambda self, body: math.inf)
        monkeypatch.setattr(components.coupler.component, "require_valid", lambda params: None)
    sim = Simulation(scene())
    comp = sim.components[component]
    comp.params = dataclasses.replace(comp.params, **{name: value})
    comp.setup()
    return sim


@pytest.mark.parametrize(("component", "name", "value", "port", "field", "t"), OVERFLOWS)
def test_an_overflow_in_a_physics_component_stops_the_run_naming_it(component, name, value, port, field, t,
                                                                   monkeypatch):
    """The step whose output holds an infinity fails: the run ends 'failed' with a SimulationError
    naming the component, the output port and field, and the step's start time (the run's last line
    of defence, behind the scene's checks and the stable steps, which are taken out here)."""
    sim = _past_the_checks(component, name, value, monkeypatch)
    outcome = run_scene(sim.scene, None, progress=False, simulation=sim)
    assert outcome.failed and outcome.result.status == "failed"
    error = outcome.result.error
    assert isinstance(error, SimulationError)
    assert error.component == component
    assert error.time_ns == pytest.approx(t * 1e9, abs=1.0)
    assert f"non-finite value in output {port!r} field {field!r}" in error.reason
    assert outcome.result.time_ns <= error.time_ns + 1_000_000  # stopped there, not run on


def test_values_that_can_only_overflow_are_refused_when_the_scene_loads():
    """The same values given in the scene are refused before anything runs."""
    with pytest.raises(ScenarioError, match=r"components\.stone\.gravity: each component at most 10000"):
        scene("components.stone.gravity=[0.0, 0.0, -1.0e+307]")
    with pytest.raises(ScenarioError, match=r"components\.coupler\.rho: must be <= 100000 kg/m\^3"):
        scene("components.coupler.rho=1.0e+307")


def test_the_command_line_refuses_the_dense_water_before_the_run(tmp_path, capsys):
    """`cosim run` on a scene with water of 1e307 kg/m^3 exits 2 naming the value (it ran, and failed
    at t = 0.074 s with an overflow)."""
    path = tmp_path / "dense.yaml"
    path.write_text(POND.replace("effects: [", "rho: 1.0e+307\n    effects: ["), encoding="utf-8")
    assert main(["run", str(path), "--no-record", "-q"]) == 2
    assert "components.coupler.rho: must be <= 100000 kg/m^3 (got 1e+307)" in capsys.readouterr().err


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
    absurdly small: the scene is refused before the run (it failed at the first contact), naming the
    substeps it would need in three digits, not 150; past the scene's checks, the run says the same
    when it gets there (the same figures: the load check takes the motion bound the run applies)."""
    with pytest.raises(ScenarioError) as info:
        scene("components.stone.velocity=[1.0e+150, 0.0, 0.0]")
    assert info.value.problems == [
        "components.coupler: will need 1.6e+148 substeps of its step 0.0002 s (stable step 1.25e-152 s once the "
        "run is under way), more than the limit 10000; lower dt or every"]
    sim = _past_the_checks("stone", "velocity", (1.0e150, 0.0, 0.0))
    outcome = run_scene(sim.scene, None, progress=False, simulation=sim)
    assert outcome.failed
    error = outcome.result.error
    assert isinstance(error, SimulationError) and error.component == "coupler"
    assert "needs 1.6e+148 substeps (stable step 1.25e-152 s), more than the limit 10000" in error.reason

SMALL_SKIP = ["components.pond.nx=200", "components.pond.ny=60", "components.stone.position=[0.1, 0.3, 0.1]",
              "until=0.12", "record.visual_rate=0"]


def test_a_stone_far_lighter_than_the_water_it_meets_takes_its_first_contact_in_substeps():
    """A slate 0.1 mm thin (2 g against a face that stops 0.3 kg of water): the coupler's stable step
    bounds its first wet step from before it touches, so the scheduler substeps that step. It took it
    whole, and the water gave the stone energy (at 1 um it left at 41 km/s from 11 m/s); now the
    water takes energy, and the stone ends with less than it started with. Under on_unstable: error
    a step far too long for such a stone is refused when the scene loads."""
    from pathlib import Path

    from cosim.scenario import load

    skip = Path(__file__).resolve().parents[2] / "scenarios" / "skip.yaml"
    sim = Simulation(load(skip, [*SMALL_SKIP, "components.stone.thickness=1e-4"]))
    stone, coupler = sim.components["stone"], sim.components["coupler"]
    start = stone.initial_outputs()["state"]
    run_scene(sim.scene, None, progress=False, simulation=sim)
    end = stone.body_state()
    assert coupler.dissipated > 0.0
    assert end.kinetic_energy + end.potential_energy < start.kinetic_energy + start.potential_energy
    refused = r"components\.coupler: step 0\.0005 s exceeds the stable step 6\.\d+e-07 s"
    with pytest.raises(ScenarioError, match=refused):
        load(skip, [*SMALL_SKIP, "components.stone.thickness=1e-6", "on_unstable=error"])


HELD_SKIP = Path(__file__).resolve().parents[2] / "scenarios" / "held_skip.yaml"


@pytest.mark.parametrize("speed", [500.0, 2000.0])
def test_a_stone_meeting_the_water_at_hundreds_of_m_per_s_is_slowed_by_it(speed):
    """The held skip's stone thrown at 500 m/s and 2 km/s (10 deg down, from 15 cm): its first step
    near the water has the approach's bound, as every later one has, so the coupler substeps it. It
    was taken whole, the run's first coupler step having no bound yet, and the water threw the stone
    out at 25 km/s from 2 km/s (-8e7 J "taken"), exit 0. Now the water takes energy and the stone
    leaves slower than it came."""
    from cosim.scenario import load

    vx, vz = speed * math.cos(math.radians(10.0)), -speed * math.sin(math.radians(10.0))
    sim = Simulation(load(HELD_SKIP, [f"components.stone.velocity=[{vx!r}, 0.0, {vz!r}]", "until=0.01",
                                      "record.visual_rate=0"]))
    stone, coupler = sim.components["stone"], sim.components["coupler"]
    start = stone.initial_outputs()["state"]
    sim.run()
    end = stone.body_state()
    assert coupler.dissipated > 0.0
    assert end.speed < start.speed
    assert end.kinetic_energy + end.potential_energy < start.kinetic_energy + start.potential_energy


def test_a_substep_too_long_for_the_forces_it_meets_is_refined_within_the_step():
    """The coupler's step at the 2 km/s stone's first touch, taken in 2 substeps where its own
    forces allow about 4 us: each substep longer than the stable step of the forces it meets takes
    the rest of the step in substeps that short, so the step's mean force is that of 1,000 substeps
    to 11% (the first-order method at its stable step; taken in 2, 10 or 100 it is the same). Taken as
    set, 2 substeps gave 5.2 MN along the water against 0.27 MN resolved (the private copy went
    deep into the water unopposed), 10 gave 0.94 MN."""
    import copy

    from cosim.scenario import load

    sim = Simulation(load(HELD_SKIP, ["components.stone.velocity=[1969.6, 0.0, -347.3]", "until=0.0005",
                                      "record.visual_rate=0"]))
    coupler = sim.components["coupler"]
    seen = []
    inner = coupler.step_gathered

    def keep(t_ns, dt_ns, inputs, *args, **kwargs):
        seen.append((t_ns, dt_ns, dict(inputs), copy.deepcopy(coupler)))
        return inner(t_ns, dt_ns, inputs, *args, **kwargs)

    coupler.step_gathered = keep
    sim.run()
    t_ns, dt_ns, inputs, before = seen[0]
    assert inputs["body"].position[2] < 0.0  # the stone in the water at its first step
    forces = {}
    for substeps in (2, 1000):
        again = copy.deepcopy(before)
        again.bound = dt_ns * 1e-9 / substeps * (1.0 + 1e-9)
        stepped = type(again).step_gathered(again, t_ns, dt_ns, inputs, "substep")  # the class's own, not keep
        forces[substeps] = np.asarray(stepped["wrench"].force)
        # at least as set; more where the state the step meets needs them (Component.restep: 148 here)
        assert again.last_substeps >= substeps
    assert np.linalg.norm(forces[2] - forces[1000]) < 0.15 * np.linalg.norm(forces[1000])


def test_a_stone_through_the_bed_before_the_waters_first_answer_is_not_said_to_start_there():
    """At 5 km/s the held skip's stone goes through the water (still, as assumed) and its bed before
    the water's first patch arrives: the run ends as for any body through the bed, saying where. It
    failed saying the body "starts 0.25 m below the water's bed: start it above the bed", of a stone
    started 15 cm above the water."""
    from cosim.scenario import load

    sim = Simulation(load(HELD_SKIP, ["components.stone.velocity=[4924.0, 0.0, -868.2]", "until=0.02",
                                      "record.visual_rate=0"]))
    sim.run()
    assert sim.components["coupler"].stop_reason.startswith("the body went through the water's bed at x = ")
    assert sim.components["coupler"].dissipated > 0.0


@pytest.mark.parametrize("integrator", ["verlet", "semi_implicit_euler", "rk4"])
@pytest.mark.parametrize("torque", [math.inf, 1e200])
def test_a_torque_turning_the_body_past_any_angle_is_said_as_its_state_not_a_domain_error(integrator, torque):
    """A torque whose step turns the body by more than 1.3e154 rad (an infinite one, or 1e200 N m)
    failed the step on a bare 'ValueError: math domain error' (the sine of an infinite angle) under
    verlet and semi-implicit Euler; it is said as every other non-finite input is, by the state it
    leaves, under each integrator."""
    from components.messages import Wrench
    from components.rigid_body import RigidBody, RigidBodyParams

    body = RigidBody("stone", RigidBodyParams(shape="disk", radius=0.05, thickness=0.01, density=2650.0,
                                              integrator=integrator))
    with pytest.raises(SimulationError, match=r"^component 'stone' failed at t = 0 s: non-finite value in output "
                                              r"'state' field '\w+'$"):
        body.step(0, 1_000_000, {"wrench": Wrench(np.zeros(3), np.array([torque, 0.0, 0.0]))})
