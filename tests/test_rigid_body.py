"""The RigidBody component alone, driven with hand-made messages (components.rigid_body)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from components.messages import BodyState, Impulse, Shape, Wrench
from components.rigid import quaternion as quat
from components.rigid_body import RigidBody
from cosim.codec.json_codec import codec_for
from cosim.errors import SimulationError
from cosim.messages import messages_equal
from cosim.params import build

DT_NS = 500_000  # 0.5 ms, the scenes' base step
DT = DT_NS / 1e9
G = 9.81


def make(**params) -> RigidBody:
    problems: list[str] = []
    p = build(RigidBody.Params, params, "stone", problems)
    assert not problems, problems
    return RigidBody("stone", p)


def run(body, steps, wrench=None, impulses=None, start=0):
    """Step ``body`` with a held wrench and {step index: Impulse} events; return the last state."""
    impulses = impulses or {}
    out = None
    for k in range(start, start + steps):
        out = body.step(k * DT_NS, DT_NS, {"wrench": wrench, "impulse": impulses.get(k)})["state"]
    return out


def problems_of(**params) -> list[str]:
    problems: list[str] = []
    build(RigidBody.Params, params, "stone", problems)
    return problems


# --- parameters ------------------------------------------------------------------------------------

def test_unknown_integrator_is_reported_with_the_choices():
    """integrator: an unknown name is a parameter problem listing the registered choices."""
    assert problems_of(integrator="euler") == [
        "stone.integrator: unknown integrator 'euler' (choices: verlet, semi_implicit_euler, rk4)"]


@pytest.mark.parametrize(("params", "problem"), [
    ({"thickness": 0.0}, "stone.thickness: a disk needs thickness > 0 m (got 0)"),
    ({"tilt_axis": [0, 0, 0]}, "stone.tilt_axis: must be a non-zero vector (got [0, 0, 0])"),
    ({"lock_attitude": True, "scripted_tilt_deg": [[0, 10]]},
     "stone.lock_attitude: cannot be combined with scripted_tilt_deg (choose one)"),
    ({"tilt_deg": 5.0, "scripted_tilt_deg": [[0, 10]]},
     "stone.tilt_deg: give either tilt_deg or scripted_tilt_deg, not both"),
    ({"scripted_tilt_deg": [[0, 10]], "angular_velocity": [1, 0, 0]},
     "stone.angular_velocity: is set by scripted_tilt_deg (with spin); leave it 0"),
    ({"scripted_velocity": [[1, 0, 0], [0.5, 1, 1]]},
     "stone.scripted_velocity: keyframe times must increase strictly (got 1 then 0.5)"),
    ({"radius": -1.0}, "stone.radius: must be > 0 m (got -1)"),
    ({"spin": 1e300}, "stone.spin: makes the stone's kinetic energy overflow a float (got 1e+300)"),
    ({"angular_velocity": [0, 0, 1e300]},
     "stone.angular_velocity: makes the stone's kinetic energy overflow a float (got (0.0, 0.0, 1e+300))"),
    ({"velocity": [1e200, 0, 0]},
     "stone.velocity: makes the stone's kinetic energy overflow a float (got (1e+200, 0.0, 0.0))"),
    # a held disk turned across its axis: the rim moved at 1 m/s, the attitude never turned
    ({"lock_attitude": True, "angular_velocity": [0, 20, 0]},
     "stone.angular_velocity: turns the held disk across its axis at 20 rad/s, which lock_attitude never does "
     "(the rim would move as if it did): give only its turn about the axis, as spin: 0, or leave the attitude "
     "free"),
    # a scripted tilt turning faster than a float holds (90 deg in 1e-320 s ran, then failed at t = 0 with
    # a non-finite kinetic energy in its state; an angle of 1e308 to -1e308 the same)
    ({"scripted_tilt_deg": [[0, 0], [1e-320, 90]]},
     "stone.scripted_tilt_deg: makes the stone's kinetic energy overflow a float (got [(0.0, 0.0), (1e-320, 90.0)])"),
    ({"scripted_tilt_deg": [[0, 1e308], [1, -1e308]]},
     "stone.scripted_tilt_deg: makes the stone's kinetic energy overflow a float "
     "(got [(0.0, 1e+308), (1.0, -1e+308)])"),
    # the moment of inertia out of range is blamed on what takes it there (it was always the radius)
    ({"density": 1e-300, "radius": 0.025, "thickness": 0.00275},
     "stone.density: gives the body a moment of inertia of 3.37476e-309 kg m^2, not a positive, finite, normal "
     "float (got 1e-300)"),
    ({"mass": 1e-305, "radius": 0.025},
     "stone.mass: gives the body a moment of inertia of 6.25e-309 kg m^2, not a positive, finite, normal float "
     "(got 1e-305)"),
    ({"lock_attitude": True, "tilt_deg": 90.0, "angular_velocity": [3, 0, 4]},
     "stone.angular_velocity: turns the held disk across its axis at 4 rad/s, which lock_attitude never does "
     "(the rim would move as if it did): give only its turn about the axis, as spin: -3, or leave the attitude "
     "free"),
])
def test_inconsistent_parameters_are_reported_with_their_path(params, problem):
    """Each rule across fields is reported as 'path: rule (got value)'."""
    assert problems_of(**params) == [problem]


def test_a_held_body_may_turn_about_its_axis_and_a_held_ball_any_way():
    """lock_attitude holds a spin about a disk's axis (here tilted 90 deg about y: the axis along
    +x), and any turn of a sphere, which looks the same turned any way."""
    assert problems_of(lock_attitude=True, tilt_deg=90.0, angular_velocity=[5, 0, 0]) == []
    assert problems_of(lock_attitude=True, shape="sphere", angular_velocity=[0, 20, 0]) == []
    # a spin typed to four digits along the axis tilted 20 deg about y (its across part 2e-5 of it):
    # taken, and held about the axis alone (its part across would move the rim all run)
    assert problems_of(lock_attitude=True, tilt_deg=20.0, angular_velocity=[-34.2, 0, 93.97]) == []
    state = make(lock_attitude=True, tilt_deg=20.0, angular_velocity=[-34.2, 0, 93.97]).initial_outputs()["state"]
    axis = quat.body_axis(tuple(state.orientation))
    w = np.asarray(state.angular_velocity)
    assert np.linalg.norm(w - (w @ axis) * np.asarray(axis)) < 1e-12 and abs(w @ axis) == pytest.approx(100.0, rel=1e-4)
    # the advice counts a spin given besides
    assert problems_of(lock_attitude=True, spin=10.0, angular_velocity=[0, 20, 0])[0].endswith(
        "give only its turn about the axis, as spin: 10, or leave the attitude free")
    # too large to hold is the energy's problem, said as such (the check squared it and overflowed)
    assert problems_of(lock_attitude=True, angular_velocity=[1e300, 0, 1e300]) == [
        "stone.angular_velocity: makes the stone's kinetic energy overflow a float (got (1e+300, 0.0, 1e+300))"]


def test_a_sphere_accepts_zero_thickness():
    """A sphere has no thickness: 0 is fine and is published as 0."""
    assert problems_of(shape="sphere", thickness=0.0) == []
    state = make(shape="sphere", thickness=0.0, radius=0.02).initial_outputs()["state"]
    assert state.thickness == 0.0 and state.shape is Shape.SPHERE


# --- published state -------------------------------------------------------------------------------

def test_initial_state_fills_every_field():
    """The t = 0 state carries geometry, mass from density, inertia, attack angle, speed and energies."""
    body = make(radius=0.05, thickness=0.004, density=2500.0, position=[0, 0, 0.2], velocity=[3, 0, 4],
                tilt_deg=20.0)
    msg = body.initial_outputs()["state"]
    mass = 2500.0 * math.pi * 0.05 ** 2 * 0.004
    assert isinstance(msg, BodyState)
    assert msg.mass == pytest.approx(mass)
    i_d = mass * (3 * 0.05 ** 2 + 0.004 ** 2) / 12
    assert msg.inertia == pytest.approx([i_d, i_d, mass * 0.05 ** 2 / 2])
    assert msg.attack_angle_deg == pytest.approx(20.0)
    assert msg.speed == pytest.approx(5.0)
    assert msg.kinetic_energy == pytest.approx(0.5 * mass * 25.0)
    assert msg.potential_energy == pytest.approx(mass * G * 0.2)
    assert msg.first_nonfinite() is None


def test_default_tilt_raises_the_leading_edge():
    """The default tilt axis (-y) raises the +x edge: nose up for a throw along +x."""
    q = tuple(make(tilt_deg=30.0).initial_outputs()["state"].orientation)
    front = quat.rotate(q, (0.05, 0.0, 0.0))
    assert front[2] == pytest.approx(0.05 * math.sin(math.radians(30.0)))


def test_spin_is_added_about_the_tilted_axis():
    """spin adds an angular velocity along the body's symmetry axis (world frame)."""
    msg = make(tilt_deg=30.0, spin=100.0).initial_outputs()["state"]
    axis = quat.body_axis(tuple(msg.orientation))
    assert msg.angular_velocity == pytest.approx(np.multiply(axis, 100.0))


def test_published_state_round_trips_through_the_codec():
    """The published BodyState encodes and decodes bit for bit."""
    body = make(velocity=[1.0, 2.0, 3.0], angular_velocity=[0.1, 0.2, 30.0], tilt_deg=12.0)
    msg = run(body, 3)
    codec = codec_for(BodyState)
    assert messages_equal(codec.decode(codec.encode(msg)), msg)


# --- dynamics through step() -----------------------------------------------------------------------

def test_free_fall_through_step_is_exact():
    """With nothing connected, 400 steps of 0.5 ms give z0 - g t^2/2 and -g t to round-off."""
    body = make(position=[0, 0, 2.0])
    msg = run(body, 400)
    assert msg.position[2] == pytest.approx(2.0 - 0.5 * G * 0.2 ** 2, rel=1e-14)
    assert msg.velocity[2] == pytest.approx(-G * 0.2, rel=1e-14)


def test_held_wrench_adds_to_gravity():
    """A constant wrench force F over t gives x = (F/M + g) t^2 / 2."""
    body = make(position=[0, 0, 0], shape="sphere", radius=0.02, mass=0.5)
    wrench = Wrench(np.array([1.0, 0.0, 0.25 * G]), np.zeros(3))  # F/M = (2, 0, g/2)
    msg = run(body, 200, wrench=wrench)
    t = 0.1
    assert msg.position == pytest.approx([0.5 * 2.0 * t * t, 0.0, -0.5 * 0.5 * G * t * t], rel=1e-12)


def test_torque_spins_up_a_sphere_at_torque_over_inertia():
    """A constant torque about the centre of a sphere gives omega = torque t / I."""
    body = make(shape="sphere", radius=0.02, mass=0.5, gravity=[0, 0, 0])
    msg = run(body, 100, wrench=Wrench(np.zeros(3), np.array([0.0, 0.0, 1e-3])))
    assert msg.angular_velocity == pytest.approx([0.0, 0.0, 1e-3 * 0.05 / (0.4 * 0.5 * 0.02 ** 2)], rel=1e-12)


def test_impulse_is_applied_once_at_the_start_of_the_step():
    """An impulse changes v by J/M and x by the correction before the step's integration, once."""
    body = make(position=[0, 0, 1.0], shape="sphere", radius=0.02, mass=0.5)
    imp = Impulse(np.array([0.0, 0.0, 1.0]), np.zeros(3), np.array([0.0, 0.0, 0.01]))
    msg = run(body, 1, impulses={0: imp})
    v0 = 1.0 / 0.5
    assert msg.velocity[2] == pytest.approx(v0 - G * DT, rel=1e-14)
    assert msg.position[2] == pytest.approx(1.01 + v0 * DT - 0.5 * G * DT * DT, rel=1e-14)
    msg = run(body, 1, start=1)  # no impulse delivered on the next step
    assert msg.velocity[2] == pytest.approx(v0 - 2 * G * DT, rel=1e-14)


def test_angular_impulse_changes_angular_momentum():
    """An angular impulse H changes the world angular momentum by H."""
    body = make(gravity=[0, 0, 0], tilt_deg=40.0)
    imp = Impulse(np.zeros(3), np.array([1e-5, 0.0, 0.0]), np.zeros(3))
    msg = run(body, 1, impulses={0: imp})
    q, w = tuple(msg.orientation), tuple(msg.angular_velocity)
    from components.rigid.dynamics import angular_momentum
    assert angular_momentum(body.body.inertia, q, w) == pytest.approx((1e-5, 0.0, 0.0), rel=1e-12, abs=1e-20)


# --- options ---------------------------------------------------------------------------------------

def test_locked_attitude_ignores_torques_and_angular_impulses_and_keeps_the_spin():
    """lock_attitude holds orientation and angular velocity; the spin's energy stays in the books."""
    body = make(tilt_deg=20.0, spin=400.0, lock_attitude=True)
    start = body.initial_outputs()["state"]
    msg = run(body, 50, wrench=Wrench(np.zeros(3), np.array([1.0, 2.0, 3.0])),
              impulses={3: Impulse(np.zeros(3), np.array([1.0, 0.0, 0.0]), np.zeros(3))})
    assert np.array_equal(msg.orientation, start.orientation)
    assert np.array_equal(msg.angular_velocity, start.angular_velocity)
    spin_energy = 0.5 * body.body.inertia[2] * 400.0 ** 2
    assert msg.kinetic_energy == pytest.approx(spin_energy + 0.5 * msg.mass * msg.speed ** 2)


def test_scripted_tilt_follows_the_keyframes():
    """scripted_tilt_deg sets the attitude at every step end, whatever the torque; the angular velocity
    is the tilt rate about tilt_axis plus the spin about the body axis."""
    body = make(scripted_tilt_deg=[[0.0, 10.0], [0.1, 30.0]], spin=50.0)
    assert body.initial_outputs()["state"].attack_angle_deg == pytest.approx(10.0)
    msg = run(body, 100, wrench=Wrench(np.zeros(3), np.array([0.0, 1.0, 0.0])))  # t = 0.05 s
    assert msg.attack_angle_deg == pytest.approx(20.0)
    axis = np.array(quat.body_axis(tuple(msg.orientation)))
    expected = np.array([0.0, -math.radians(200.0), 0.0]) + 50.0 * axis
    assert msg.angular_velocity == pytest.approx(expected)
    msg = run(body, 200, start=100)  # past the last keyframe: held
    assert msg.attack_angle_deg == pytest.approx(30.0)
    assert msg.angular_velocity == pytest.approx(50.0 * np.array(quat.body_axis(tuple(msg.orientation))))


@pytest.mark.parametrize("size", [1e200, 1.0, 1e-200])
def test_a_scripted_tilt_turns_at_its_rate_whatever_the_length_of_its_axis(size):
    """The scripted tilt's angular velocity is its rate about the unit axis: an axis of 1e200 squared
    to inf and published no turn at all (the attitude turning), one of 1e-200 divided by zero."""
    body = make(tilt_axis=[size, 0.0, 0.0], scripted_tilt_deg=[[0.0, 0.0], [0.01, 20.0]])
    msg = run(body, 4)
    assert msg.angular_velocity.tolist() == pytest.approx([math.radians(20.0) / 0.01, 0.0, 0.0], rel=1e-12)


def test_an_impulse_that_spins_an_rk4_body_past_its_bound_is_taken_in_the_substeps_it_needs():
    """RK4's bound (0.5 rad a step) is judged before the step; an angular impulse at the step's start
    to 2000 rad/s about the axis and 300 across it made a 1 ms step 2 rad, taken whole: the angular
    momentum 3.6% off the impulse's (torque-free, it is conserved) and the attitude 1.6 deg off the
    exact free rotation. The step is now taken in 5 substeps, said as taken; under on_unstable: error
    the step fails, naming the bound."""
    from components.rigid.dynamics import angular_momentum, free_rotation
    body = make(integrator="rk4", gravity=[0.0, 0.0, 0.0])
    inertia = body.body.inertia
    h = (inertia[0] * 300.0, 0.0, inertia[2] * 2000.0)
    kick = {"impulse": Impulse(np.zeros(3), np.array(h), np.zeros(3)), "wrench": None, "added_mass": None}
    body.step(0, 1_000_000, kick, on_unstable="substep")
    assert body.last_substeps == 5
    s = body.state
    momentum = angular_momentum(inertia, s.orientation, s.angular_velocity)
    assert np.linalg.norm(np.subtract(momentum, h)) / np.linalg.norm(h) < 1e-4  # (was 3.6e-2)
    exact = free_rotation(inertia, quat.IDENTITY, h, 1e-3)
    assert math.degrees(quat.angle_between(exact, s.orientation)) < 0.01  # (was 1.59)
    # turning at 750 rad/s before the step, the scheduler takes it in 2 substeps; kicked to 2500 rad/s,
    # each is taken in 3 pieces: said as the 6 taken (it said 5, the whole step's count under the bound)
    spun = make(integrator="rk4", gravity=[0.0, 0.0, 0.0], spin=750.0)
    spun.status = "initialized"
    more = {**kick, "impulse": Impulse(np.zeros(3), np.array([0.0, 0.0, inertia[2] * 1750.0]), np.zeros(3))}
    spun.step(0, 1_000_000, more, on_unstable="substep")
    assert spun.last_substeps == 6
    strict = make(integrator="rk4", gravity=[0.0, 0.0, 0.0])
    strict.status = "initialized"
    with pytest.raises(SimulationError, match="exceeds the stable step"):
        strict.step(0, 1_000_000, kick, on_unstable="error")


def test_scripted_velocity_drives_the_horizontal_motion_only():
    """scripted_velocity sets vx, vy and their exact integral; z stays free; horizontal impulses and
    forces are ignored."""
    body = make(position=[0, 0, 1.0], scripted_velocity=[[0.0, 2.0, 0.0], [0.1, 4.0, 1.0]])
    imp = Impulse(np.array([5.0, 5.0, 0.0]), np.zeros(3), np.array([1.0, 1.0, 0.0]))
    msg = run(body, 200, wrench=Wrench(np.array([3.0, 3.0, 0.0]), np.zeros(3)), impulses={7: imp})  # 0.1 s
    assert msg.position == pytest.approx([0.3, 0.05, 1.0 - 0.5 * G * 0.01], rel=1e-12)
    assert msg.velocity == pytest.approx([4.0, 1.0, -G * 0.1], rel=1e-12)


@pytest.mark.parametrize("integrator", ["semi_implicit_euler", "verlet", "rk4"])
def test_a_scripted_body_carrying_water_moves_up_and_down_as_its_vertical_row_says(integrator):
    """A disk tilted 45 deg carrying 5 M of water along its axis, its horizontal velocity scripted
    (from 2 m/s, speeding up at 10 m/s^2 along x): only a_z is free, (M + M_a,zz) a_z = F_z - M_a,zx a_x,
    M_a = 5 M n n^T. Solved as for a free body and then held horizontally, its fall mixed in the
    horizontal force (a 1 N push the script held lifted it at 0.39 m/s after 0.1 s; gravity alone
    gave 0.57 m/s down where 0.28 is right)."""
    from components.messages import AddedMass

    def vz_after(push: float, gravity: list[float], script: list[list[float]]) -> float:
        body = make(position=[0, 0, 0], tilt_deg=45.0, scripted_velocity=script, gravity=gravity,
                    integrator=integrator)
        water = AddedMass(5.0 * body.body.mass, 0.0, 0.0, 0.0)
        out = None
        for k in range(200):  # 0.1 s
            out = body.step(k * DT_NS, DT_NS, {"wrench": Wrench(np.array([push, 0.0, 0.0]), np.zeros(3)),
                                               "impulse": None, "added_mass": water})["state"]
        return float(out.velocity[2])

    n = (-math.sin(math.radians(45.0)), 0.0, math.cos(math.radians(45.0)))  # the axis, nose up along +x
    held = [[0.0, 2.0, 0.0]]
    assert vz_after(0.0, [0.0, 0.0, -G], held) == pytest.approx(-G / (1.0 + 5.0 * n[2] ** 2) * 0.1, rel=1e-12)
    assert vz_after(1.0, [0.0, 0.0, 0.0], held) == 0.0
    speeding = [[0.0, 2.0, 0.0], [1.0, 12.0, 0.0]]  # a_x = 10 m/s^2
    expected = -5.0 * n[2] * n[0] * 10.0 / (1.0 + 5.0 * n[2] ** 2) * 0.1
    assert vz_after(1.0, [0.0, 0.0, 0.0], speeding) == pytest.approx(expected, rel=1e-12)


# --- framework services ----------------------------------------------------------------------------

def test_set_state_of_get_state_reproduces_the_run_bit_for_bit():
    """Restoring a checkpoint and re-running gives the same messages, bit for bit."""
    params = dict(velocity=[3.0, 0.5, 2.0], angular_velocity=[1.0, -2.0, 40.0], tilt_deg=15.0,
                  integrator="rk4")
    body = make(**params)
    wrench = Wrench(np.array([0.1, 0.0, 0.0]), np.array([0.0, 1e-4, 0.0]))
    run(body, 37, wrench=wrench)
    saved = body.get_state()
    first = [run(body, 1, wrench=wrench, start=k) for k in range(37, 60)]
    other = make(**params)
    other.set_state(saved)
    second = [run(other, 1, wrench=wrench, start=k) for k in range(37, 60)]
    assert all(messages_equal(a, b) for a, b in zip(first, second, strict=True))


def test_stable_step_is_unbounded_for_exact_drift_and_bounded_for_rk4_spin():
    """Verlet rotation is exact at any step; RK4 reports a bound shrinking with the spin rate."""
    assert make(spin=400.0).max_stable_step() == math.inf
    assert make(spin=400.0, integrator="rk4").max_stable_step() == pytest.approx(0.5 / 400.0)
    assert make(integrator="rk4").max_stable_step() == math.inf


def test_summary_names_the_body_and_its_final_state():
    """The closing summary gives position, speed and energies."""
    (line,) = make(position=[1, 2, 3]).summary()
    assert line.startswith("stone: at (1, 2, 3) m, speed 0 m/s")


def test_a_disk_tilted_about_an_axis_not_across_its_throw_is_said_to_meet_the_water_banked():
    """The default tilt_axis raises the +x edge: thrown along -y, the disk came down on its side and
    sank at its first touch with no word. The scene now says so, with the axis that would raise its
    front edge along the throw; that axis (or a throw along +x) says nothing."""
    from pathlib import Path

    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    along_minus_y = "components.stone.velocity=[0, -10.94, -1.15]"
    (notice,) = load(scene, [along_minus_y]).notices
    assert notice == ("components.stone: tilt_deg 8 about tilt_axis [0.0, -1.0, 0.0] leaves it 0 deg nose-up along "
                      "its throw and banked 8 deg across it, so it meets the water on its side; to raise its front "
                      "edge along the throw, give tilt_axis [-1, 0, 0]")
    assert load(scene, [along_minus_y, "components.stone.tilt_axis=[-1, 0, 0]"]).notices == []
    assert load(scene).notices == []
    # thrown back along -x it comes down front edge first; let go with no horizontal speed, no front edge
    (back,) = load(scene, ["components.stone.velocity=[-10.94, 0, -1.15]"]).notices
    assert "leaves it -8 deg nose-up along its throw and banked 0 deg across it, so it meets the water front " \
           "edge first; to raise its front edge along the throw, give tilt_deg -8" in back
    # tilted the wrong way about the right axis: the angle's sign is the fix (it said to give the axis it had)
    (nose_down,) = load(scene, ["components.stone.tilt_deg=-8"]).notices
    assert nose_down.endswith("meets the water front edge first; to raise its front edge along the throw, give "
                              "tilt_deg 8")
    assert load(scene, ["components.stone.tilt_deg=8"]).notices == []
    assert load(scene, ["components.stone.velocity=[1e-9, 0, -3]"]).notices == []


def test_a_held_attitude_spun_is_said_to_push_the_stone_with_its_spins_energy():
    """With lock_attitude the spin never slows: the water's friction on the spinning face takes nothing
    from it and drives the stone sideways (the held skip spun at 2000 rev/s left its first contact at
    55 m/s from 8, exit 0, without a word). The scene says so; unspun, or free, it says nothing."""
    from pathlib import Path

    from cosim.scenario import load

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml"
    (notice,) = load(scene, ["components.stone.spin=125.7"]).notices
    assert notice.startswith("components.stone: spin 125.7 rad/s with lock_attitude: the held spin never slows")
    assert load(scene).notices == []
    assert load(scene, ["components.stone.spin=125.7", "components.stone.lock_attitude=false"]).notices == []
