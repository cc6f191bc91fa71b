"""A uniform disk rolling without slipping on its rim on a flat SolidGround, in steady motion, against
the exact steady solution of Euler's equations with the rolling constraint. Only a body and a ground
(no water), through the real loader and scheduler::

    disk.state ----------------> ground.body
    disk.impulse <--(delay 1)--- ground.impulse

The steady motion, for the body's own geometry and moments (a solid cylinder of radius R and
thickness e: I_d = M (3 R^2 + e^2) / 12 about a diameter, I_a = M R^2 / 2 about its axis). The disk
touches the plane at the rim of its lower face. Let theta be the tilt (the disk's plane against the
horizontal, its axis a against the vertical z), h the horizontal unit vector along which the disk's
plane rises, t = z x h, so a = cos(theta) z - sin(theta) h. From the centre of mass the contact point
is r = -R (sin(theta) z + cos(theta) h) - (e/2) a, the centre lying

    d   = R cos(theta) - (e/2) sin(theta)    horizontally from the contact point, along h,
    z_G = R sin(theta) + (e/2) cos(theta)    above the plane.

In steady motion the tilt is constant and the frame (a, h, t) turns about z at the precession rate
Omega; the centre runs round a horizontal circle about a fixed vertical line, from which it lies at
D h (velocity Omega D t), and the body spins at s about its axis relative to that frame:
omega = Omega z + s a.

- Rolling, v + omega x r = 0: omega x r = -(Omega d + s R) t, so s = Omega (D - d) / R; the contact
  point runs round a circle of radius |D - d|.
- Forces: the centre's acceleration is -Omega^2 D h, so the ground pushes with N = M g up and a
  friction -M Omega^2 D h, nothing along t.
- Angular momentum about the centre: L = I_d Omega z + (I_a s + (I_a - I_d) Omega cos(theta)) a,
  turning with the frame: dL/dt = Omega z x L = -Omega sin(theta) (I_a s + (I_a - I_d) Omega cos(theta)) t.
- The contact force's torque about the centre: r x (M g z - M Omega^2 D h) = M (g d + Omega^2 D z_G) t.

Equating the last two (Euler's equations in the turning frame) with the rolling spin s:

    Omega^2 = M g d / ((I_d - I_a) sin(theta) cos(theta) + I_a sin(theta) (d - D) / R - M D z_G).

For a thin disk (e = 0, I_d = M R^2 / 4) this is Omega^2 = 4 g cot(theta) / (R cos(theta) - 6 D): with
the centre fixed (D = 0), Euler's disk, Omega^2 sin(theta) = 4 g / R (Moffatt, "Euler's disk and its
finite-time singularity", Nature 404, 833 (2000)); on a wide circle (D = -b, the disk leaning in,
b >> R) the rolling coin, Omega^2 b = 2/3 g cot(theta) (Routh, "Advanced Dynamics of a System of
Rigid Bodies", 1905, art. 244; K. T. McDonald, "The rolling motion of a disk on a horizontal plane",
arXiv:physics/0008227 (2000)). The thickness is no small correction here: a 6 mm disk of 5 cm radius
at 70 degrees on a 0.2 m circle precesses 9% slower than the thin formula says (its weight's lever d
is 16% shorter), and Euler's disk at 30 degrees 1.6% faster than Moffatt's.

Each case starts exactly on its steady motion and runs at three steps; the precession rate is the
slope of the azimuth of h (the axis's horizontal part, reversed) over the run. Measured with velocity
Verlet (the attitude's path is the same under every integrator: between the ground's impulses the
body turns torque-free, exactly):

============================  ==========  ===========  ==========  ============  ============
case, run                     step [ms]   rate error   tilt drift  centre off    rim sunk
============================  ==========  ===========  ==========  ============  ============
Euler's disk 30 deg, 0.5 s    0.5         -4.48%       +1.66 deg   1.23 mm       0.144 mm
                              0.25        -2.34%       +0.84 deg   0.68 mm       0.040 mm
                              0.125       -1.20%       +0.43 deg   0.35 mm       0.011 mm
coin 70 deg, b 0.2 m, 1 s     0.5         -0.143%      0.08 deg    0.78 mm       0.083 mm
                              0.25        -0.071%      0.04 deg    0.39 mm       0.041 mm
                              0.125       -0.036%      0.02 deg    0.20 mm       0.020 mm
============================  ==========  ===========  ==========  ============  ============

(exact rates 40.245 and 3.1153 rad/s; "centre off": of the centre from its circle; "rim sunk": the
lowest rim point's deepest below the plane.)

The error is first order in the step, and it is not a fixed offset: the disk drifts off the steady
motion (its energy kept to 3e-13: as Euler's disk rises, about 3 deg/s at 0.5 ms, it slows), so the
rate error grows with the length of the run (Euler's disk at 0.5 ms: -0.5% over the first 20 ms,
-8.3% over 1 s; at 60 degrees -1.7% over 0.5 s). The ground's impulse is computed on the state at
the end of a step and applied at the start of the next, while the body turns free in between: a
first-order splitting. Extrapolated from the two finer steps (Richardson, 2 r(h/4) - r(h/2)) the
rate meets the exact one to 0.05% (Euler's disk) and 0.0001% (the coin), which tells the exact
formula from the thin disk's (1.6% and 10% away) and the body's moments from the thin disk's
I_d = M R^2 / 4 (0.26% away for Euler's disk).

The rim sinks into the plane steadily, less at a shorter step (first order for the coin, nearly
second for Euler's disk): the lift of a rim contact is capped at the energy its impulse took
(components.contact.solver, point 2), and what is left is never made up while the disk rolls. The
sticking impulse already takes all the energy an impulse at the contact point can, and a lift by
translation costs M g a metre: each step the two nearly match (Euler's disk's first: a lift of
4.634 um for a fall of 4.636 um), but as the motion drifts off the steady one the lift falls short
by more (5% of the step's fall by 0.5 s). Lifted whole instead, the disk gains M g times the depth
(0.34% in 0.5 s). A lift that costs nothing needs the body turned about its centre, which an Impulse
does not carry. The bounds below hold the depth to the measured one, not to zero.

Under semi-implicit Euler each free step falls g dt^2, twice Verlet's g dt^2 / 2, losing
M (g dt)^2 / 2: the integrator's own error, which the ground's next answer lifts back without
booking it (it reads the overshoot, dv dt / 2, off the body's states). So after the first step
(whose loss shows at its end, before any answer) the energy holds to 1e-13 with nothing booked, and
rate, tilt and centre are as above to their digits; the rim sinks 0.145 and 0.084 mm at 0.5 ms.
(With the lift capped alone, the rim sank g dt^2 / 2 more every step, 1.37 and 2.54 mm, and the energy
fell by M (g dt)^2 / 2 a step, 3.0% in 0.5 s and 3.2% in 1 s, while the ground booked nothing.)
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass

import numpy as np
import pytest

from components.messages import Shape
from components.rigid import quaternion as quat
from components.rigid.shapes import mass_properties
from cosim.scenario import loads
from cosim.scheduler import Simulation
from tests.toys import Channels

G = 9.81  # [m/s^2]
RADIUS, THICKNESS, DENSITY = 0.05, 0.006, 2700.0  # [m], [m], [kg/m^3]: a slate disk 10 cm across
MU = 1.0  # friction (static and kinetic): the coin needs 0.2 of its weight, Euler's disk none
STEPS = (0.0005, 0.00025, 0.000125)  # [s] the scenes' default step, then halved twice


@dataclass(frozen=True)
class Case:
    """A steady rolling motion and what its runs must meet.

    tilt_deg: the disk's plane against the horizontal [deg]; offset: D [m], where the centre lies from
    the axis of its circle along h (0: Euler's disk, its centre fixed; negative: leaning in);
    until: run length [s]. Bounds: rate [relative] at the coarsest and the finest step and of the
    Richardson extrapolation; tilt [deg], off (the centre off its circle) [m] and sunk (the lowest
    rim point below the plane) [m] at the coarsest step.
    """

    tilt_deg: float
    offset: float
    until: float
    rate_coarse: float
    rate_fine: float
    rate_extrapolated: float
    tilt: float
    off: float
    sunk: float


CASES = {
    "euler_disk": Case(30.0, 0.0, 0.5, rate_coarse=0.055, rate_fine=0.015, rate_extrapolated=0.0015,
                       tilt=2.0, off=1.5e-3, sunk=0.2e-3),
    "rolling_coin": Case(70.0, -0.2, 1.0, rate_coarse=0.0025, rate_fine=0.0006, rate_extrapolated=1e-4,
                         tilt=0.15, off=1.2e-3, sunk=0.12e-3),
}


def body():
    """The disk's mass properties, as the RigidBody computes them."""
    return mass_properties(Shape.DISK, RADIUS, THICKNESS, density=DENSITY)


def steady_rate(tilt: float, offset: float, mass: float, i_d: float, i_a: float, radius: float = RADIUS,
                thickness: float = THICKNESS, g: float = G) -> float:
    """Omega [rad/s], the precession rate of the steady rolling motion at ``tilt`` [rad] whose centre
    lies ``offset`` [m] (D) from the axis of its circle (the module docstring's formula)."""
    c = 0.5 * thickness
    s, k = math.sin(tilt), math.cos(tilt)
    d = radius * k - c * s
    z_g = radius * s + c * k
    return math.sqrt(mass * g * d / ((i_d - i_a) * s * k + i_a * s * (d - offset) / radius - mass * offset * z_g))


def scene(case: Case, dt: float, integrator: str = "verlet") -> tuple[str, float]:
    """The scene (YAML text) of the disk started on the steady motion of ``case`` at step ``dt`` [s],
    its body stepped by ``integrator``, and its exact precession rate [rad/s]. The disk is tilted
    about +x, so h = +y and t = -x; the axis of the centre's circle is the z axis."""
    props = body()
    i_d, _, i_a = props.inertia
    th = math.radians(case.tilt_deg)
    c = 0.5 * THICKNESS
    d = RADIUS * math.cos(th) - c * math.sin(th)
    z_g = RADIUS * math.sin(th) + c * math.cos(th)
    rate = steady_rate(th, case.offset, props.mass, i_d, i_a)
    spin = rate * (case.offset - d) / RADIUS  # s, rolling
    axis = (0.0, -math.sin(th), math.cos(th))
    omega = [spin * axis[0], spin * axis[1], rate + spin * axis[2]]
    text = f"""
name: rolling_disk
dt: {dt!r}
until: {case.until!r}
components:
  disk:
    type: RigidBody
    integrator: {integrator}
    shape: disk
    radius: {RADIUS!r}
    thickness: {THICKNESS!r}
    density: {DENSITY!r}
    tilt_deg: {case.tilt_deg!r}
    tilt_axis: [1.0, 0.0, 0.0]
    position: [0.0, {case.offset!r}, {z_g!r}]
    velocity: [{-rate * case.offset!r}, 0.0, 0.0]
    angular_velocity: {omega!r}
  ground:
    type: SolidGround
    mu_static: {MU!r}
    mu_kinetic: {MU!r}
    restitution: 0.0
connections:
  - disk.state -> ground.body
  - {{from: ground.impulse, to: disk.impulse, delay: 1,
     initial: {{linear: [0, 0, 0], angular: [0, 0, 0], correction: [0, 0, 0]}}}}
"""
    return text, rate


@dataclass(frozen=True)
class Run:
    """What one run measured. rate: the fitted precession rate [rad/s] and exact: the steady one;
    tilt: the largest departure of the tilt from its start [deg]; off: of the centre from its circle
    [m]; sunk: the deepest the lowest rim point went below the plane [m]; energy: the largest change
    of kinetic plus potential energy over its start [relative]; drift: the same over its value at the
    end of the first step [relative to the start's]; first: its change over that step [J];
    dissipated: the ground's books at the end [J]; inertia: (3,) the body's published moments
    [kg m^2]; in_contact, sliding: steps after the first the ground held it, and slid it; impacts,
    painleve: the ground's counts."""

    rate: float
    exact: float
    tilt: float
    off: float
    sunk: float
    energy: float
    drift: float
    first: float
    dissipated: float
    inertia: tuple[float, float, float]
    steps: int
    in_contact: int
    sliding: int
    impacts: int
    painleve: int

    @property
    def error(self) -> float:
        """The rate's relative error."""
        return self.rate / self.exact - 1.0


@functools.cache
def roll(name: str, dt: float, integrator: str = "verlet") -> Run:
    """Run case ``name`` at step ``dt`` [s] under ``integrator`` and measure it (cached: the tests
    share the runs)."""
    case = CASES[name]
    text, exact = scene(case, dt, integrator)
    watch = Channels("disk.state", "ground.contact")
    sim = Simulation(loads(text, source=name), observers=[watch])
    result = sim.run(round(case.until * 1e9))
    assert result.status == "ok", result.reason
    states = watch.messages("disk.state")
    reports = watch.messages("ground.contact")[1:]  # (the first is the t = 0 output)
    t = np.array([time for time, _ in watch.seen["disk.state"]])
    axis = np.array([quat.body_axis(tuple(m.orientation.tolist())) for m in states])
    tilt = np.arccos(np.clip(axis[:, 2], -1.0, 1.0))
    azimuth = np.unwrap(np.arctan2(-axis[:, 1], -axis[:, 0]))  # of h
    rate = float(np.polyfit(t, azimuth, 1)[0])
    x = np.array([m.position for m in states])
    rim = x[:, 2] - (RADIUS * np.sin(tilt) + 0.5 * THICKNESS * np.cos(tilt))  # the lowest point's height
    energy = np.array([m.kinetic_energy + m.potential_energy for m in states])
    ground = sim.components["ground"]
    return Run(rate=rate, exact=exact, tilt=float(np.degrees(np.abs(tilt - tilt[0]).max())),
               off=float(np.abs(np.hypot(x[:, 0], x[:, 1]) - abs(case.offset)).max()),
               sunk=float(max(0.0, -rim.min())), energy=float(np.abs(energy - energy[0]).max() / energy[0]),
               drift=float(np.abs(energy[1:] - energy[1]).max() / energy[0]), first=float(energy[1] - energy[0]),
               dissipated=reports[-1].dissipated_energy, inertia=tuple(states[0].inertia.tolist()),
               steps=len(reports), in_contact=sum(r.in_contact for r in reports[1:]),
               sliding=sum(r.sliding for r in reports), impacts=ground.impacts, painleve=ground.painleve)


def test_the_steady_rate_reduces_to_the_thin_disks_classic_results():
    """With no thickness the formula is Moffatt's Euler's disk, Omega^2 sin(theta) = 4 g / R, with the
    centre fixed, and 4 g cot(theta) / (R cos(theta) - 6 D) on any circle, whose wide limit is the
    rolling coin's Omega^2 b = 2/3 g cot(theta)."""
    m = 0.1
    thin = {"mass": m, "i_d": m * RADIUS**2 / 4, "i_a": m * RADIUS**2 / 2, "thickness": 0.0}
    for deg in (5.0, 30.0, 60.0, 85.0):
        th = math.radians(deg)
        assert steady_rate(th, 0.0, **thin) ** 2 * math.sin(th) == pytest.approx(4 * G / RADIUS, rel=1e-12)
        for offset in (-0.01, -0.3):
            assert steady_rate(th, offset, **thin) ** 2 == pytest.approx(
                4 * G / math.tan(th) / (RADIUS * math.cos(th) - 6 * offset), rel=1e-12)
        b = 1e4
        assert steady_rate(th, -b, **thin) ** 2 * b == pytest.approx(2 / 3 * G / math.tan(th), rel=1e-5)


@pytest.mark.parametrize("name", list(CASES))
def test_the_disk_precesses_at_the_exact_steady_rate_to_first_order_in_the_step(name):
    """The fitted precession rate is within the case's bound of the exact steady rate at the default
    step (0.5 ms) and at 0.125 ms, its error halves with the step (a ratio of 1.6 to 2.5 per halving:
    first order, not a fixed offset), and the rate extrapolated from the two finer steps meets the
    exact one closely enough to tell the body's own geometry and moments from the thin disk's."""
    case = CASES[name]
    runs = [roll(name, dt) for dt in STEPS]
    errors = [r.error for r in runs]
    assert abs(errors[0]) < case.rate_coarse, errors
    assert abs(errors[-1]) < case.rate_fine, errors
    for coarse, fine in itertools.pairwise(errors):
        assert 1.6 < coarse / fine < 2.5, errors
    extrapolated = 2.0 * runs[2].rate - runs[1].rate
    assert extrapolated / runs[0].exact - 1.0 == pytest.approx(0.0, abs=case.rate_extrapolated)


@pytest.mark.parametrize("name", list(CASES))
def test_the_rolling_disk_keeps_its_tilt_its_circle_its_contact_and_its_energy(name):
    """At every step the disk stays in contact after its first step (no bounce, no slip, no friction
    dropped), its tilt, its centre's circle and its rim's depth in the plane stay within the case's
    bounds at 0.5 ms and the tilt's drift halves with the step, its kinetic plus potential energy
    is kept to 1e-12 with nothing dissipated (the energy-capped lift), and the body's moments are
    those the exact rate was worked out with."""
    case = CASES[name]
    runs = [roll(name, dt) for dt in STEPS]
    for r in runs:
        assert r.inertia == pytest.approx(body().inertia, rel=1e-15)
        assert (r.in_contact, r.sliding, r.impacts, r.painleve) == (r.steps - 1, 0, 0, 0)
        assert r.energy < 1e-12
        assert abs(r.dissipated) < 1e-15
    coarse = runs[0]
    assert coarse.tilt < case.tilt
    assert coarse.off < case.off
    assert coarse.sunk < case.sunk
    tilts = [r.tilt for r in runs]
    for a, b in itertools.pairwise(tilts):
        assert 1.6 < a / b < 2.5, tilts


@pytest.mark.parametrize("name", list(CASES))
def test_under_semi_implicit_euler_the_rolling_disk_keeps_its_energy_and_its_rim_on_the_plane(name):
    """At 0.5 ms under semi-implicit Euler the first step loses its own M (g dt)^2 / 2 (shown at its
    end, before the ground answers), and from there kinetic plus potential energy is kept to 1e-12
    with nothing dissipated, the disk stays in contact without a slip or a bounce, its rim sinks no
    deeper than under velocity Verlet (within 2%) and it precesses at Verlet's rate: the ground lifts
    each step's overshoot uncharged. It lost 3.0% of its energy in 0.5 s (3.2% in 1 s), sinking
    1.37 mm (2.54 mm), while the ground booked nothing."""
    case, dt = CASES[name], STEPS[0]
    euler, verlet = roll(name, dt, "semi_implicit_euler"), roll(name, dt)
    assert euler.first == pytest.approx(-0.5 * body().mass * (G * dt) ** 2, rel=1e-9)
    assert euler.drift < 1e-12
    assert abs(euler.dissipated) < 1e-15
    assert (euler.in_contact, euler.sliding, euler.impacts, euler.painleve) == (euler.steps - 1, 0, 0, 0)
    assert euler.sunk < case.sunk
    assert euler.sunk < 1.02 * verlet.sunk
    assert euler.rate == pytest.approx(verlet.rate, rel=1e-6)
    assert (euler.tilt, euler.off) == pytest.approx((verlet.tilt, verlet.off), rel=0.01)
