"""The SolidGround component: alone with hand-made body states, then in the body <-> ground loop
driven by hand the way the scheduler drives it (components.ground)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from components.ground import SolidGround
from components.messages import BodyState, GroundContact, Impulse, Shape
from components.rigid import quaternion as quat
from components.rigid.dynamics import inertia_solve
from components.rigid_body import RigidBody
from cosim.errors import SimulationError
from cosim.messages import messages_equal
from cosim.params import build

DT_NS = 500_000
DT = DT_NS / 1e9
G = 9.81
R, E = 0.05, 0.006
H = 0.5 * E  # centre height of a flat disk lying on the floor [m]


def make(cls, name, **params):
    problems: list[str] = []
    p = build(cls.Params, params, name, problems)
    assert not problems, problems
    return cls(name, p)


def body(**params) -> RigidBody:
    return make(RigidBody, "stone", **{"radius": R, "thickness": E, **params})


def ground(**params) -> SolidGround:
    return make(SolidGround, "ground", **params)


def simulate(stone, floor, steps):
    """The scene loop: stone steps (impulse from the previous tick, delay 1), then the ground sees the
    stone's new state (direct edge). Returns [(BodyState, GroundContact)] per tick."""
    pending = None
    trace = []
    for k in range(steps):
        state = stone.step(k * DT_NS, DT_NS, {"wrench": None, "impulse": pending})["state"]
        out = floor.step(k * DT_NS, DT_NS, {"body": state})
        pending = out.get("impulse")
        trace.append((state, out["contact"]))
    return trace


def books(trace):
    """Kinetic + potential energy of each published state plus the dissipation booked before it."""
    energy = np.array([s.kinetic_energy + s.potential_energy for s, _ in trace])
    dissipated = np.array([c.dissipated_energy for _, c in trace])
    return energy[1:] + dissipated[:-1]


def state_message(stone, position, orientation, velocity, angular_velocity) -> BodyState:
    stone.set_state({"position": position, "orientation": orientation, "velocity": velocity,
                     "angular_velocity": angular_velocity})
    return stone.body_state()


# --- the component alone -----------------------------------------------------------------------------

def test_kinetic_friction_above_static_is_rejected():
    """mu_kinetic > mu_static is a parameter problem naming both values."""
    problems: list[str] = []
    build(SolidGround.Params, {"mu_static": 0.3, "mu_kinetic": 0.5}, "ground", problems)
    assert problems == ["ground.mu_kinetic: must be <= mu_static (0.3) (got 0.5)"]


def test_without_contact_only_the_contact_report_is_published():
    """A body far above the plane, or no body at all: no impulse, in_contact false."""
    floor = ground()
    far = body(position=[0, 0, 1.0]).initial_outputs()["state"]
    for inputs in ({"body": far}, {"body": None}):
        out = floor.step(0, DT_NS, inputs)
        assert set(out) == {"contact"}
        assert not out["contact"].in_contact


def test_initial_outputs_are_a_zero_impulse_and_no_contact():
    """At t = 0 the ground publishes a zero impulse and 'not in contact'."""
    out = ground().initial_outputs()
    assert messages_equal(out["impulse"], Impulse.zero())
    assert messages_equal(out["contact"], GroundContact(False, 0.0, 0.0, False, 0.0))


@pytest.mark.parametrize("tilt_deg", [15.0, 30.0, 60.0])
def test_tilted_rim_impact_matches_the_impulse_formula(tilt_deg):
    """A tilted disk hitting a frictionless floor on its rim: the published impulse gives the body the
    linear and angular velocities of physics.md's formula within 1e-9 relative (spin-up included)."""
    th = math.radians(tilt_deg)
    stone = body(gravity=[0, 0, 0])
    q = quat.from_axis_angle((1.0, 0.0, 0.0), th)
    z = R * math.sin(th) + H * math.cos(th) - 1e-13  # rim corner just touching
    v, w = (0.7, -0.3, -2.0), (4.0, 1.0, 30.0)
    msg = state_message(stone, [0.0, 0.0, z], list(q), list(v), list(w))
    floor = ground(restitution=0.6, mu_static=0.0, mu_kinetic=0.0, gravity=[0, 0, 0])
    imp = floor.step(0, DT_NS, {"body": msg})["impulse"]
    # physics.md: K = 1/M + (r x n).I^-1 (r x n), P = -(1 + e) v_n / K, v += P n / M, w += I^-1 (r x n) P
    n = np.array([0.0, 0.0, 1.0])
    r = np.array([0.0, -R * math.cos(th) + H * math.sin(th), -R * math.sin(th) - H * math.cos(th)])
    rot = np.array([quat.rotate(q, e) for e in np.eye(3)]).T
    inv_i = rot @ np.diag(1.0 / np.array(stone.body.inertia)) @ rot.T
    rn = np.cross(r, n)
    vn = (np.array(v) + np.cross(w, r)) @ n
    p = -(1 + 0.6) * vn / (1 / stone.body.mass + rn @ inv_i @ rn)
    v_expected = np.array(v) + p * n / stone.body.mass
    w_expected = np.array(w) + inv_i @ rn * p
    v_after = np.array(v) + imp.linear / stone.body.mass
    w_after = np.add(w, inertia_solve(stone.body.inertia, quat.body_axis(q), tuple(imp.angular)))
    assert np.linalg.norm(v_after - v_expected) <= 1e-9 * np.linalg.norm(v_expected)
    assert np.linalg.norm(w_after - w_expected) <= 1e-9 * np.linalg.norm(w_expected)
    # and the body applies it so on its next step (no gravity or torque: v and L are kept by the flight)
    after = stone.step(DT_NS, DT_NS, {"wrench": None, "impulse": imp})["state"]
    assert np.linalg.norm(after.velocity - v_expected) <= 1e-9 * np.linalg.norm(v_expected)
    momentum = rot @ np.diag(stone.body.inertia) @ rot.T @ w_expected
    q1 = tuple(after.orientation)
    rot1 = np.array([quat.rotate(q1, e) for e in np.eye(3)]).T
    momentum_after = rot1 @ np.diag(stone.body.inertia) @ rot1.T @ after.angular_velocity
    assert np.linalg.norm(momentum_after - momentum) <= 1e-9 * np.linalg.norm(momentum)


def test_a_gravity_other_than_the_bodys_is_reported():
    """A ground assuming another gravity than the body's fails on contact, naming both energies
    (a body whose gravity it cannot see, an FMU's, say); a RigidBody's scene is refused at load."""
    stone = body(position=[0, 0, H - 1e-6], gravity=[0, 0, -3.71])
    floor = ground()
    with pytest.raises(SimulationError, match=r"gravity \[0.0, 0.0, -9.81\] m/s\^2 does not match"):
        floor.step(0, DT_NS, {"body": stone.initial_outputs()["state"]})
    assert ground().check_start_sources({}, {"body": stone}) == [
        "gravity [0.0, 0.0, -9.81] m/s^2 is not the gravity of its body stone ([0.0, 0.0, -3.71] m/s^2): set gravity "
        "to [0.0, 0.0, -3.71]"]
    assert ground(gravity=[0, 0, -3.71]).check_start_sources({}, {"body": stone}) == []


def test_ground_checkpoint_reproduces_the_run_bit_for_bit():
    """set_state(get_state()) on a fresh ground, fed the same states, publishes the same messages."""
    stone = body(position=[0, 0, 0.01], tilt_deg=5.0, velocity=[1.0, 0, 0], angular_velocity=[0, 0, 20.0])
    floor = ground()
    simulate(stone, floor, 200)
    saved = floor.get_state()
    states = [s for s, _ in simulate(stone, floor, 50)]
    floor.set_state(saved)
    first = [floor.step(0, DT_NS, {"body": s}) for s in states]
    other = ground()
    other.set_state(saved)
    second = [other.step(0, DT_NS, {"body": s}) for s in states]
    assert sum(out["contact"].in_contact for out in first) > 15
    for a, b in zip(first, second, strict=True):
        assert a.keys() == b.keys() and all(messages_equal(a[k], b[k]) for k in a)


# --- the loop: bounces -------------------------------------------------------------------------------

def apex_heights(trace, rest):
    """Height above ``rest`` of each apex, from the first rising state after each bounce (exact: free
    flight under Verlet is exact)."""
    heights = []
    rising = False
    for s, _ in trace:
        vz = s.velocity[2]
        if vz > 0 and not rising:
            heights.append(s.position[2] + vz * vz / (2 * G) - rest)
        rising = vz > 0
    return heights


@pytest.mark.parametrize("restitution", [0.8, 0.5])
def test_flat_drop_bounce_heights_fall_as_e_squared(restitution):
    """A flat disk dropped from 10 cm: each bounce height is e^2 times the previous, within 1%."""
    stone = body(position=[0, 0, 0.1 + H])
    trace = simulate(stone, ground(restitution=restitution), 3000)
    heights = [0.1, *apex_heights(trace, H)[:5]]
    assert len(heights) == 6
    ratios = np.array(heights[1:]) / np.array(heights[:-1])
    assert np.allclose(ratios, restitution ** 2, rtol=0.01), ratios


def test_sphere_bounces_as_e_squared_and_rests_on_its_bottom():
    """A dropped sphere bounces with heights e^2 and rests with its centre R above the floor."""
    stone = body(shape="sphere", radius=0.02, position=[0, 0, 0.12])
    trace = simulate(stone, ground(restitution=0.7), 6000)
    heights = [0.1, *apex_heights(trace, 0.02)[:4]]
    assert np.allclose(np.array(heights[1:]) / np.array(heights[:-1]), 0.49, rtol=0.01)
    last, contact = trace[-1]
    assert last.position[2] == pytest.approx(0.02 - 0.5 * G * DT * DT, abs=1e-12)
    assert contact.normal_force == pytest.approx(last.mass * G, rel=1e-9)


def test_energy_books_close_through_bounces():
    """Kinetic + potential + dissipated energy is constant to round-off through a series of bounces."""
    trace = simulate(body(position=[0, 0, 0.1 + H]), ground(restitution=0.7), 4000)
    e = books(trace)
    assert np.ptp(e) < 1e-12 * abs(e[0])


@pytest.mark.parametrize("restitution", [0.0, 0.5, 0.9])
def test_tilted_drop_settles_flat_with_closed_books(restitution):
    """A disk dropped at 30 degrees hits its rim, rocks and comes to rest lying flat in face contact
    within 2 s (the rocking is not kept alive by the position corrections); the energy books close to
    1e-12 relative."""
    stone = body(position=[0, 0, 0.1], tilt_deg=30.0, tilt_axis=[1, 0, 0])
    floor = ground(restitution=restitution)
    trace = simulate(stone, floor, 4000)
    last, contact = trace[-1]
    assert floor.impacts >= (0 if restitution == 0 else 5)
    assert last.attack_angle_deg < 0.01
    assert contact.in_contact and contact.normal_force == pytest.approx(last.mass * G, rel=1e-6)
    assert np.linalg.norm(last.angular_velocity) < 1e-9
    e = books(trace)
    assert np.ptp(e) < 1e-12 * abs(e[0])


# --- the loop: resting and sliding -------------------------------------------------------------------

def test_flat_disk_rests_without_jitter_or_creep():
    """A disk lying flat for 10 s: every published state identical after the first steps, the normal
    force equal to the weight, no rocking."""
    stone = body(position=[0, 0, H], angular_velocity=[0, 0, 0])
    trace = simulate(stone, ground(), 20_000)
    positions = np.array([s.position for s, _ in trace[10:]])
    assert np.ptp(positions, axis=0).max() < 1e-15
    assert all(s.attack_angle_deg == 0.0 for s, _ in trace)
    assert trace[-1][1].normal_force == pytest.approx(trace[-1][0].mass * G, rel=1e-12)


def slope_disk(slope_deg):
    """A disk lying flat on a slope descending towards +x, touching it at the origin."""
    phi = math.radians(slope_deg)
    normal = (math.sin(phi), 0.0, math.cos(phi))
    return body(position=[H * c for c in normal], tilt_deg=slope_deg, tilt_axis=[0, 1, 0])


@pytest.mark.parametrize("slope_deg", [20.0, math.degrees(math.atan(0.5)) - 0.01])
def test_disk_holds_on_a_slope_below_the_friction_angle(slope_deg):
    """With tan(slope) <= mu_s the disk stays put for 10 s: drift under 1e-6 m, static friction."""
    floor = ground(slope_deg=slope_deg, mu_static=0.5, mu_kinetic=0.4)
    trace = simulate(slope_disk(slope_deg), floor, 20_000)
    positions = np.array([s.position for s, _ in trace])
    assert np.abs(positions - positions[0]).max() < 1e-6
    assert not trace[-1][1].sliding and trace[-1][1].in_contact
    phi = math.radians(slope_deg)
    assert trace[-1][1].friction_force == pytest.approx(trace[-1][0].mass * G * math.sin(phi), rel=1e-9)
    assert trace[-1][1].normal_force == pytest.approx(trace[-1][0].mass * G * math.cos(phi), rel=1e-9)


def test_disk_slides_down_a_steep_slope_at_g_sin_minus_mu_cos():
    """With tan(slope) > mu_s the disk slides with a = g (sin - mu_k cos) within 1%; kinetic + potential
    + dissipated energy stays constant within 0.5%, and the dissipation is mu_k N times the distance."""
    slope, mu_k = 35.0, 0.4
    phi = math.radians(slope)
    trace = simulate(slope_disk(slope), ground(slope_deg=slope, mu_static=0.5, mu_kinetic=mu_k), 4000)
    t = DT * np.arange(1, len(trace) + 1)
    down = np.array([math.cos(phi), 0.0, -math.sin(phi)])
    distance = np.array([s.position @ down for s, _ in trace])
    a = 2 * np.polyfit(t, distance, 2)[0]
    expected = G * (math.sin(phi) - mu_k * math.cos(phi))
    assert a == pytest.approx(expected, rel=0.01)
    assert all(c.sliding for _, c in trace[1:])
    total = np.array([s.kinetic_energy + s.potential_energy + c.dissipated_energy for s, c in trace])
    scale = trace[-1][1].dissipated_energy
    assert np.ptp(total) < 0.005 * scale
    mass = trace[0][0].mass
    assert trace[-1][1].dissipated_energy == pytest.approx(mu_k * mass * G * math.cos(phi) * distance[-1],
                                                           rel=1e-3)


def test_flat_disk_thrown_along_the_floor_stops_at_v2_over_2_mu_g():
    """A disk sliding flat at 2 m/s stops after v^2 / (2 mu_k g) and stays flat."""
    trace = simulate(body(position=[0, 0, H], velocity=[2.0, 0, 0]), ground(mu_kinetic=0.4), 1500)
    last = trace[-1][0]
    assert last.position[0] == pytest.approx(4.0 / (2 * 0.4 * G), rel=1e-3)
    assert last.velocity[0] == 0.0 and last.attack_angle_deg == 0.0


def test_spinning_flat_disk_slows_by_torsional_friction():
    """A flat disk spinning on the floor loses spin at 4/3 mu_k g / R (uniform pressure, arm 2R/3)."""
    trace = simulate(body(position=[0, 0, H], angular_velocity=[0, 0, 50.0]), ground(mu_kinetic=0.4), 1500)
    spin = np.array([s.angular_velocity[2] for s, _ in trace])
    t = DT * np.arange(1, len(trace) + 1)
    turning = spin > 1.0
    rate = np.polyfit(t[turning][5:], spin[turning][5:], 1)[0]
    assert rate == pytest.approx(-4.0 / 3.0 * 0.4 * G / R, rel=1e-3)
    assert spin[-1] == 0.0


def test_sliding_sphere_ends_rolling_at_five_sevenths_of_its_speed():
    """A sphere launched sliding without spin ends rolling at 5/7 of its speed, having dissipated
    1/2 M v^2 (1 - 5/7)."""
    stone = body(shape="sphere", radius=0.02, position=[0, 0, 0.02], velocity=[2.0, 0, 0])
    trace = simulate(stone, ground(mu_static=0.5, mu_kinetic=0.3), 1000)
    last, contact = trace[-1]
    assert last.velocity[0] == pytest.approx(2.0 * 5 / 7, rel=1e-9)
    assert last.angular_velocity[1] * 0.02 == pytest.approx(2.0 * 5 / 7, rel=1e-9)
    assert contact.dissipated_energy == pytest.approx(0.5 * last.mass * 4.0 * (1 - 5 / 7), rel=1e-6)


def test_sphere_rolls_down_a_slope_at_five_sevenths_g_sin():
    """A sphere on a 20 degree slope with enough friction rolls without slipping at 5/7 g sin(slope)."""
    phi = math.radians(20.0)
    normal = np.array([math.sin(phi), 0.0, math.cos(phi)])
    stone = body(shape="sphere", radius=0.02, position=list(0.02 * normal))
    trace = simulate(stone, ground(slope_deg=20.0, mu_static=0.5, mu_kinetic=0.4), 1000)
    t = DT * np.arange(1, len(trace) + 1)
    down = np.array([math.cos(phi), 0.0, -math.sin(phi)])
    a = 2 * np.polyfit(t, [s.position @ down for s, _ in trace], 2)[0]
    assert a == pytest.approx(5 / 7 * G * math.sin(phi), rel=1e-6)
    assert not trace[-1][1].sliding
    assert abs(trace[-1][1].dissipated_energy) < 1e-9


def test_locked_attitude_bounces_on_translation_alone():
    """A spinning body with a locked attitude (ground told so) bounces with the translational impulse
    only: the rebound is -e v_n of its centre and the spin is untouched."""
    stone = body(position=[0, 0, 0.1], tilt_deg=20.0, spin=400.0, lock_attitude=True)
    floor = ground(restitution=0.5, mu_static=0.0, mu_kinetic=0.0)
    trace = simulate(stone, floor, 400)
    first_up = next(s for s, _ in trace if s.velocity[2] > 0)
    drop = 0.1 - (R * math.sin(math.radians(20.0)) + H * math.cos(math.radians(20.0)))
    apex = first_up.position[2] + first_up.velocity[2] ** 2 / (2 * G)
    assert apex - (0.1 - drop) == pytest.approx(0.25 * drop, rel=1e-6)
    assert np.array_equal(trace[-1][0].angular_velocity, trace[0][0].angular_velocity)


def test_summary_counts_bounces_and_dissipation():
    """The closing summary gives the number of bounces, in how many contacts (the spells of touching
    that plot counts: the last touchdown, too slow to bounce, is one without a bounce; it printed
    "12 bounces" where the plot showed 13 contacts), and the energy dissipated."""
    floor = ground(restitution=0.5)
    trace = simulate(body(position=[0, 0, 0.05 + H]), floor, 2000)
    touching = [c.in_contact for _, c in trace]
    spells = sum(1 for before, now in zip([False, *touching], touching, strict=False) if now and not before)
    (line,) = floor.summary()
    assert line.startswith(f"ground: {floor.impacts} bounces in {spells} contacts, ")
    assert line.endswith("J dissipated, body at rest on it")
    assert floor.impacts >= 3 and spells == floor.impacts + 1


def test_summaries_of_a_resting_body_say_it_rests():
    """A body resting on the ground ends each step fallen for one step (g dt): the ground says that its
    answer leaves it at rest, the body that its speed and energies are those before that answer (it
    printed "speed 0.004905 m/s" as the body's speed at rest)."""
    stone, floor = body(position=[0, 0, 0.05 + H]), ground(restitution=0.5)
    simulate(stone, floor, 2000)
    assert floor.summary()[0].endswith("body at rest on it")
    line = stone.summary()[0]
    assert ", speed 0.004905 m/s, kinetic " in line
    assert line.endswith(" J (its last step's end, before the contact's answer to it)")
    assert "before the contact's answer" not in body(position=[0, 0, 1.0]).summary()[0]
    assert Shape.DISK == 0
