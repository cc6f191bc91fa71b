"""Messages exchanged by the physics components.

Frames: the world frame has z up; the undisturbed water surface is z = 0 unless a scene says
otherwise; x is the main throwing direction. Quaternions are (w, x, y, z), rotating body-frame
vectors into the world frame. The body frame of a disk has its symmetry axis along body z.
All units SI.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Sequence
from typing import Annotated

import numpy as np

from cosim.messages import Array, Message, Quat, Vec3, message

Grid = Annotated[np.ndarray, Array("float64", (None, None))]
"""A 2D float64 array indexed [j, i] (row j along y, column i along x)."""


class Shape(enum.IntEnum):
    """Body shape."""

    DISK = 0
    SPHERE = 1


@message
class BodyState(Message):
    """Rigid-body state at the message's log time, world frame.

    position: (3,) centre of mass [m]; orientation: (4,) unit quaternion (w, x, y, z) body->world;
    velocity: (3,) [m/s]; angular_velocity: (3,) world frame [rad/s].
    Geometry and mass ride along so that contact components need no copy of the body's settings:
    shape; radius [m]; thickness [m] (disk; 0 for a sphere); mass [kg]; inertia: (3,) principal
    moments about body x, y, z [kg m^2], the first two equal (the bodies are axisymmetric about z,
    which the contact components rely on: the ground refuses a body that is not).
    Derived for viewers and plots: attack_angle_deg, the angle between the disk face and the
    horizontal plane [deg] (0 for a sphere), unsigned and whichever way the face leans: the attack
    angle while the lean stays along the path (components.analysis.data.attack_along_motion gives
    the signed angle along the motion); speed [m/s]; kinetic_energy and potential_energy [J]
    (potential -M g . position, zero at the origin: relative to z = 0 when gravity is along -z).
    attitude_locked: the body ignores torques and angular impulses (locked or scripted attitude), so
    contact components must not expect it to turn.
    """

    position: Vec3
    orientation: Quat
    velocity: Vec3
    angular_velocity: Vec3
    shape: Shape
    radius: float
    thickness: float
    mass: float
    inertia: Vec3
    attack_angle_deg: float
    speed: float
    kinetic_energy: float
    potential_energy: float
    attitude_locked: bool = False


@message
class Wrench(Message):
    """Force [N] and torque about the body's centre of mass [N m], world frame. Additive.

    Wrenches are held over the receiver's step (a force acts for the whole step).
    """

    force: Vec3
    torque: Vec3

    additive = True

    def __add__(self, other: Wrench) -> Wrench:  # type: ignore[override]
        return Wrench(self.force + other.force, self.torque + other.torque)

    @staticmethod
    def zero() -> Wrench:
        return Wrench(np.zeros(3), np.zeros(3))


@message
class AddedMass(Message):
    """The water a submerged body carries along as it accelerates (added mass), in the body's frame
    (symmetry axis z), for the body to add to its own inertia: the water's force -M_a a then acts
    without the lag of a held force, which would make a light body unstable.

    axial, radial: along the axis and across it [kg]; axial_inertia, diameter_inertia: about the
    axis and about a diameter [kg m^2]. All zero while the body is not under water.
    """

    axial: float
    radial: float
    axial_inertia: float
    diameter_inertia: float

    @staticmethod
    def zero() -> AddedMass:
        return AddedMass(0.0, 0.0, 0.0, 0.0)

    def values(self) -> tuple[float, float, float, float]:
        """(axial, radial, axial_inertia, diameter_inertia): the message compared by value."""
        return (self.axial, self.radial, self.axial_inertia, self.diameter_inertia)

    def problem(self) -> str | None:
        """What makes this no added mass (a value negative or not finite), or None."""
        for (name, unit), value in zip(_ADDED_MASS_FIELDS, self.values(), strict=True):
            if not (value >= 0.0 and math.isfinite(value)):
                return f"{name} = {value!r} {unit}: an added mass is finite and at least 0"
        return None

    def carried(self, mass: float, axis: Sequence[float], force: Sequence[float]) -> tuple[float, float, float]:
        """The force [N] (world frame) that gives a body of ``mass`` [kg] with symmetry axis ``axis``
        (world) the acceleration ``force`` gives it together with this water: (M + M_a) a = F, so
        M a = M (M + M_a)^-1 F, along the axis and across it. What it takes off ``force`` is the
        water's -M_a a, with no lag."""
        return _split_scale(axis, force, mass / (mass + self.axial), mass / (mass + self.radial))

    def with_inertia(self, inertia: Sequence[float]) -> tuple[float, float, float]:
        """The principal moments [kg m^2] of a body of moments ``inertia`` (I_d, I_d, I_a) and the
        water it turns: (I_d + J_d, I_d + J_d, I_a + J_a). The body turns over the step as this
        inertia under the whole torque, Euler's equations (I + J) w' + w x (I + J) w = T with the
        gyroscopic term of the water's share too: scaling the torque by I / (I + J) instead slows a
        spinning body's precession, which depends on its spin's angular momentum alone, by that
        factor (0.41 for a 6 mm slate of 5 cm radius wholly under water, 0.65 for the reference skip's
        15 mm one)."""
        return (inertia[0] + self.diameter_inertia, inertia[1] + self.diameter_inertia,
                inertia[2] + self.axial_inertia)


_ADDED_MASS_FIELDS = (("axial", "kg"), ("radial", "kg"), ("axial_inertia", "kg m^2"), ("diameter_inertia", "kg m^2"))


def _split_scale(axis: Sequence[float], h: Sequence[float], along: float, across: float) -> tuple[float, float, float]:
    """``along`` (h.n) n + ``across`` (h - (h.n) n) for the unit vector n = ``axis``."""
    k = (along - across) * (h[0] * axis[0] + h[1] * axis[1] + h[2] * axis[2])
    return (across * h[0] + k * axis[0], across * h[1] + k * axis[1], across * h[2] + k * axis[2])


@message
class Impulse(Message):
    """An instantaneous change applied once at the start of the receiver's step, world frame.

    linear: (3,) impulse [N s]; angular: (3,) angular impulse about the centre of mass [N m s];
    correction: (3,) position correction [m] removing penetration (applied directly to the
    position, not through the velocity, so it adds no energy). Additive.
    """

    linear: Vec3
    angular: Vec3
    correction: Vec3

    additive = True

    def __add__(self, other: Impulse) -> Impulse:  # type: ignore[override]
        return Impulse(self.linear + other.linear, self.angular + other.angular,
                       self.correction + other.correction)

    @staticmethod
    def zero() -> Impulse:
        return Impulse(np.zeros(3), np.zeros(3), np.zeros(3))


@message
class GroundContact(Message):
    """What the solid ground did this step.

    in_contact: the body touches a plane; normal_force [N] (>= 0); friction_force [N];
    sliding: kinetic (true) or static (false) friction; dissipated_energy [J]: total energy removed by
    impacts and friction since the start (cumulative, so energy books close at any time).
    """

    in_contact: bool
    normal_force: float
    friction_force: float
    sliding: bool
    dissipated_energy: float


@message
class PatchRequest(Message):
    """The water region a consumer needs next step, world frame [m]: x in [x_min, x_max],
    y in [y_min, y_max]. An empty request (x_min > x_max) asks for nothing.
    columns: False asks for the region's crest only (HeightPatch.crest, no columns): a body far
    above the water asks so, to learn whether a wave reaches up to it."""

    x_min: float
    x_max: float
    y_min: float
    y_max: float
    columns: bool = True

    @staticmethod
    def empty() -> PatchRequest:
        return PatchRequest(1.0, 0.0, 1.0, 0.0)


@message
class HeightPatch(Message):
    """Water columns over a window of the grid.

    i0, j0: grid index of the window's first column (x) and row (y); cell: cell size [m];
    origin_x, origin_y: world position of the centre of cell (0, 0) [m], so cell (i, j) is centred at
    (origin_x + i*cell, origin_y + j*cell); rest_level: undisturbed surface height [m];
    height: (nj, ni) surface elevation z [m]; velocity: (nj, ni) vertical surface velocity [m/s];
    bottom: (nj, ni) bed elevation z [m]. An empty window has shape (0, 0).
    occupied: (nj, ni) the occupied height b [m] the water had applied when it computed this window
    (the last OccupiedHeight it received, already part of ``height``), so that the body that sent it
    knows how much of its own displacement the water holds; (0, 0) when the source does not say
    (hand-made still water).
    off_grid: the window is empty because the request lay wholly outside the water's grid: there is
    no water there (an empty window without it means that nothing was asked yet).
    crest: the highest the surface stands above rest_level over the window [m] (the occupied height
    under a body included), rounded up to the millimetre; sent alone, with no columns, for a request
    of the crest only; at t = 0, before anything is asked, the whole water's. -1 when not known: an
    empty window (nothing asked, or off the grid), or a source that does not say (hand-made water).
    """

    i0: int
    j0: int
    cell: float
    origin_x: float
    origin_y: float
    rest_level: float
    height: Grid
    velocity: Grid
    bottom: Grid
    occupied: Grid = dataclasses.field(default_factory=lambda: np.zeros((0, 0)))
    off_grid: bool = False
    crest: float = -1.0


@message
class OccupiedHeight(Message):
    """Height of each water column occupied by bodies, b_ij [m], over a window of the grid.

    Absolute (not a change): the water applies h += b - b_prev itself, so a slower water component
    sampling the latest message still conserves volume. Columns outside the window have b = 0.
    i0, j0: first column and row; b: (nj, ni).
    already_displaced: the body was in the water when the run began, so its displacement is part of
    the water at rest (a floating ball let go at its waterline leaves the surface flat): the water
    takes the first such b of a body as already there, without raising its surface.
    """

    i0: int
    j0: int
    b: Grid
    already_displaced: bool = False


@message
class WaterField(Message):
    """The whole surface, for viewers only (published at the water's field_rate or every field_every
    steps, never to physics).

    cell [m]; origin_x, origin_y: centre of cell (0, 0) [m]; height: (ny, nx) elevation z [m];
    volume: total water volume above the bed [m^3]; energy: the wave model's energy [J] (the explicit
    model's lattice energy, oscillating about its step's exact invariant without drift (by a few
    percent for waves many columns long, by several times for grid-scale noise near the stable step),
    so bounded when the model is stable, and for short waves far above their physical energy, see
    components.water.diagnostics;
    the implicit shallow_water model's lattice energy, which its numerical damping takes; the airy
    model's modes' energy);
    active_fraction: share of the water stepped in the last step (tiles not at rest over all tiles; 1
    when every column is stepped). With a
    field window the height covers that window only (origin_x, origin_y its first cell), volume,
    energy and active_fraction the whole water.
    """

    cell: float
    origin_x: float
    origin_y: float
    height: Grid
    volume: float
    energy: float
    active_fraction: float = 1.0


@message
class WaterContact(Message):
    """What the water did to the body this step (for the stage monitor, plots and energy books).

    wetted: the body touches water; submerged_fraction: immersed volume / body volume;
    wetted_area [m^2]: the wetted surface as the surface effects meet it (0 when neither pressure
    nor friction is on: only they tile the faces); buoyancy, pressure, friction, wave_drag: (3,)
    forces of each effect [N]; depth: depth of the body's lowest point below the local surface [m]
    (negative above it; over dry land, where there is no surface, below the rest level; for a body
    far above the water, its bounding sphere above the coupler's wave_allowance over the rest level
    or the crest the water reports, the bounding sphere's lowest point below the rest level, which
    costs no look at its pose);
    dissipated_energy [J], cumulative work done by the water on the body, with the sign flipped.
    """

    wetted: bool
    submerged_fraction: float
    wetted_area: float
    buoyancy: Vec3
    pressure: Vec3
    friction: Vec3
    wave_drag: Vec3
    depth: float
    dissipated_energy: float


class StageId(enum.IntEnum):
    """Stages of a throw (Tsai et al. 2022 names)."""

    APPROACH = 0
    HIT = 1
    SLIDE = 2
    FLY_AWAY = 3
    SINK = 4
    REST = 5
    FLOAT = 6  # a stone lighter than water, too slow to skip: it floats instead of sinking
    LEFT_POND = 7  # off the water's grid (over its edge, or thrown past it): the run ends there
    GROUND = 8  # on the solid ground and dry, not at rest: sliding, rolling or bouncing on it


@message
class Stage(Message):
    """A stage change: stage id with its label beside it, the skip count so far, the position x, y
    [m] (of left-pond: where the stone came down beside the water, a little before the change; y NaN
    in recordings made before it was kept), and since [s], when the stage began: the message is
    published when the stage is known, which for rest is the end of the slow spell that makes it
    (REST_HOLD on), and for the run's first stage the end of its first step (NaN in recordings made
    before it was kept: the message's time)."""

    stage: StageId
    label: str
    skips: int
    x: float
    y: float = math.nan
    since: float = math.nan


@message
class SkipRecord(Message):
    """Figures of one finished skip (published at fly-away).

    index: 1 for the first skip; touchdown_time [s] and touchdown_x, touchdown_y [m] where the contact
    began;
    contact_time [s]; takeoff_angle_deg: angle of the velocity above the horizontal at fly-away;
    distance [m]: from the previous touchdown (or the throw's start, for the first) to this one,
    along the line the stone was thrown along (its horizontal heading at t = 0);
    speed_in, speed_out [m/s]: speed at touchdown and at fly-away.
    The sideways curve a spinning stone takes: drift [m], how far the touchdown point lies beside the
    line the stone was thrown along (left of the throw positive); heading_deg, the direction of the
    horizontal velocity at fly-away against the throw's starting direction (turned left positive).
    peak_g: the largest vertical force of the water on the stone during the contact over its weight
    [g], what an accelerometer riding in the stone reads along the vertical (Tang et al. 2021 find a
    disk bounces when it passes about 4 g, docs/validation.md section 2c); the water's drag along the
    water, which can be larger (a thick edge ploughing in), is not in it.
    """

    index: int
    touchdown_time: float
    touchdown_x: float
    contact_time: float
    takeoff_angle_deg: float
    distance: float
    speed_in: float
    speed_out: float
    drift: float = 0.0
    heading_deg: float = 0.0
    peak_g: float = 0.0
    touchdown_y: float = math.nan  # [m] where the contact began (NaN in recordings made before it was kept)
