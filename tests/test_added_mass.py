"""A body under water carries water along (added mass): exact sinking accelerations, closed energy
books, and a scene that names the effect without connecting it is refused."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from components.analysis import experiments as ex
from components.coupler.added_mass import full_added_mass, scaled
from components.messages import AddedMass, BodyState, Shape, WaterContact, Wrench
from components.rigid.quaternion import body_axis
from components.rigid_body import RigidBody
from cosim.errors import ScenarioError, SimulationError
from cosim.params import build
from cosim.record.reader import Recording
from cosim.replay import replay_component, restart_simulation
from cosim.runner import run_scene
from cosim.scenario import load, loads

RHO = 1000.0


@pytest.mark.parametrize("shape", ["sphere", "disk"])
def test_a_body_released_under_water_sinks_as_body_and_water_together(shape):
    """Released at rest, a slate sphere and a slate disk falling face on (its added mass 1.07 times
    its own) start at g (M - rho V) / (M + M_a) (potential flow) within 0.5%; without the effect at
    g (M - rho V) / M, 19% and 2.1 times faster."""
    with_it, without_it = ex.release_exact(shape)
    assert ex.release_under_water(shape).acceleration() == pytest.approx(with_it, rel=5e-3)
    assert ex.release_under_water(shape, added_mass=False).acceleration() == pytest.approx(without_it, rel=2.5e-2)


def test_a_ball_lighter_than_its_added_mass_rises_steadily():
    """A cork-light ball (200 kg/m^3: its added mass is 2.5 times its own) released under water rises
    at g (rho V - M) / (M + M_a) = 11.2 m/s^2, not at 39 m/s^2 (measured from 3 to 8 ms: its drag
    grows sooner than the heavy ones'); the force held a step late would overshoot and grow (the
    added-mass instability of partitioned schemes), taken by the body it cannot."""
    release = ex.release_under_water("sphere", density=200.0)
    assert release.acceleration(3.0, 8.0) == pytest.approx(ex.release_exact("sphere", 200.0)[0], rel=1e-2)
    steps = sorted(release.vz)
    assert all(release.vz[b] > release.vz[a] for a, b in itertools.pairwise(steps[2:]))  # speeding up, no ringing


@pytest.mark.parametrize("shape", ["sphere", "disk"])
def test_the_energy_the_water_carries_along_is_in_the_books(shape):
    """Kinetic plus potential energy plus what the coupler says the water took stays constant to
    round-off over 0.3 s of sinking (without the added mass's own work it drifts by 1e-2 J for the
    sphere: the water set moving)."""
    values = list(ex.release_under_water(shape, until=0.3).energy.values())
    assert len(values) > 500
    assert max(values) - min(values) < 1e-12


@pytest.mark.parametrize("shape", ["sphere", "disk"])
def test_the_water_turning_with_a_tumbling_body_is_in_the_books(shape):
    """A body thrown under water spinning at 100 rad/s about its axis and tumbling at 30 rad/s across
    it (kinetic energy 0.017 J for the disk): the books close over 0.1 s to 1e-9 J, as they do without
    the added mass (6e-10 J: the held torque's work taken over a step by the trapezoid rule), the
    water's kinetic energy 1/2 omega . J omega taken with the body's axis at each end of a step (with
    the axis of the step's start alone they were 4.9e-5 J short)."""
    values = list(ex.release_under_water(shape, until=0.1, tumbling=True).energy.values())
    assert len(values) > 150
    assert max(values) - min(values) < 1e-9


def _body(**params) -> RigidBody:
    problems: list[str] = []
    built = build(RigidBody.Params, params, "stone", problems)
    assert not problems, problems
    return RigidBody("stone", built)


@pytest.mark.parametrize("integrator", ["verlet", "semi_implicit_euler", "rk4"])
@pytest.mark.parametrize("shape", ["sphere", "disk"])
def test_the_body_alone_takes_its_added_mass_exactly(shape, integrator):
    """The body alone, the buoyancy rho V g held on it and its whole added mass given: it sinks at
    g (M - rho V) / (M + M_a) exactly (to 1e-12; the scene's 0.5% above is the water's own forces
    besides), by every integrator."""
    body = _body(shape=shape, radius=0.05, thickness=0.006, density=2650.0, position=[0.0, 0.0, -1.0],
                 integrator=integrator)
    mass, volume = body.body.mass, body.body.volume
    added = full_added_mass(Shape.DISK if shape == "disk" else Shape.SPHERE, 0.05, RHO)
    buoyancy = Wrench(np.array([0.0, 0.0, RHO * volume * 9.81]), np.zeros(3))
    for k in range(200):
        state = body.step(k * 500_000, 500_000, {"wrench": buoyancy, "impulse": None, "added_mass": added})["state"]
    exact = -9.81 * (mass - RHO * volume) / (mass + added.axial)
    assert state.velocity[2] / 0.1 == pytest.approx(exact, rel=1e-12)


def test_a_changing_added_mass_alone_neither_speeds_nor_slows_the_body():
    """No force on it, the body's share of its added mass going 0, 1/4, 1/2, 1, 1/2, 0 (as it goes
    under and comes out): its velocity and its own kinetic energy stay as they were (the water's
    reaction is -M_a a, and a is zero), to round-off."""
    body = _body(gravity=[0.0, 0.0, 0.0], radius=0.05, thickness=0.006, density=2650.0, velocity=[0.0, 0.0, 2.0],
                 angular_velocity=[30.0, 0.0, 0.0], spin=200.0)
    full = full_added_mass(Shape.DISK, 0.05, RHO)
    start = body.initial_outputs()["state"]
    k = 0
    for share in (0.0, 0.25, 0.5, 1.0, 0.5, 0.0):
        for _ in range(100):
            state = body.step(k * 500_000, 500_000, {"wrench": None, "impulse": None,
                                                     "added_mass": scaled(full, share)})["state"]
            k += 1
    assert state.velocity[2] == pytest.approx(2.0, rel=1e-12)
    assert state.kinetic_energy == pytest.approx(start.kinetic_energy, rel=1e-12)


def test_the_body_takes_the_water_along_its_axis_and_across_it_apart():
    """(M + M_a) a = F: along the axis with the axial added mass, across it with the radial one; the
    water's moments of inertia about a diameter and about the axis are added to the body's."""
    axis = (0.0, 0.0, 1.0)
    added = AddedMass(2.0, 6.0, 5.0, 0.5)
    assert added.carried(2.0, axis, (1.0, 2.0, 4.0)) == pytest.approx((0.25, 0.5, 2.0))  # across: 2 / 8; along: 2 / 4
    assert added.with_inertia((3.0, 3.0, 5.0)) == pytest.approx((3.5, 3.5, 10.0))


def test_a_spinning_body_under_water_precesses_at_its_own_rate():
    """A fast-spinning disk wholly under water, a torque across its axis held on it: its axis turns
    at T / (I_a Omega), its spin's angular momentum alone, whatever water it turns about a diameter
    (that water slows only the nutation); scaling the torque by I_d / (I_d + J_d) instead turned it
    at 0.65 of that rate. Over 0.1 s (eight turns of its nutation) the axis turns within 2% of
    T t / (I_a Omega)."""
    radius, thickness, spin = 0.05, 0.015, 2 * math.pi * 65
    problems: list[str] = []
    params = build(RigidBody.Params, {"shape": "disk", "radius": radius, "thickness": thickness, "density": 2650.0,
                                      "position": [0.0, 0.0, -1.0], "spin": spin, "gravity": [0.0, 0.0, 0.0],
                                      "integrator": "semi_implicit_euler"}, "stone", problems)
    assert not problems, problems
    body = RigidBody("stone", params)
    water = full_added_mass(Shape.DISK, radius, RHO)
    i_a = body.body.inertia[2]
    torque = 0.05  # [N m] about x, across the axis
    dt, steps = 1e-4, 1000
    for k in range(steps):
        body.step(k * int(dt * 1e9), int(dt * 1e9), {"wrench": Wrench(np.zeros(3), np.array([torque, 0.0, 0.0])),
                                                     "added_mass": water})
    axis = body_axis(tuple(body.body_state().orientation.tolist()))
    turned = math.degrees(math.acos(min(1.0, abs(axis[2]))))
    expected = math.degrees(torque * dt * steps / (i_a * spin))
    assert turned == pytest.approx(expected, rel=0.02)


def test_the_added_mass_comes_in_as_the_body_goes_under():
    """Potential-flow values wholly under water, scaled by the submerged share (0 at the surface)."""
    disk = full_added_mass(Shape.DISK, 0.05, RHO)
    assert (disk.axial, disk.radial, disk.axial_inertia) == (pytest.approx(8.0 / 3.0 * RHO * 0.05**3), 0.0, 0.0)
    assert disk.diameter_inertia == pytest.approx(16.0 / 45.0 * RHO * 0.05**5)
    assert scaled(disk, 0.5).axial == pytest.approx(0.5 * disk.axial)
    assert not any((scaled(disk, 0.0).axial, scaled(disk, 0.0).diameter_inertia))


def test_an_added_mass_that_reaches_no_body_is_refused():
    """Named among the effects but not connected, the added mass would silently do nothing."""
    text = ex.RELEASE_SCENE.format(until=0.01, shape="sphere", radius=0.02, thickness=0.006, density=2650.0,
                                   added=", added_mass", connection="", motion="")
    with pytest.raises(ScenarioError, match=r"components\.coupler: its output 'added_mass' feeds nothing, but "
                                            r"effect added_mass acts only through it"):
        loads(text)


def test_an_added_mass_that_is_none_is_refused():
    """A negative or non-finite added mass (a connection's initial value, or any source) would turn the
    body's inertia negative or infinite: refused at load, naming the field, and at run time, naming
    the input (a slate started with -0.125 kg along its axis flew off at 90 m/s in 10 ms)."""
    skip = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    with pytest.raises(ScenarioError) as caught:
        load(skip, ["connections.3.initial.axial=-0.125"])
    assert str(caught.value).endswith("components.stone: its input 'added_mass' starts with axial = -0.125 kg: an "
                                      "added mass is finite and at least 0 (the initial value of the connection "
                                      "into it)")
    stone = RigidBody("stone")
    stone.start_outputs()
    with pytest.raises(SimulationError, match=r"input 'added_mass': diameter_inertia = nan kg m\^2: an added mass"):
        stone.step(0, 500_000, {"added_mass": AddedMass(0.0, 0.0, 0.0, math.nan)})


def test_a_sinking_body_replays_and_restarts_bit_for_bit(tmp_path):
    """Recorded while its added mass acts, the sinking slate's components replay alone bit for bit, and
    a restart from the checkpoint at 0.1 s (the coupler's book and the added mass the body holds
    restored) gives the same later states and energy books."""
    text = ex.RELEASE_SCENE.format(until=0.2, shape="disk", radius=0.02, thickness=0.006, density=2650.0,
                                   added=", added_mass", connection=ex.RELEASE_ADDED_MASS, motion="")
    text += "record: {checkpoint_every: 0.1}\n"
    recording = Recording(run_scene(loads(text), tmp_path / "sink.mcap", progress=False).recording)
    for name in ("body", "coupler", "pond"):
        report = replay_component(recording, name)
        assert report.ok, str(report)
    assert len(list(recording.messages("/coupler/added_mass", AddedMass))) >= 2  # none, then the full one
    sim, stamp = restart_simulation(recording, 150_000_000)
    assert stamp == 100_000_000
    again = Recording(run_scene(sim.scene, tmp_path / "again.mcap", progress=False, simulation=sim).recording)
    later = [(t, m.position.tobytes()) for t, m in recording.messages("/body/state", BodyState) if t > stamp]
    assert [(t, m.position.tobytes()) for t, m in again.messages("/body/state", BodyState)] == later
    books = [(t, m.dissipated_energy) for t, m in recording.messages("/coupler/contact", WaterContact) if t > stamp]
    assert [(t, m.dissipated_energy) for t, m in again.messages("/coupler/contact", WaterContact)] == books
