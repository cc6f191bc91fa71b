"""The published experiments as runnable throws: the Clanet/Rosellini aluminium disk thrown at still
water through the full co-simulation (RigidBody + WaterSurface + WaterCoupler with every effect +
StageMonitor), and what each throw did; and a body let go under water, whose start tests the added
mass against potential flow (:func:`release_under_water`).

Used by ``tools/validate_targets.py`` and the tests that hold the
model to the published values (``tests/test_validation_targets.py``). The experiment: Clanet, Hersen &
Bocquet, Nature 427, 29 (2004); Rosellini, Hersen, Clanet & Bocquet, J. Fluid Mech. 543, 137 (2005).
An aluminium disk (R = 2.5 cm, e = 2.75 mm, 2700 kg/m^3) thrown by a catapult with speed U, impact
angle beta (velocity below the horizontal) and attack angle alpha (face nose-up), spun at 65 rev/s
(held attitude, ``spin=None``) or at a given spin with a free attitude.

A throw is started with the disk's lowest point 1.05 cm above the water and the vertical speed that
gravity brings to U sin(beta) at the surface: the water delivers its first patch a few water steps
into the run, before the stone arrives. The throws step the body with velocity Verlet (RigidBody's
default, named in the scene) at a 0.1 ms base step (``BASE_STEP``; a component whose stable step is
shorter substeps), not the stone scenes' semi-implicit Euler at 0.5 ms; the releases under water
with velocity Verlet at 0.5 ms.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from components.analysis.data import attack_along_motion
from components.messages import BodyState
from cosim.scenario import Scene, loads
from cosim.scheduler import BaseObserver, Simulation

RADIUS = 0.025  # [m] Clanet et al.'s aluminium disk
THICKNESS = 0.00275  # [m]
ALUMINIUM = 2700.0  # [kg/m^3]
GRAVITY = 9.81  # [m/s^2]
START_HEIGHT = 0.0105  # [m] of the lowest point above the water at the start
DEPTH = 0.3  # [m] of the still water
# [m] the water's one wave speed is that of ripples as long as the disk is wide (0.30 m/s), as in the
# stone scenes (WaterSurface's wave_length; docs/accuracy.md)
RIPPLE_LENGTH = 2 * RADIUS
BASE_STEP = 1e-4  # [s] of the co-simulation (the coupler substeps where it must)
TAKEOFF_CLEARANCE = 0.002  # [m] the stage monitor's default: a bounce rises this far clear of the water
SPHERE_RADIUS = 0.01  # [m] of the sphere of Johnson & Reid's ricochet throws

SCENE = """
name: clanet_throw
dt: {dt}
until: {until}
on_unstable: substep
components:
  stone:
    type: RigidBody
    shape: disk
    radius: {radius}
    thickness: {thickness}
    density: {density}
    position: [{x[0]!r}, {x[1]!r}, {x[2]!r}]
    velocity: [{v[0]!r}, {v[1]!r}, {v[2]!r}]
    tilt_deg: {alpha!r}
    integrator: verlet
    {attitude}
  pond:
    type: WaterSurface
    nx: {nx}
    ny: {ny}
    cell: {cell!r}
    depth: {depth}
    wave_length: {wave_length!r}
    origin_x: {ox!r}
    origin_y: {oy!r}
    boundary: absorbing
    every: {water_every}
    field_rate: 0
  coupler:
    type: WaterCoupler
    effects: [displacement, buoyancy, pressure, friction, wave_drag, added_mass]
  stages:
    type: StageMonitor
    stop_after: 0.0
    takeoff_clearance: {clearance!r}
connections:
  - stone.state -> coupler.body
  - pond.patch -> coupler.water
  - {{from: coupler.wrench, to: stone.wrench, delay: 1, initial: {{force: [0, 0, 0], torque: [0, 0, 0]}}}}
  - {{from: coupler.added_mass, to: stone.added_mass, delay: 1,
     initial: {{axial: 0, radial: 0, axial_inertia: 0, diameter_inertia: 0}}}}
  - {{from: coupler.occupied, to: pond.occupied, delay: 1, initial: {{i0: 0, j0: 0, b: []}}}}
  - {{from: coupler.request, to: pond.request, delay: 1, initial: {{x_min: 1, x_max: 0, y_min: 1, y_max: 0}}}}
  - stone.state -> stages.body
  - coupler.contact -> stages.water
"""


def start(speed: float, alpha_deg: float, beta_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Centre [m] and velocity [m/s] of a throw that meets still water at ``speed`` and ``beta_deg``."""
    alpha, beta = math.radians(alpha_deg), math.radians(beta_deg)
    x = np.array([0.0, 0.0, RADIUS * math.sin(alpha) + 0.5 * THICKNESS * math.cos(alpha) + START_HEIGHT])
    vz = math.sqrt(max((speed * math.sin(beta)) ** 2 - 2.0 * GRAVITY * START_HEIGHT, 0.0))
    return x, np.array([speed * math.cos(beta), 0.0, -vz])


def throw_scene(speed: float, alpha_deg: float, beta_deg: float = 20.0, *, cell: float = 0.005,
                spin_rev_s: float | None = None, until: float = 0.6,
                clearance: float = TAKEOFF_CLEARANCE, ripple_length: float = RIPPLE_LENGTH,
                length: float = 0.8) -> Scene:
    """One throw of the disk over a ``length`` x 0.2 m pond of ``cell`` columns (every effect on, the
    reference skip's six; 0.8 m long: a contact lasts a few centimetres of travel, a longer pond for
    the skips that follow); ``spin_rev_s`` None holds the attitude (the 65 rev/s high-spin limit), a
    number frees it with that spin [rev/s] about the disk's axis; ``ripple_length`` [m] the waves whose
    speed the water's one speed is (the body's width)."""
    x, v = start(speed, alpha_deg, beta_deg)
    width = 0.2  # [m]
    # the water's step as the long waves' sqrt(g d) would need it (c dt / s <= 0.5): kept at the
    # ripples' slower speed too, so the throws' water steps as it always has
    long_wave_speed = math.sqrt(GRAVITY * DEPTH)
    water_every = max(1, math.floor(0.5 * cell / long_wave_speed / BASE_STEP))
    attitude = ("lock_attitude: true" if spin_rev_s is None
                else f"lock_attitude: false\n    spin: {2.0 * math.pi * spin_rev_s!r}")
    text = SCENE.format(dt=BASE_STEP, until=until, radius=RADIUS, thickness=THICKNESS, density=ALUMINIUM,
                        x=x.tolist(), v=v.tolist(), alpha=float(alpha_deg), attitude=attitude,
                        nx=round(length / cell), ny=round(width / cell), cell=cell, depth=DEPTH,
                        wave_length=ripple_length,
                        ox=-0.1 + 0.5 * cell, oy=-0.5 * width + 0.5 * cell, water_every=water_every,
                        clearance=clearance)
    return loads(text, source="clanet_throw")


@dataclass(frozen=True)
class ThrowOutcome:
    """What one throw did, up to its first bounce or its sink."""

    bounced: bool  # the stage monitor recorded a fly-away before a sink
    contact_s: float  # how long the disk was wetted in its first contact [s]
    attack_deg: tuple[float, float, float]  # attack angle over the contact: min, max, at its end [deg]
    tilt_change_deg: float  # largest change of the face's tilt from the horizontal during it [deg]


def _attack_along_motion(state: BodyState) -> float:
    """The attack angle along the horizontal motion [deg]: the face nose-up (positive) or nose-down
    (negative) in the plane of the motion, unlike BodyState.attack_angle_deg, the face's unsigned
    tilt from the horizontal."""
    return float(attack_along_motion(np.asarray(state.orientation, dtype=float)[None],
                                     np.asarray(state.velocity, dtype=float)[None],
                                     np.array([state.attack_angle_deg]))[0])


def run_throw(scene: Scene) -> ThrowOutcome:
    """Run ``scene`` (from :func:`throw_scene`) to the first bounce or sink."""
    return _throw(scene, None)[0]


@dataclass(frozen=True)
class AttackHistory:
    """A throw's attack angle along its motion over time, from its touchdown on (for figures)."""

    time_s: np.ndarray  # [s] since the touchdown
    attack_deg: np.ndarray  # along the horizontal motion: nose-up positive [deg]
    wetted: np.ndarray  # bool: the coupler reported the disk wetted
    outcome: ThrowOutcome  # what :func:`run_throw` says of the same throw


def attack_history(scene: Scene, after_s: float = 0.03) -> AttackHistory:
    """The attack angle of ``scene``'s throw (from :func:`throw_scene`) from its touchdown to
    ``after_s`` [s] past its first bounce or sink (or the scene's end)."""
    outcome, times, attacks, wetted = _throw(scene, after_s)
    return AttackHistory(np.array(times), np.array(attacks), np.array(wetted), outcome)


def _throw(scene: Scene, after_s: float | None) -> tuple[ThrowOutcome, list[float], list[float], list[bool]]:
    """Run ``scene`` to its first bounce or sink, and on for ``after_s`` [s] when it is a number: the
    throw's outcome (up to the bounce or sink), and from its touchdown on, each step's time since the
    touchdown [s], attack angle along the motion [deg] and whether the coupler reported it wetted
    (kept only with ``after_s``)."""
    sim = Simulation(scene)
    sim.initialize()
    stages = sim.components["stages"]
    stone = sim.components["stone"]
    end = scene.until_ns
    coupler_contact = {r.name: r for r in sim.runners}["coupler"].slots["contact"]
    touched_at = None
    wetted_from = wetted_until = None
    attacks: list[float] = []
    tilt0 = None
    tilt_change = 0.0
    bounced = ended = False
    times: list[float] = []
    history: list[float] = []
    wetted: list[bool] = []
    while sim.time_ns < end:
        sim.step()
        state = stone.body_state()
        if stages.track.in_contact and touched_at is None:
            touched_at = sim.time_ns
        report = coupler_contact.entries[-1][1] if coupler_contact.entries else None
        wet = report is not None and bool(report.wetted)
        attack = _attack_along_motion(state) if touched_at is not None else math.nan
        if after_s is not None and touched_at is not None:
            times.append((sim.time_ns - touched_at) * 1e-9)
            history.append(attack)
            wetted.append(wet)
        if ended:
            continue
        if wet:
            wetted_from = sim.time_ns if wetted_from is None else wetted_from
            wetted_until = sim.time_ns
        if touched_at is not None:
            attacks.append(attack)
            tilt0 = state.attack_angle_deg if tilt0 is None else tilt0
            tilt_change = max(tilt_change, abs(state.attack_angle_deg - tilt0))
        bounced = bool(stages.track.skips)
        ended = bounced or (stages.stage is not None and stages.stage.name == "SINK")
        if ended:
            if after_s is None:
                break
            end = min(end, sim.time_ns + round(after_s * 1e9))
    contact = 0.0 if wetted_from is None else (wetted_until - wetted_from) * 1e-9
    span = (min(attacks), max(attacks), attacks[-1]) if attacks else (math.nan,) * 3
    return ThrowOutcome(bounced, contact, span, tilt_change), times, history, wetted


@dataclass(frozen=True)
class ContactPeak:
    """One contact of a throw with the water: the peak of the water's vertical force over the stone's
    weight during it [-] (in g: what an accelerometer riding in the stone reads along the vertical), and
    whether it ended in a bounce (else the stone stayed on the water until it sank)."""

    peak_g: float
    bounced: bool


def contact_peaks(scene: Scene) -> list[ContactPeak]:
    """Every contact of ``scene``'s stone (a scene with a ``stone`` and a stage monitor ``stages``, as
    the stone scenes have) whose end was seen, in order: its peak (the stage monitor's, SkipRecord.
    peak_g) and whether it ended in a bounce or the stone stayed on the water until it sank. A
    contact still going on when the run ends (the scene's end, the stone off the pond) is left out."""
    sim = Simulation(scene)
    sim.run()
    monitor = sim.components["stages"]
    contacts = [ContactPeak(r.peak_g, True) for r in monitor.records]
    if monitor.stage is not None and monitor.stage.name == "SINK" and math.isnan(monitor.left_at):
        contacts.append(ContactPeak(monitor.track.peak_g, False))  # the last contact: it stayed on the water
    return contacts


def sphere_throw_scene(speed: float, theta_deg: float, relative_density: float, *, radius: float = SPHERE_RADIUS,
                       cell: float = 0.005, until: float = 0.4) -> Scene:
    """A sphere of ``radius`` [m] and ``relative_density`` thrown at ``theta_deg`` below the horizontal
    onto still water (Johnson & Reid's ricochet), over the same pond as the disk."""
    text = throw_scene(speed, 0.0, theta_deg, cell=cell, until=until, ripple_length=2 * radius).text
    x, _ = start(speed, 0.0, theta_deg)
    disk = (f"    shape: disk\n    radius: {RADIUS}\n    thickness: {THICKNESS}\n    density: {ALUMINIUM}\n"
            f"    position: [0.0, 0.0, {float(x[2])!r}]")
    sphere = (f"    shape: sphere\n    radius: {radius!r}\n    density: {1000.0 * relative_density!r}\n"
              f"    position: [0.0, 0.0, {radius + START_HEIGHT!r}]")
    if disk not in text:
        raise AssertionError("the disk throw's text changed: update sphere_throw_scene")
    return loads(text.replace(disk, sphere), source="sphere_throw")


def bounces(speed: float, alpha_deg: float, beta_deg: float = 20.0, **scene_args) -> bool:
    """Whether the throw bounces (a fly-away before a sink)."""
    return run_throw(throw_scene(speed, alpha_deg, beta_deg, **scene_args)).bounced


def critical_speed(alpha_deg: float, *, lo: float = 1.0, hi: float = 6.0, step: float = 0.1,
                   tol: float = 0.01, bounce: Callable[..., bool] | None = None,
                   **throw_args) -> tuple[float, list[float]]:
    """The speed [m/s] above which every throw at ``alpha_deg`` bounces, and the slower speeds that
    bounce too.

    Every speed lo, lo + step, ..., hi is thrown (a throw need not bounce at every speed above one that
    does: near the threshold a stone can surf along the surface instead); the critical speed is then
    bisected to ``tol`` between the fastest one that does not bounce and the next. NaN if even ``hi``
    does not bounce. ``bounce(speed, alpha_deg, **throw_args)`` decides a throw (default: :func:`bounces`,
    the full co-simulation).
    """
    bounces_ = bounce or bounces
    grid = np.round(np.arange(lo, hi + 0.5 * step, step), 6)
    results = [bounces_(float(u), alpha_deg, **throw_args) for u in grid]
    if not results[-1]:
        return math.nan, []
    fails = [float(u) for u, ok in zip(grid, results, strict=True) if not ok]
    if not fails:
        return float(grid[0]), []
    a = fails[-1]
    below = [float(u) for u, ok in zip(grid, results, strict=True) if ok and u < a]
    b = a + step
    while b - a > tol:
        mid = 0.5 * (a + b)
        if bounces_(mid, alpha_deg, **throw_args):
            b = mid
        else:
            a = mid
    return 0.5 * (a + b), below


# --- a body released under water (added mass) ----------------------------------------------------

RELEASE_SCENE = """
name: release
dt: 0.0005
until: {until}
components:
  body:
    type: RigidBody
    shape: {shape}
    radius: {radius!r}
    thickness: {thickness!r}
    density: {density!r}
    position: [0.2, 0.2, -0.2]
    integrator: verlet
{motion}  pond:
    type: WaterSurface
    nx: 40
    ny: 40
    cell: 0.01
    depth: 0.5
    boundary: absorbing
    every: 4
    field_rate: 0
  coupler:
    type: WaterCoupler
    effects: [displacement, buoyancy, pressure, friction, wave_drag{added}]
connections:
  - body.state -> coupler.body
  - pond.patch -> coupler.water
  - {{from: coupler.wrench, to: body.wrench, delay: 1, initial: {{force: [0, 0, 0], torque: [0, 0, 0]}}}}
  - {{from: coupler.occupied, to: pond.occupied, delay: 1, initial: {{i0: 0, j0: 0, b: []}}}}
  - {{from: coupler.request, to: pond.request, delay: 1, initial: {{x_min: 1, x_max: 0, y_min: 1, y_max: 0}}}}
{connection}
"""
RELEASE_ADDED_MASS = ("  - {from: coupler.added_mass, to: body.added_mass, delay: 1, "
                      "initial: {axial: 0, radial: 0, axial_inertia: 0, diameter_inertia: 0}}")
"""The connection that takes the added mass to the body, for :data:`RELEASE_SCENE`'s ``connection``."""
RELEASE_TUMBLING = ("    tilt_deg: 45\n    velocity: [0.3, 0.2, 0.1]\n"
                    "    angular_velocity: [5.0, 30.0, 100.0]\n")
"""The body's lines that throw it tumbling, for :data:`RELEASE_SCENE`'s ``motion``."""
RELEASE_RADIUS = 0.02  # [m] of the released sphere and disk
RELEASE_THICKNESS = 0.006  # [m] of the released disk (a slate)
SLATE = 2650.0  # [kg/m^3]


@dataclass(frozen=True)
class Release:
    """A body let go at rest 20 cm under a still pond: by time [ns], its vertical velocity [m/s] and
    its energy [J] (kinetic plus potential plus what the water took, the coupler's books)."""

    vz: dict[int, float]
    energy: dict[int, float]

    def acceleration(self, start_ms: float = 5.0, end_ms: float = 15.0) -> float:
        """The mean vertical acceleration [m/s^2] between two times after the release (the first step
        is gravity's alone: the coupler's answer reaches the body a step late)."""
        start, end = round(start_ms * 1e6), round(end_ms * 1e6)
        return (self.vz[end] - self.vz[start]) / ((end - start) * 1e-9)


def release_under_water(shape: str, *, density: float = SLATE, added_mass: bool = True,
                        until: float = 0.02, tumbling: bool = False) -> Release:
    """A sphere or a disk (face down) of ``density`` [kg/m^3] released at rest under a still pond of
    1 cm columns, with every effect of the reference skip's six (the added mass left out when
    ``added_mass`` is False; the wave drag, against horizontal motion only, does nothing to this
    vertical start). ``tumbling``: thrown instead, tilted 45 deg, at (0.3, 0.2, 0.1) m/s and
    turning at (5, 30, 100) rad/s (spun about its axis and tumbling across it)."""
    text = RELEASE_SCENE.format(until=until, shape=shape, radius=RELEASE_RADIUS, thickness=RELEASE_THICKNESS,
                                density=density, added=", added_mass" if added_mass else "",
                                connection=RELEASE_ADDED_MASS if added_mass else "",
                                motion=RELEASE_TUMBLING if tumbling else "")
    log = _ReleaseLog()
    Simulation(loads(text, source="release"), observers=[log]).run()
    return Release(log.vz, {t: log.energy[t] + w for t, w in log.water.items() if t in log.energy})


def release_exact(shape: str, density: float = SLATE, water: float = 1000.0) -> tuple[float, float]:
    """The starting acceleration [m/s^2] of :func:`release_under_water` in potential flow, with the
    added mass and without it: g (M - rho V) / (M + M_a) (Lamb, Hydrodynamics, sections 92, 108:
    M_a = half the displaced water for a sphere, 8/3 rho R^3 for a disk moving face on)."""
    r, e = RELEASE_RADIUS, RELEASE_THICKNESS
    volume = 4.0 / 3.0 * math.pi * r**3 if shape == "sphere" else math.pi * r**2 * e
    added = 0.5 * water * volume if shape == "sphere" else 8.0 / 3.0 * water * r**3
    mass = density * volume
    net = GRAVITY * (water * volume - mass)
    return net / (mass + added), net / mass


class _ReleaseLog(BaseObserver):
    def __init__(self) -> None:
        self.vz: dict[int, float] = {}
        self.energy: dict[int, float] = {}
        self.water: dict[int, float] = {}

    def on_exchange(self, time_ns: int, component: str, port: str, msg) -> None:
        if component == "body" and port == "state":
            self.vz[time_ns] = float(msg.velocity[2])
            self.energy[time_ns] = msg.kinetic_energy + msg.potential_energy
        elif component == "coupler" and port == "contact":
            self.water[time_ns] = msg.dissipated_energy
