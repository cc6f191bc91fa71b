"""A SolidGround's energy books when the body feels forces besides gravity (buoyancy under water):
the ground charges its position corrections against them too, so its dissipated energy never falls
and kinetic + potential + dissipated (+ the other forces' work) stays constant
(components.contact.solver, point 4 of its docstring; components.ground)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from components.contact.geometry import slope_plane
from components.contact.solver import Material, resolve_contact
from components.ground import SolidGround
from components.messages import Shape, Wrench
from components.rigid.dynamics import RigidState
from components.rigid.shapes import mass_properties
from components.rigid_body import RigidBody
from cosim.params import build
from cosim.scenario import load
from cosim.scheduler import Simulation
from tests.toys import Channels

SCENES = Path(__file__).resolve().parent.parent / "scenarios"
G = 9.81
DT_NS = 1_000_000
DT = DT_NS / 1e9
R = 0.03  # [m] the granite ball of scenarios/float_sphere.yaml
BALL = mass_properties(Shape.SPHERE, R, 0.0, density=2650.0)
BUOYANCY = 1000.0 * G * 4.0 / 3.0 * math.pi * R**3  # [N] of the ball wholly under water


def make(cls, name, **params):
    problems: list[str] = []
    p = build(cls.Params, params, name, problems)
    assert not problems, problems
    return cls(name, p)


def test_a_resting_step_under_water_dissipates_nothing():
    """A ball resting on the bed under water, one step after it was put back on it: it fell by
    a dt^2/2 under its weight less its buoyancy (a = g - B/M); the ground's response takes its
    speed and lifts it back, and books 0 J, not the -B a dt^2/2 of a lift charged against gravity
    alone."""
    a = G - BUOYANCY / BALL.mass
    state = RigidState((0.0, 0.0, R - 0.5 * a * DT * DT), (1.0, 0.0, 0.0, 0.0), (0.0, 0.0, -a * DT), (0.0, 0.0, 0.0))
    floor, material, g = slope_plane((0.0, 0.0, 0.0), 0.0), Material(restitution=0.2), (0.0, 0.0, -G)
    dry = resolve_contact(BALL, state, floor, material, g, DT)
    wet = resolve_contact(BALL, state, floor, material, g, DT, other_force=(0.0, 0.0, BUOYANCY))
    assert dry.dissipated == pytest.approx(-BUOYANCY * 0.5 * a * DT * DT, rel=1e-9)  # the lift's share
    assert abs(wet.dissipated) < 1e-15 * BALL.mass * G * R
    assert wet.linear == dry.linear and wet.correction == dry.correction  # the response itself is the same


def test_ground_books_close_under_a_held_upward_force():
    """A ball let go just above a floor under a held upward force (buoyancy without water) settles:
    the ground's dissipated energy never falls, and kinetic + potential + dissipated minus the
    force's work along the published positions stays constant to round-off (the ground reads the
    force off the body's change of velocity: it is not wired to it)."""
    stone = make(RigidBody, "stone", shape="sphere", radius=R, density=2650.0, position=[0.0, 0.0, R + 0.01])
    ground = make(SolidGround, "ground", restitution=0.2)
    lift = Wrench(np.array([0.0, 0.0, BUOYANCY]), np.zeros(3))
    pending, energy, books, work, x_prev = None, [], [], 0.0, None
    for k in range(1500):
        state = stone.step(k * DT_NS, DT_NS, {"wrench": lift, "impulse": pending})["state"]
        out = ground.step(k * DT_NS, DT_NS, {"body": state})
        pending = out.get("impulse")
        if x_prev is not None:
            work += BUOYANCY * (state.position[2] - x_prev)
        x_prev = state.position[2]
        energy.append(state.kinetic_energy + state.potential_energy - work)
        books.append(out["contact"].dissipated_energy)
    assert ground.impacts >= 2 and out["contact"].in_contact
    assert np.all(np.diff(books) >= 0.0)
    total = np.array(energy[1:]) + np.array(books[:-1])  # a ground's report reaches the body's next state
    assert np.ptp(total) < 1e-12 * BALL.mass * G * 0.01


def test_float_sphere_ground_books_never_fall_and_close():
    """scenarios/float_sphere.yaml to 1 s: the granite ball lands on the bed (three bounces by 0.43 s)
    and rests there. The bed's dissipated energy never decreases (it fell by 3.4e-6 J a step when
    the buoyancy's share of each lift was charged to it), and the granite's kinetic + potential
    energy plus what the water and the bed dissipated stays constant within the one thing the bed
    cannot know: how the water's force changes in the step after its correction, at most the sum
    of |W_k - W_(k-1)| |c_k| over the corrections (9.0e-5 J here, against 0.79 J exchanged: the water's
    force changes most as the ball's underside, pressed into the bed at a landing, leaves the water, and
    as the water, told of the bed's answer (scenarios/float_sphere.yaml wires it), turns at once from
    resisting the fall to resisting the rebound; 5.4e-5 J before it was told)."""
    watch = Channels("granite.state", "granite_water.contact", "granite_water.wrench", "bottom.contact",
                     "bottom.impulse")
    sim = Simulation(load(SCENES / "float_sphere.yaml"), observers=[watch])
    assert sim.run(1_000_000_000).status == "ok"
    ground = np.array([m.dissipated_energy for m in watch.messages("bottom.contact")])
    assert ground[-1] > 0.28 and np.all(np.diff(ground) >= 0.0)
    body = np.array([m.kinetic_energy + m.potential_energy for m in watch.messages("granite.state")])
    water = np.array([m.dissipated_energy for m in watch.messages("granite_water.contact")])
    total = body[1:] + water[1:] + ground[:-1]
    # the bound: each published correction against the change of the water's force it was booked with
    forces = np.array([m.force for m in watch.messages("granite_water.wrench")])
    contact = np.array([m.in_contact for m in watch.messages("bottom.contact")])
    corrections = iter(watch.messages("bottom.impulse")[1:])  # (the first is the connection's initial value)
    bound = sum(np.abs(forces[k] - forces[k - 1]) @ np.abs(next(corrections).correction)
                for k in np.flatnonzero(contact) if k > 0)
    assert np.abs(total - total[0]).max() <= bound + 1e-12
    assert bound < 1.5e-4 * (body[0] - body.min())  # small beside the energy exchanged (0.79 J)


@pytest.mark.parametrize("scene", sorted(p.name for p in SCENES.glob("*.yaml")
                                         if "type: SolidGround" in p.read_text()))
def test_shipped_ground_books_never_fall(scene):
    """In every shipped scene with a SolidGround, each ground's dissipated energy never decreases
    (ground_bounce's tilted disk used to gain 0.7 mJ at a rim impact whose friction kept pushing
    after the impulse had reversed the slip, Kane's paradox, and 1.2 uJ a step resting on a rim
    point lifted by its whole fall)."""
    config = load(SCENES / scene)
    grounds = [name for name, c in config.components.items() if c.type_name == "SolidGround"]
    watch = Channels(*(f"{g}.contact" for g in grounds))
    sim = Simulation(config, observers=[watch])
    assert sim.run(min(config.until_ns, 3_000_000_000)).status == "ok"  # (float_sphere rests by 0.5 s)
    for g in grounds:
        books = np.array([m.dissipated_energy for m in watch.messages(f"{g}.contact")])
        assert books[-1] > 0.0 and np.all(np.diff(books) >= 0.0), g


def test_a_ball_resting_on_the_bed_does_not_start_to_roll():
    """The granite ball of float_sphere.yaml sinks straight down and rests on the bed from 0.43 s,
    in the middle of its pond. The water's pressure on a sphere acts through its centre, and the
    water moves alike on either side of it, so nothing turns it, sinking or resting: its spin stays
    at round-off (6e-17 rad/s). The columns' buoyancy torque, sampling error that grew with the
    ball's place on the grid, set it rolling: 2.7e-6, 7.9e-4 and 4.0e-3 rad/s at 0.5, 2 and 6 s; the
    drag of its surface pieces, which were neither at its centre nor mirror images across x, left it
    turning at 1e-6 rad/s from its sinking."""
    watch = Channels("granite.state")
    sim = Simulation(load(SCENES / "float_sphere.yaml"), observers=[watch])
    assert sim.run(3_000_000_000).status == "ok"
    spin = np.array([np.linalg.norm(m.angular_velocity) for m in watch.messages("granite.state")])
    assert spin.max() < 1e-12


@pytest.mark.parametrize(("impacts", "contacts", "said"),
                         [(0, 0, "floor: 0 bounces in 0 contacts, "), (1, 1, "floor: 1 bounce in 1 contact, "),
                          (2, 3, "floor: 2 bounces in 3 contacts, "), (2, None, "floor: 2 bounces, ")])
def test_the_grounds_summary_counts_its_bounces_in_words(impacts, contacts, said):
    """(None: restored from a checkpoint older than the contacts' count, which is then not known.)"""
    ground = make(SolidGround, "floor")
    ground.impacts, ground.contacts = impacts, contacts
    assert ground.summary()[0].startswith(said)


def test_a_tilted_disk_settling_at_coarse_steps_never_gains_energy_from_a_face_lift():
    """A disk tilted 10 deg dropped from 12 cm at 2 ms steps (Verlet, e 0.9, mu 1.0 and 0.8): as it
    settles from rocking on its rim to lying flat within the face's tolerance, the face was lifted by
    its lowest rim point's penetration, more than its centre had fallen, and the ground's book fell by
    1.8 uJ there. Each response now dissipates zero or more."""
    step_ns = 2_000_000
    disk = make(RigidBody, "disk", shape="disk", radius=0.05, thickness=0.006, density=2700.0,
                position=[0.0, 0.0, 0.12], tilt_deg=10.0, tilt_axis=[1.0, 0.0, 0.0])
    ground = make(SolidGround, "ground", restitution=0.9, mu_static=1.0, mu_kinetic=0.8)
    pending, books = None, []
    for k in range(1000):
        state = disk.step(k * step_ns, step_ns, {"impulse": pending})["state"]
        out = ground.step(k * step_ns, step_ns, {"body": state})
        pending = out.get("impulse")
        books.append(out["contact"].dissipated_energy)
    assert out["contact"].in_contact and ground.impacts >= 5
    assert np.all(np.diff(books) >= 0.0)
