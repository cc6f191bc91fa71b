"""A stone started where it cannot be is refused, not accepted silently: 5 m inside the ground when
the scene loads (bad input), below the pond's bed at the water's first patch (a failed run naming it)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from components.rigid.quaternion import body_axis
from cosim.component import Component
from cosim.errors import ScenarioError, SimulationError
from cosim.scenario import load, loads
from cosim.scheduler import Simulation

ROOT = Path(__file__).resolve().parents[1]

SCENES = Path(__file__).resolve().parents[1] / "scenarios"


def test_a_body_starting_inside_the_ground_is_refused_when_the_scene_loads():
    with pytest.raises(ScenarioError, match=r"components\.floor_flat: the body starts 5 m inside the ground"):
        load(SCENES / "ground_bounce.yaml", ["components.disk_flat.position=[0, 0, -5]"])


def test_a_body_touching_the_ground_at_the_start_is_accepted():
    load(SCENES / "ground_bounce.yaml", ["components.disk_flat.position=[0, 0, 0.001]"])


def test_a_stone_starting_below_the_pond_bed_is_refused_when_the_scene_loads():
    """Bad input, named before anything runs (before, the run started and failed at the water's
    first patch, exit 1)."""
    with pytest.raises(ScenarioError, match=r"components\.coupler: the body starts 9\.45 m below the water's bed "
                                            r"\(its centre at z = -10 m, the bed under it at z = -0\.5 m\)"):
        load(SCENES / "held_skip.yaml", ["components.stone.position=[0.3, 0.5, -10]",
                                         "components.stone.velocity=[0, 0, 0]"])


def test_a_stone_below_the_pond_bed_that_no_scene_check_saw_fails_at_the_first_patch_naming_the_bed():
    """The run's own check stays: a body moved under the bed after the scene's checks (here its
    state set before the run) still fails the run at the water's first patch, naming the bed."""
    scene = load(SCENES / "held_skip.yaml", ["until=0.01"])
    sim = Simulation(scene)
    stone = sim.components["stone"]
    stone.state = stone.state._replace(position=(0.3, 0.5, -10.0), velocity=(0.0, 0.0, 0.0))
    with pytest.raises(SimulationError, match=r"coupler.*starts 9\.45 m below the water's bed"):
        sim.run()


def test_a_stone_starting_under_water_above_the_bed_runs():
    sim = Simulation(load(SCENES / "held_skip.yaml", ["components.stone.position=[0.3, 0.5, -0.2]",
                                                  "components.stone.velocity=[0, 0, 0]", "until=0.05"]))
    assert sim.run().status in ("ok", "stopped")


class OverflowingSetUp(Component):
    """A component whose set-up leaves a float's range: a failure no field's own range check sees."""

    def setup(self) -> None:
        math.exp(1000.0)

    def _step_impl(self, t, dt, inputs):
        return {}


def test_a_component_that_cannot_be_built_from_its_values_is_named():
    """The error names the component that cannot be built, not just 'components', and says why."""
    scene = ("name: overflow\ndt: 0.001\nuntil: 0.01\n"
             "components:\n  thing: {type: 'tests.test_reliability_start:OverflowingSetUp'}\n")
    with pytest.raises(ScenarioError, match=r"components\.thing: a number in its set-up leaves a float's range: "
                                            r"OverflowError: math range error"):
        loads(scene)


@pytest.mark.parametrize(("override", "problem"), [
    ("components.stone.radius=1e-300", "components.stone.radius: gives the body a volume of 0 m^3, not a "
                                       "positive, finite, normal float (got 1e-300)"),
    ("components.stone.radius=1e200", "components.stone.radius: gives the body a volume of inf m^3, not a "
                                      "positive, finite, normal float (got 1e+200)"),
    ("components.stone.thickness=1e-320", "components.stone.thickness: gives the body a volume of 7.90505e-323 "
                                          "m^3, not a positive, finite, normal float (got 1e-320)"),
    ("components.stone.density=1e-310", "components.stone.density: gives the body a mass of 4.71239e-315 kg, "
                                        "not a positive, finite, normal float (got 1e-310)"),
    ("components.pond.depth=1e308", "components.pond.depth: must be <= 100000 m (got 1e+308)"),
    ("components.pond.wave_speed=1e308", "components.pond.wave_speed: must be <= 10000 m/s (got 1e+308)"),
    ("components.pond.rest_level=-1e308", "components.pond.rest_level: must be >= -1e+06 m (got -1e+308)"),
    ("components.pond.field_rate=1e308", "components.pond.field_rate: must be <= 1e+06 Hz (got 1e+308)"),
    ("components.coupler.water_level=1e308", "components.coupler.water_level: must be <= 1e+06 m (got 1e+308)"),
    ("components.stone.mass=1e-320", "components.stone.mass: gives the body a mass of 9.99989e-321 kg, not a "
                                     "positive, finite, normal float (got 1e-320)"),
    ("components.stone.mass=1e308", "components.stone.mass: makes the body denser than 1e+06 kg/m^3 (the density's "
                                    "bound; osmium is 22,590): at most 47.12 kg for its 4.712e-05 m^3 (got 1e+308)"),
    # (its weight finite, it passed, and its contact with a ground failed the run with a non-finite force)
    ("components.stone.mass=1e307", "components.stone.mass: makes the body denser than 1e+06 kg/m^3 (the density's "
                                    "bound; osmium is 22,590): at most 47.12 kg for its 4.712e-05 m^3 (got 1e+307)"),
    ("components.stone.density=1e6", None),  # the bound itself, given as a density
    ("components.stone.mass=47.12", None),  # and as a mass
    ("components.pond.displacement_smoothing=5000", "components.pond.displacement_smoothing: must be <= 1000 "
                                                    "(got 5000)"),
    ("components.pond.ny=99999999999999999999", "components.pond.ny: must be a 64-bit integer, below 2^63 in "
                                                "size (got 99999999999999999999)"),
    ("components.coupler.face_elements=100000", "components.coupler.face_elements: must be <= 1024 (got 100000)"),
    ("components.coupler.g=1e-320", "components.coupler.g: must be 0 (weightless) or at least 1e-06 m/s^2 "
                                    "(got 9.99989e-321)"),
    ("components.coupler.c_l=1e308", "components.coupler.c_l: must be <= 1000 (got 1e+308)"),
    ("components.stone.density=1e308", "components.stone.density: must be <= 1e+06 kg/m^3 (got 1e+308)"),
    ("components.coupler.lookahead=1e308", "components.coupler.lookahead: must be <= 10 s (got 1e+308)"),
    ("components.stone.position=[0, 0, 1e308]", "components.stone.position: makes the stone's potential energy "
                                                "overflow a float (got (0.0, 0.0, 1e+308))"),
])
def test_a_scene_whose_numbers_leave_a_floats_range_is_refused_naming_the_parameter(override, problem):
    """Values each field accepts alone but whose mass, volume or wave arithmetic would overflow or
    vanish (the stone's mass of 1e-315 kg would turn every force into infinity at its first step)."""
    if problem is None:
        load(SCENES / "held_skip.yaml", [override])
        return
    with pytest.raises(ScenarioError) as caught:
        load(SCENES / "held_skip.yaml", [override])
    assert str(caught.value).endswith(problem)


def test_a_body_far_longer_than_wide_starts_over_a_bounded_stand_in_for_the_water():
    """Before the water's first patch the coupler assumes still water over the body's footprint, at
    most 64 columns along it: a disk 100 km thick once asked for 10^13 columns of 6 mm there and
    never started. The longest disk a scene takes now (24495 times its radius: 1.2 km for the
    slate, tilted so that its footprint is 420 m long) runs, over 2 x 64 + 5 columns along it."""
    sim = Simulation(load(SCENES / "skip.yaml", ["components.stone.thickness=1224", "until=0.002"]))
    assert sim.run().status == "ok"
    stand_in = sim.components["coupler"]._assumed_still_water(np.zeros(3), (210.0, 0.05), 0.0)
    assert stand_in.height.shape[1] <= 2 * 64 + 5


def test_a_disk_longer_than_its_spin_can_be_told_from_round_off_is_refused():
    """A disk 1e20 m thick and 2.5 cm across (moments of inertia 2.7e42 apart) grew its angular
    momentum from round-off until a math domain error at its fifth step; at 24495 times its radius
    (moments 1e8 apart) it spins at 401.56 rad/s for a second to 3e-5, and beyond that it is refused."""
    with pytest.raises(ScenarioError) as caught:
        load(SCENES / "spinning_disk.yaml", ["components.wobbler.thickness=1e20"])
    assert str(caught.value).endswith(
        "components.wobbler.thickness: makes a rod 4e+21 times as long as its radius, whose moments of inertia are "
        "more than 1e+08 apart: round-off in its angular momentum would swamp its spin; at most 24495 times the "
        "radius, 612.4 m here (got 1e+20)")
    sim = Simulation(load(SCENES / "spinning_disk.yaml", ["components.wobbler.thickness=612", "until=1.0"]))
    wobbler = sim.components["wobbler"]
    spin0 = _spin(wobbler.state)
    assert sim.run().status == "ok"
    assert _spin(wobbler.state) == pytest.approx(spin0, rel=1e-4)


def _spin(state) -> float:
    """The angular velocity about the body's own axis [rad/s]."""
    return float(np.dot(state.angular_velocity, body_axis(state.orientation)))


def test_a_spinning_disk_whose_thickness_makes_its_energy_overflow_is_refused():
    """Its moment of inertia about a diameter grows with the thickness squared: a disk 1 km thick
    spun at 1e151 rad/s, whose energy the radius alone would keep finite, is refused at its spin."""
    with pytest.raises(ScenarioError, match=r"components\.stone\.spin: makes the stone's kinetic energy overflow"):
        load(SCENES / "skip.yaml", ["components.stone.thickness=1000", "components.stone.spin=1e151"])


def test_a_coupler_water_level_other_than_its_waters_rest_level_is_refused():
    """The coupler's water_level is the level it takes until the water's first patch comes: one
    other than the water's own wetted the stone with water that was not there (a touchdown at
    t = 0.001 s and a 94 ms contact 5 m above the pond); refused naming both."""
    with pytest.raises(ScenarioError) as info:
        load(ROOT / "scenarios" / "skip.yaml", ["components.coupler.water_level=5"])
    assert info.value.problems == ["components.coupler: water_level 5 m is not the rest level 0 m of the water "
                                   "feeding it; leave water_level out (the water's own is taken from its first "
                                   "patch) or give the water's rest_level"]
    load(ROOT / "scenarios" / "skip.yaml", ["components.coupler.water_level=1", "components.pond.rest_level=1",
                                            "components.stone.position=[0.3, 1.75, 1.1]"])
    load(ROOT / "scenarios" / "skip.yaml", ["components.pond.rest_level=1",  # water_level left out: taken
                                            "components.stone.position=[0.3, 1.75, 1.1]"])


BIG_PINE = ["components.pine.radius=0.3", "components.pine.position=[0, 0, 0.2]"]


def test_a_body_whose_pushed_aside_water_falls_past_an_open_edge_is_refused():
    """A 0.6 m pine ball let go half in the 0.8 m open pond of float_sphere.yaml: the water it pushes
    aside reaches 0.6 m from its centre, past the absorbing edges 0.4 m away, which took it in as a wave
    and gave it back: the ball bobbed higher at every bob (133 to 230 J) while the pond's water grew by
    up to 65%, exit 0. Refused at load, naming the reach and the room; the same ball in a 2 m pond, or
    in the 0.8 m one with walls, loads."""
    with pytest.raises(ScenarioError) as refused:
        load(SCENES / "float_sphere.yaml", BIG_PINE)
    said = ("components.pine_water: the water the body pushes aside reaches 0.6 m from its centre (its radius "
            "and the displacement's band), past the open edge of the water feeding it (0.4 m away)")
    assert said in str(refused.value)
    load(SCENES / "float_sphere.yaml", [*BIG_PINE, "components.pine_pond.nx=200", "components.pine_pond.ny=200",
                                        "components.pine_pond.origin_x=-0.995", "components.pine_pond.origin_y=-0.995"])
    load(SCENES / "float_sphere.yaml", [*BIG_PINE, "components.pine_pond.boundary=reflecting"])


def test_a_stone_let_go_inside_a_crest_higher_than_the_wave_allowance_meets_it():
    """The held skip's pond starting with a 20 cm bump under the stone: the coupler took a body more
    than wave_allowance (5 cm) above the rest level to be far from any water, so the stone, let go
    inside the crest, fell through it untouched for 50 ms and then skipped as over still water (a
    scene starting so was then refused at load). A far body now asks the water for the crest where it
    goes, and meets the crest: thrown into that wall of water at 7.88 m/s, it is down to about
    1 m/s in 30 ms, as with the allowance raised to the crest's 0.2 m."""
    bump = "components.pond.initial={x: 0.35, y: 0.5, amplitude: 0.2, width: 0.1}"

    def stone_after(*overrides: str):
        sim = Simulation(load(SCENES / "held_skip.yaml", [bump, "until=0.03", "record.visual_rate=0", *overrides]))
        sim.run()
        state = sim.components["stone"].body_state()
        return np.concatenate([state.position, state.velocity])

    met, raised = stone_after(), stone_after("components.coupler.wave_allowance=0.2")
    free = stone_after("components.coupler.effects=[]")  # through nothing, as it flew before
    assert free[3] == pytest.approx(7.88, abs=0.01)
    assert met[3] < 1.5 and raised[3] < 1.5
    assert met[3] == pytest.approx(raised[3], abs=0.05)  # a step later at most: met as the crest is learnt


@pytest.mark.parametrize("at_ms", [1.5, 2.0])
def test_a_run_restarted_inside_the_crest_continues_the_same(at_ms):
    """The crest the coupler last learnt is part of its state: restored from a checkpoint taken while
    the water's patches said nothing new (an empty window), the coupler took the crest to be 0 and
    the stone fell through the 20 cm bump again (1.74 m/s off the run it continued)."""
    import copy

    overrides = ["components.pond.initial={x: 0.35, y: 0.5, amplitude: 0.2, width: 0.1}", "until=0.03",
                 "record.visual_rate=0"]
    first = Simulation(load(SCENES / "held_skip.yaml", overrides))
    first.run(round(at_ms * 1e6))
    checkpoint = copy.deepcopy(first.checkpoint())
    first.run()
    again = Simulation(load(SCENES / "held_skip.yaml", overrides))
    again.restore(checkpoint)
    again.run()
    a, b = first.components["stone"].body_state(), again.components["stone"].body_state()
    assert np.array_equal(a.position, b.position) and np.array_equal(a.velocity, b.velocity)


def test_a_body_far_too_light_for_the_step_that_starts_in_the_water_is_refused_as_the_scene_loads():
    """The pine ball of scenarios/float_sphere.yaml made 1e-300 kg/m^3: its buoyancy would carry it
    further than its radius within a step. Refused at load naming its coupler and the step it needs
    (it failed at its first step with 'ValueError: math domain error', exit 1, its speed overflowed);
    the scene as written loads, the ball's bound 39 ms against its 1 ms step."""
    with pytest.raises(ScenarioError, match=r"components\.pine_water: step 0\.001 s exceeds the stable step "
                                            r"[0-9.e+-]+ s it will need once the run is under way"):
        load(ROOT / "scenarios" / "float_sphere.yaml", ["components.pine.density=1e-300"])
    sim = Simulation(load(ROOT / "scenarios" / "float_sphere.yaml"))
    sim.initialize()
    ball = sim.components["pine"].body_state()
    assert sim.components["pine_water"]._buoyant_bound(ball) == pytest.approx(
        math.sqrt(2 * 0.25 * ball.radius * ball.mass / (1000 * 9.81 * 4 / 3 * math.pi * ball.radius**3)))


def test_a_ground_plane_through_a_point_beyond_1000_km_is_refused_naming_it():
    """A SolidGround through [-1e308, 0, 0]: refused at load as a body's position is (it ran, the
    viewer's arithmetic of the plane overflowing into a numpy warning)."""
    with pytest.raises(ScenarioError, match=r"components\.floor_flat\.point: must lie within 1000 km of the origin"):
        load(SCENES / "ground_bounce.yaml", ["components.floor_flat.point=[-1e308, 0, 0]"])
    load(SCENES / "ground_bounce.yaml", ["components.floor_flat.point=[-1e6, 0, 0]"])


def test_a_scripted_velocity_whose_kinetic_energy_overflows_is_refused_naming_it():
    """scripted_velocity [[0, 1e308, 0]]: refused at load as a velocity of that size is (the run failed at
    its first step, its summary saying speed inf m/s, exit 1)."""
    with pytest.raises(ScenarioError, match=r"components\.disk_tilted\.scripted_velocity: makes the stone's kinetic "
                                            r"energy overflow a float"):
        load(SCENES / "ground_bounce.yaml", ["components.disk_tilted.scripted_velocity=[[0, 1e308, 0]]"])
    with pytest.raises(ScenarioError) as unscripted:  # a vertical speed alone is the velocity's, not the script's
        load(SCENES / "ground_bounce.yaml", ["components.disk_tilted.velocity=[0, 0, 1e160]"])
    assert "velocity" in str(unscripted.value) and "scripted_velocity" not in str(unscripted.value)
