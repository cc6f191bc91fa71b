"""WaterCoupler: the two-way stone-water interaction, per water column under the body.

Ports (see DESIGN.md section 3)::

    body   (BodyState,   direct edge from the stone: its state at the END of its step)  --+
    water  (HeightPatch, direct edge from the water: the window requested last step)  ---+--> coupler
    ground (Impulse,     optional, direct edge from a SolidGround of the same body: its answer to that
                         state, which the body applies at the start of its next step; the coupler
                         meets the water with the body as the ground leaves it) ----------+
    coupler --> wrench   (Wrench, to the body through a delayed edge, held over its next step)
            --> occupied (OccupiedHeight, to the water: absolute displacement b_ij; empty when dry)
            --> request  (PatchRequest, to the water: the body's footprint at its next position)
            --> contact  (WaterContact, to the stage monitor, plots and energy books)
            --> added_mass (AddedMass, to the body through a delayed edge: the water a submerged
                            body carries along, for its inertia; effect ``added_mass``)

One step: read the body state and the patch; if the body is far from the water, publish a zero
wrench, an empty occupied window and an empty request at once (no column work). Otherwise evaluate
the named effects (:mod:`components.coupler.kernel`) at the received state and publish their sum;
with the ring displacement and one step at a time (the usual case) all of that column and element
work is one compiled call (:mod:`components.coupler.step_kernel`), and Python only reads and builds
the messages.

Displacement and buoyancy (``displacement_mode: ring``, the default): the volume the body holds
under the rest level is pushed out into a ring of columns around it (spread further, once the body
is under the rest level, over the width an image source at its top's depth gives:
:func:`kernel.depth_spread`), and the buoyancy is Archimedes'
force against the rest level plus rho g times the water's height where that volume went, on each
waterline column (:meth:`WaterCoupler._add_hydrostatics`). The work the buoyancy does on a heaving
or rocking body is then what the displacement gives the water, so the two together gain no energy
and the body is damped by the waves it radiates. With ``column`` (Mueller's b under the body, as
the height-field demos do) the buoyancy uses the surface under the body, which the body's own
displacement raised: a floating or slow body is fed back its own displacement and gains energy
without bound (a warning says so as the scene loads); it is kept for comparison with those demos.

Stability: :meth:`WaterCoupler.max_stable_step` bounds the step by the linearised stiffness and
damping of the water forces against the body's mass and inertia. When the scheduler substeps the
coupler (``on_unstable: substep``), the coupler advances a private copy of the body (its water
forces plus gravity, semi-implicit Euler) through the substeps and publishes the mean wrench over
the step: the impulse the body then receives equals the finely resolved one, so a 30 m/s entry
neither explodes nor forces a globally tiny step. (With held inputs, repeating the same evaluation
would be pointless, so this component overrides the base class's substep loop.) The scheduler counts
a step's substeps from the bound of the last state evaluated, the body's previous one; a step whose
own state needs a shorter one is taken again in that many (:meth:`WaterCoupler._restepped`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal, NamedTuple

import numpy as np

from components import compiled
from components.coupler import kernel, step_kernel
from components.coupler.added_mass import ZERO as ZERO_ADDED_MASS
from components.coupler.added_mass import AddedMassBook, full_added_mass, scaled
from components.coupler.effects import (
    ADDED_MASS,
    BUOYANCY,
    COLUMN_MASK,
    DISPLACEMENT,
    EFFECTS,
    ELEMENT_MASK,
    FRICTION,
    PRESSURE,
    effect_mask,
    unknown_effects,
)
from components.coupler.forces import (
    C_DRAG_DISK,
    C_DRAG_SPHERE,
    C_FRICTION,
    C_IMPACT,
    C_LIFT,
    C_MIN,
    C_WAVE,
    CLOSURE_DEPTH,
    GRAVITY,
    RHO_WATER,
)
from components.coupler.geometry import (
    Elements,
    disk_elements,
    disk_half_extents,
    lowest_point,
    quat_to_matrix,
    sphere_elements,
)
from components.coupler.met_surface import MetSurface, planing_share
from components.messages import (
    AddedMass,
    BodyState,
    HeightPatch,
    Impulse,
    OccupiedHeight,
    PatchRequest,
    Shape,
    WaterContact,
    Wrench,
)
from components.rigid import quaternion as quat
from components.rigid.dynamics import RigidState, apply_impulse
from components.rigid.shapes import shape_volume
from components.rigid_body import gravity_mismatch
from cosim.component import Component, Port
from cosim.messages import Message
from cosim.params import param, require_valid

DAMPING_SAFETY = 1.0  # step <= this / damping rate: explicit relaxation never overshoots (limit is 2) [-]
SPRING_SAFETY = 1.0  # step <= this / sqrt(stiffness / mass) (symplectic limit is 2) [-]
APPROACH_SAFETY = 4.0  # a dry body's step <= this / the damping rate of its whole face at its speed [-]
MOTION_FRACTION = 0.25  # near the water a step may carry the body at most this fraction of its radius [-]
MAX_AUTO_SUBSAMPLES = 16  # cap of the automatic sub-cells per column side [-]
SUBSAMPLES_PER_RADIUS = 12.0  # automatic sub-cells: about this many samples per body radius [-]
SAMPLES_ACROSS = 12.0  # automatic sub-cells: and at least this many across the body's narrowest width [-]
DEFAULT_MARGIN = 0.05  # request margin before the first patch tells the cell size [m]

ALL_EFFECTS = [name for name in EFFECTS if name != "added_mass"]  # the default: the forces; added_mass is
# named where the body takes it (its own port, connected in the scene)
_EFFECTS_DOC = ("effects switched on, by name: " + ", ".join(EFFECTS)
                + " (added_mass acts through the body's added_mass input: connect it; not in the default)")


def _ro(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


_ZERO3 = _ro(np.zeros(3))
_EMPTY_GRID = _ro(np.zeros((0, 0)))
_NO_WATERLINE = np.zeros((0, 0, 0))  # evaluate: no per-column waterline wanted (empty, never written)


class _Ring(NamedTuple):
    """One step's ring displacement (see :meth:`WaterCoupler._ring`)."""

    rest: np.ndarray  # stats of the body under a flat surface at the rest level (kernel.S_* layout)
    lifted: np.ndarray  # sum_k level_k (A_k, moment_y_k, -moment_x_k) [m^3] (kernel.ring_lift)
    window: tuple[int, int, np.ndarray] | None  # (i_lo, j_lo, b) in patch indices [m]; None: nothing


COEFFICIENT_MAX = 1e3  # [-] a force coefficient's upper bound: the published ones are of order 1
RHO_MAX = 1e5  # [kg/m^3] the liquid's density at most: mercury is 13,546, and more only overflows the forces


LENGTH_MAX = 1000.0  # [m] the coupler's lengths at most: a wet_ramp of 1e308 overflowed its forces mid-run


@dataclass(frozen=True)
class WaterCouplerParams:
    """Parameters of the water coupler (SI units; coefficients from physics.md section 3)."""

    effects: list[str] = param(ALL_EFFECTS, doc=_EFFECTS_DOC)
    rho: float = param(RHO_WATER, unit="kg/m^3", gt=0, le=RHO_MAX, doc="water density (at most 100,000 kg/m^3)")
    g: float = param(GRAVITY, unit="m/s^2", ge=0, le=1e4,
                     doc="gravity (buoyancy and the substep predictor; 0, or 1e-6 to 1e4 m/s^2)")
    c_l: float = param(C_LIFT, ge=0, le=COEFFICIENT_MAX, doc="pressure coefficient C_L of the Rosellini/Clanet law")
    c_n: float = param(0.0, ge=0, le=COEFFICIENT_MAX,
                       doc="Newtonian coefficient C_N of the faces (0 = off; 1.4 per Nagahiro & Hayakawa)")
    c_b: float = param(C_IMPACT, ge=0, le=COEFFICIENT_MAX,
                       doc="impact pressure coefficient C_B of a blunt body (a sphere): "
                           "1/2 rho C_B (u.n)^2 where it advances into the water")
    c_f: float = param(C_FRICTION, ge=0, le=COEFFICIENT_MAX, doc="skin friction coefficient C_f")
    c_w: float = param(C_WAVE, ge=0, le=COEFFICIENT_MAX, doc="capillary-gravity wave drag coefficient C_W")
    c_min: float = param(C_MIN, unit="m/s", ge=0, le=1e3, doc="minimum capillary-gravity wave speed")
    c_d_disk: float = param(C_DRAG_DISK, ge=0, le=COEFFICIENT_MAX,
                            doc="pressure drag coefficient of a submerged disk (face on)")
    c_d_sphere: float = param(C_DRAG_SPHERE, ge=0, le=COEFFICIENT_MAX,
                              doc="pressure drag coefficient of a submerged sphere: its measured total, 0.47, "
                                  "less the skin friction the friction effect adds over it (8/3 C_f)")
    closure_depth: float = param(CLOSURE_DEPTH, unit="m", gt=0, le=LENGTH_MAX,
                                 doc="the planing law fades out as the body's top goes this far under the "
                                     "surface (the water closes over it); below, the body is submerged")
    displacement_mode: Literal["ring", "column"] = param(
        "ring", doc="ring: displaced volume around the body, buoyancy at the water's level there "
                    "(energy-consistent); column: Mueller's b under it, buoyancy at the surface there, "
                    "which its own displacement raised: a floating body gains energy without bound")
    ring_share: float = param(0.5, ge=0, le=100,
                              doc="half-width of the displacement band as a share of the body's radius (the band "
                                  "spans twice that outside the outline)")
    ring_cells: float = param(1.5, gt=0, le=100, doc="least half-width of the displacement band [cells]")
    smoothing: int = param(0, ge=0, le=1000, doc="volume-conserving [1,2,1] smoothing passes of the displacement")
    column_subsamples: int = param(0, ge=0, le=64, doc="sub-cells per column side (0: automatic from R/cell)")
    face_elements: int = param(16, ge=2, le=1024, doc="disk face tiling: squares across a diameter")
    rim_elements: int = param(48, ge=3, le=4096, doc="disk rim tiling: strips around the rim")
    sphere_bands: int = param(24, ge=2, le=1024, doc="sphere tiling: equal-area latitude bands")
    wet_ramp: float = param(5e-4, unit="m", gt=0, le=LENGTH_MAX,
                            doc="least depth over which a level element goes from dry to wet")
    margin_cells: int = param(4, ge=0, le=1000, doc="request margin around the footprint [cells]")
    lookahead: float = param(0.06, unit="s", ge=0, le=10,
                             doc="the requested window reaches as far ahead as the body moves in this time "
                                 "(a contact's length: the surface it meets is the one it saw coming)")
    water_level: float | None = param(None, unit="m", ge=-1e6, le=1e6,  # as a water's rest level (1000 km)
                                      doc="rest level assumed until the first patch arrives (within 1000 km of "
                                          "z = 0); default: the water's own, 0 until it is known")
    wave_allowance: float = param(0.05, unit="m", ge=0, le=LENGTH_MAX,
                                  doc="a body this high above the rest level is far from the water, or as high "
                                      "as the crest where it goes when that is higher (HeightPatch.crest)")
    quiet_above: float = param(0.01, unit="m", ge=0, le=LENGTH_MAX,
                               doc="a dry body whose lowest point is this far above the local surface "
                                   "publishes its unchanged outputs once, then holds them")

    def check(self) -> list[tuple[str, str]]:
        problems = [("effects", p) for p in unknown_effects(self.effects)]
        if 0.0 < self.g < 1e-6:  # a gravity of 1e-320 overflowed the planing share's Froude number
            problems.append(("g", f"must be 0 (weightless) or at least 1e-06 m/s^2 (got {self.g:g})"))
        return problems


def _bounding_radius(body: BodyState) -> float:
    """The radius [m] of the sphere about the body's centre that holds it (a disk's rim corners)."""
    return math.hypot(float(body.radius), 0.5 * float(body.thickness))


def _top_of(body: BodyState) -> float:
    """The height [m] of the body's highest point: a sphere's top, a disk's highest rim point (its
    axis a_z from the vertical: R sqrt(1 - a_z^2) + e/2 |a_z| above the centre)."""
    z = float(body.position[2])
    if body.shape != Shape.DISK:
        return z + float(body.radius)
    a_z = quat.body_axis(body.orientation.tolist())[2]
    return z + float(body.radius) * math.sqrt(max(0.0, 1.0 - a_z * a_z)) + 0.5 * float(body.thickness) * abs(a_z)


def _lowest_of(body: BodyState) -> float:
    """The height [m] of the body's lowest point (a disk's lowest rim point), not its bounding
    sphere's, which is sqrt(R^2 + e^2/4) under the centre whatever the disk's attitude (a level
    disk's lowest point is e/2 under it)."""
    axis = quat.body_axis(body.orientation.tolist())
    return lowest_point(body.shape == Shape.DISK, body.position, axis, float(body.radius),
                        float(body.thickness))[2]


def _surface_speed(body: BodyState) -> float:
    """The fastest a point of the body's surface can move [m/s]: |v| + R |omega|."""
    v, w = body.velocity.tolist(), body.angular_velocity.tolist()
    speed = math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
    return speed + float(body.radius) * math.sqrt(w[0] ** 2 + w[1] ** 2 + w[2] ** 2)


def _bed_under(pos: np.ndarray, patch: HeightPatch) -> float | None:
    """The water's bed [m] under the point ``pos`` (x, y), from the patch; None off the patch."""
    i = round((float(pos[0]) - patch.origin_x) / patch.cell) - int(patch.i0)
    j = round((float(pos[1]) - patch.origin_y) / patch.cell) - int(patch.j0)
    nj, ni = patch.bottom.shape
    return float(patch.bottom[j, i]) if 0 <= i < ni and 0 <= j < nj else None


def _under_the_bed(z: float, top: float, bed: float) -> str | None:
    """Why a body centred at height ``z`` whose bounding sphere's top is at ``top`` cannot start
    over a bed at ``bed`` [m]: it lies wholly under it; None when it does not."""
    if not top < bed:
        return None
    return (f"the body starts {bed - top:.4g} m below the water's bed (its centre at z = {z:.4g} m, the bed "
            f"under it at z = {bed:.4g} m): start it above the bed")


def _in_dry_land(pos: np.ndarray, top: float, bed: float, level: float, late: bool) -> str:
    """Why a run ends with a body (centred at ``pos``, its bounding sphere's top at ``top`` [m])
    wholly inside a bed at ``bed`` [m] that rises above the water's rest ``level`` [m]: it ran into
    dry land, which is no solid. ``late``: found at the water's first patch of columns, which a
    body above the water does not ask for (the coupler asks only for the crest where it goes until
    the body comes within wave_allowance, or that crest, of the rest level), so the body went in
    before."""
    x, y, z = (float(c) for c in pos)
    found = (" (found as it came down to the water's level: the coupler does not look at the bed while the "
             "body is above the water)") if late else ""
    return (f"the body ran into dry land at x = {x:.4g} m, y = {y:.4g} m: the water's bed there, at z = {bed:.4g} m, "
            f"rises above the rest level z = {level:.4g} m, and the body is wholly inside it (its centre at "
            f"z = {z:.4g} m, its top {bed - top:.4g} m under the bed){found}; the bed is not solid: to land the "
            "body on it, add a SolidGround there (as scenarios/float_sphere.yaml does)")


# [-] the wetted area over R^2 (and volume over R^3) below which a body is not wetted: round-off of a
# body on the bed of a dry column, far below any real first touch (a disk's first wet step wets mm^2)
WET_FLOOR = 1e-12


class WaterCoupler(Component):
    """Stone-water interaction per water column: displacement, buoyancy, pressure, friction, wave drag,
    added mass."""

    Params = WaterCouplerParams
    inputs = {
        "body": Port(BodyState, "the body's state at the end of its step", required=True),
        "water": Port(HeightPatch, "the water over the window requested last step", required=True),
        "ground": Port(Impulse, "solid grounds' answer to the same body state, applied at the start of the "
                                "body's next step: the water is met with the body as they leave it", event=True),
    }
    outputs = {
        "wrench": Port(Wrench, "water force and torque on the body, held over its next step"),
        "occupied": Port(OccupiedHeight, "displaced height b_ij (absolute); empty when dry"),
        "request": Port(PatchRequest, "the window of water needed next step"),
        "contact": Port(WaterContact, "what the water did this step"),
        "added_mass": Port(AddedMass, "the water a submerged body carries along, for the body's inertia "
                                      "(effect added_mass; published when it changes)"),
    }

    # --- lifecycle -------------------------------------------------------------------------------

    def setup(self) -> None:
        p = self.params
        problems = unknown_effects(p.effects)
        if problems:
            raise ValueError("effects: " + "; ".join(problems))
        require_valid(p)  # (built in code, a water density of -1 was taken)
        self.flags = effect_mask(p.effects)
        self._approach_rates: dict[tuple, float] = {}  # _approach_bound's damping rate per speed, by body
        # the added mass is no force of the kernels: the body takes it on its own port
        self.added_mass_on = bool(self.flags & ADDED_MASS)
        self.flags &= ~ADDED_MASS
        # fixed by the parameters: whether the ring displacement is on, and the effects evaluated
        # against the local surface: all of them, except the buoyancy when the ring is on (it is
        # then evaluated against the rest level, see _ring)
        self._ring_on = bool(self.flags & DISPLACEMENT) and p.displacement_mode == "ring"
        self._local = self.flags & ~BUOYANCY if self._ring_on else self.flags
        compiled.start()
        self._elements: Elements | None = None
        self._elements_key: tuple | None = None
        self._stats = np.zeros(kernel.N_STATS)
        self._b_geo = np.zeros((0, 0))
        self._ring_work: dict[str, np.ndarray] | None = None  # work arrays of the ring (_ring_arrays)
        self._still: tuple[np.ndarray, np.ndarray] | None = None  # flat patch at the rest level
        self._zero_contact_cache: tuple[float, WaterContact] | None = None
        self._scratch: step_kernel.RingScratch | None = None  # work arrays of the one-call step
        self._bv = np.empty(step_kernel.N_BODY)  # the usual step's body vector, filled each step
        # the parameter vector of each shape (its submerged drag coefficient in)
        self._prm_disk = self._parameter_vector(self.params.c_d_disk)
        self._prm_sphere = self._parameter_vector(self.params.c_d_sphere)
        self._zero_wrench = Wrench(_ZERO3, _ZERO3)
        self._empty_occupied = OccupiedHeight(0, 0, _EMPTY_GRID)
        self._empty_request = PatchRequest.empty()
        self.work = {"columns": 0, "elements": 0}
        self._reset_state()

    def _parameter_vector(self, c_d: float) -> np.ndarray:
        """The scalar parameters as :mod:`step_kernel`'s parameter vector (P_* layout), with ``c_d``
        the submerged drag coefficient of the body's shape."""
        p = self.params
        prm = np.zeros(step_kernel.N_PARAMS)
        for index, value in ((step_kernel.P_RHO, p.rho), (step_kernel.P_G, p.g), (step_kernel.P_C_L, p.c_l),
                             (step_kernel.P_C_D, c_d),
                             (step_kernel.P_C_N, p.c_n), (step_kernel.P_C_B, p.c_b), (step_kernel.P_C_F, p.c_f),
                             (step_kernel.P_C_W, p.c_w),
                             (step_kernel.P_C_MIN, p.c_min), (step_kernel.P_WET_RAMP, p.wet_ramp),
                             (step_kernel.P_CLOSURE, p.closure_depth), (step_kernel.P_RING_CELLS, p.ring_cells),
                             (step_kernel.P_RING_SHARE, p.ring_share),
                             (step_kernel.P_DAMPING_SAFETY, DAMPING_SAFETY),
                             (step_kernel.P_SPRING_SAFETY, SPRING_SAFETY),
                             (step_kernel.P_MOTION_FRACTION, MOTION_FRACTION)):
            prm[index] = value
        return prm

    def _reset_state(self) -> None:
        self.rest_level = self._assumed_level()
        self.cell = 0.0
        # in the water when the run began: its displacement is part of the water at rest, said so on
        # every occupied window until the water's patches show it holds it (see OccupiedHeight)
        self._start_in_water = True
        # the height of the body's lowest point when the run began [m] (start_inputs); None
        # when not told (a coupler stepped by hand): taken as a body that came down into the water
        self._start_bottom: float | None = None
        self._start_top: float | None = None  # its bounding sphere's top then [m] (the bed's check)
        self._crest = 0.0  # [m] over the rest level: the highest the water said it stands where the body goes
        self.dissipated = 0.0
        self.bound = math.inf
        # last published wrench and the state it acts from (force, position, torque, omega: 3 floats each)
        self._prev: dict[str, list[float]] | None = None
        self._published: BodyState | None = None  # the body's state as published this step (the books')
        # idle outputs were published and still hold: publish nothing until the body comes near
        self.quiet = False
        self._went_idle = False
        self._held_request: PatchRequest | None = None  # the window the water holds from us
        self.met = MetSurface()  # the surface the body met, which the surface effects read
        self._planing_share = 0.0  # how far this step's body is planing, 0 (floating) to 1 (see planing_share)
        self._submerged = 0.0  # how far this step's body is a submerged one, 0 to 1 (1 - _immersion's share)
        self._added_book = AddedMassBook()  # also the added mass the body holds (the last published)

    def initial_outputs(self) -> dict[str, Message]:
        """At t = 0: zero wrench, empty occupied window and request, a dry contact report.

        The body's state is not known before its first step, so the first step requests the window
        (one step of lag, covered by the margin).
        """
        outputs = {"wrench": self._zero_wrench, "occupied": self._empty_occupied,
                   "request": self._empty_request, "contact": self._dry_contact(-math.inf)}
        if self.added_mass_on:
            outputs["added_mass"] = ZERO_ADDED_MASS
        return outputs

    def get_state(self) -> dict[str, Any]:
        prev = None
        if self._prev is not None:
            prev = {k: np.array(v, dtype=float) for k, v in self._prev.items()}
        return {"rest_level": self.rest_level, "cell": self.cell, "dissipated": self.dissipated,
                "bound": self.bound, "prev": prev, "quiet": self.quiet, **self.met.get_state(),
                "held_request": None if self._held_request is None else [
                    self._held_request.x_min, self._held_request.x_max,
                    self._held_request.y_min, self._held_request.y_max, self._held_request.columns],
                "start_in_water": self._start_in_water, "start_bottom": self._start_bottom,
                "start_top": self._start_top, "crest": self._crest,
                **(self._added_book.get_state() if self.added_mass_on else {})}

    def set_state(self, state: dict[str, Any]) -> None:
        self.rest_level = float(state["rest_level"])
        self.quiet = bool(state.get("quiet", False))
        held = state.get("held_request")
        # (a checkpoint before the crest-only windows holds four numbers: a window of columns)
        self._held_request = None if held is None else PatchRequest(
            *map(float, held[:4]), columns=bool(held[4]) if len(held) > 4 else True)
        empty = self._empty_request
        if held is not None and [float(v) for v in held[:4]] == [empty.x_min, empty.x_max, empty.y_min, empty.y_max]:
            # the request is held by identity (_publishable): the empty one is always this object, or a
            # restart would publish the empty request again, which the run it continues did not
            self._held_request = self._empty_request
        self.cell = float(state["cell"])
        self.dissipated = float(state["dissipated"])
        self.bound = float(state["bound"])
        prev = state.get("prev")
        self._prev = None if prev is None else {k: [float(x) for x in v] for k, v in prev.items()}
        self.met.set_state(state)
        self._start_in_water = bool(state.get("start_in_water", False))
        self._crest = float(state.get("crest", 0.0))  # (a checkpoint from before the crest: none known)
        bottom = state.get("start_bottom", math.inf)  # a checkpoint without it: as if it began above the water
        self._start_bottom = None if bottom is None else float(bottom)
        top = state.get("start_top")  # (a checkpoint without it is past the first patch that asks for it)
        self._start_top = None if top is None else float(top)
        self._added_book.set_state(state)

    def notices(self) -> list[str]:
        """A column displacement under a body that buoyancy holds up (see :attr:`Params.displacement_mode`)."""
        if self.params.displacement_mode == "column" and self.flags & DISPLACEMENT and self.flags & BUOYANCY:
            return ["displacement_mode: column reads the surface its own displacement raised, so a floating or "
                    "slow body gains energy from the water without bound (a cork disk heaving in a closed basin: "
                    "12 times its energy within 2 s); the default, ring, is energy-consistent "
                    "(docs/validation.md, section 7)"]
        return []

    def check_start_sources(self, inputs: dict[str, Message | None], sources: dict[str, Component]) -> list[str]:
        """Two mistakes in a scene that only the water feeding the coupler shows, refused when the scene
        loads: a ``water_level`` given other than the water's rest level (the level taken until the
        water's first patch), and a body that starts wholly under the water's bed (its bounding
        sphere's top below the bed under its centre), which :meth:`_check_not_under_the_bed` refuses
        at the water's first patch otherwise."""
        body, water = inputs.get("body"), sources.get("water")
        mismatch = gravity_mismatch(sources.get("body"), self.params.g, "g") if self.flags else None
        if mismatch is not None:  # the buoyancy, rho g V, and the planing share would be another body's
            return [mismatch]
        level = getattr(water, "rest_level", None)
        given = self.params.water_level
        if isinstance(level, float) and given is not None and level != given:
            # the level assumed until the water's first patch comes: a different one wets (or dries)
            # a body with water that is not there
            return [f"water_level {given:g} m is not the rest level {level:g} m of the water feeding it; leave "
                    "water_level out (the water's own is taken from its first patch) or give the water's rest_level"]
        bed_at = getattr(water, "bed_at", None)
        if not isinstance(body, BodyState) or bed_at is None:
            return []
        grid = getattr(water, "grid", None)
        width = min(grid.nx, grid.ny) * grid.cell if grid is not None else math.inf
        if 2.0 * float(body.radius) > width:  # no column of it can hold the body's displacement around it
            return [f"the body is {2.0 * float(body.radius):.4g} m across, wider than the water feeding it "
                    f"({width:.4g} m at its narrowest): is its radius in metres?"]
        x, y, z = (float(c) for c in body.position)
        bed = bed_at(x, y)
        problem = None if bed is None else _under_the_bed(z, z + _bounding_radius(body), bed)
        if problem is None and grid is not None and self.flags & DISPLACEMENT:
            problem = self._band_past_open_edge(body, water, grid)
        return [] if problem is None else [problem]

    def _band_past_open_edge(self, body: BodyState, water: Component, grid: Any) -> str | None:
        """Why a body that starts in open water (absorbing edges) cannot: the water it pushes aside,
        spread over a band reaching the body's radius plus twice the band's half-width from its centre,
        would fall past the water's edge, whose open boundary takes such a deposit in as an incoming
        wave and gives it back: a 0.6 m pine ball in a 0.8 m pond bobbed higher at every bob (133 to
        230 J) on water that grew by up to 65%. None when it fits, the body starts out of the water,
        or the edges are walls."""
        if getattr(getattr(water, "params", None), "boundary", None) != "absorbing":
            return None
        radius = float(body.radius)
        if float(body.position[2]) - _bounding_radius(body) >= float(grid.rest_level):
            return None  # dry at the start: it may well land away from the edges
        p = self.params
        reach = radius + 2.0 * kernel.band_width(p.ring_cells, p.ring_share, float(grid.cell), radius)
        half = 0.5 * float(grid.cell)
        x, y = float(body.position[0]), float(body.position[1])
        room = min(x - (grid.origin_x - half), grid.origin_x + (grid.nx - 0.5) * grid.cell - x,
                   y - (grid.origin_y - half), grid.origin_y + (grid.ny - 0.5) * grid.cell - y)
        if reach <= room:
            return None
        return (f"the water the body pushes aside reaches {reach:.4g} m from its centre (its radius and the "
                f"displacement's band), past the open edge of the water feeding it ({max(room, 0.0):.4g} m away), "
                "which would take it in as a wave and give it back, feeding the body's bobbing: a larger pond, "
                "the body farther from the edge, or reflecting edges")

    def start_inputs(self, inputs: dict[str, Message | None]) -> None:
        """Where the body began: the height of its lowest point at t = 0 (see
        :meth:`_mound_raised`); and the bound of the first step (:meth:`start_stable_step`)."""
        body = inputs.get("body")
        if isinstance(body, BodyState):
            # its own lowest point, not its bounding sphere's: a level disk a few mm above the water
            # has its sphere centimetres under it, and was taken as already in the water (its wake lost)
            self._start_bottom = _lowest_of(body)
            self._start_top = float(body.position[2]) + _bounding_radius(body)
            # the first step's bound, as every later step near the water has one: without it the first
            # step was taken whole however fast the body came in (at 2 km/s it was thrown out at 25)
            self.bound = min(self.bound, self.start_stable_step(inputs))

    def needed_outputs(self) -> dict[str, str]:
        """The wrench whenever a force acts, the request always (the water sends only the window asked
        for: without it the body meets still water that never moves), the occupied height with the
        displacement, the added mass with its effect: each is how an effect reaches the body or the
        water, and left unconnected the effect silently does nothing."""
        needed = {"request": "the water sends only the window asked for: connect it to the water's request "
                             f"input, e.g. {{from: {self.name}.request, to: <water>.request, delay: 1, "
                             "initial: {x_min: 1, x_max: 0, y_min: 1, y_max: 0}} (an empty window; on a water "
                             "shared by several bodies, its request_<body> input)"}
        if self.flags & ~(DISPLACEMENT | ADDED_MASS):
            needed["wrench"] = ("the body feels the water's forces only through it: connect it to the body's "
                                f"wrench input, e.g. {{from: {self.name}.wrench, to: <body>.wrench, delay: 1, "
                                "initial: {force: [0, 0, 0], torque: [0, 0, 0]}}")
        if self.flags & DISPLACEMENT:
            needed["occupied"] = ("effect displacement reaches the water only through it: connect it to the water's "
                                  f"occupied input, e.g. {{from: {self.name}.occupied, to: <water>.occupied, "
                                  "delay: 1, initial: {i0: 0, j0: 0, b: []}} (on a water shared by several bodies, "
                                  "its occupied_<body> input)")
        if self.added_mass_on:
            needed["added_mass"] = ("effect added_mass acts only through it: connect it to the body's added_mass "
                                    f"input, e.g. {{from: {self.name}.added_mass, to: <body>.added_mass, delay: 1, "
                                    "initial: {axial: 0, radial: 0, axial_inertia: 0, diameter_inertia: 0}}")
        return needed

    def exclusive_inputs(self) -> tuple[str, ...]:
        """One coupler of a body to a water: a second adds the water's forces again."""
        return ("body", "water")

    def fed_through(self) -> dict[str, str]:
        """The grounds' impulses it is told of answer the body whose state it reads (another body's
        would move this one's water as if it had been bounced)."""
        return {"ground": "body"}

    def told_of(self) -> dict[str, tuple[str, str]]:
        """Its ``ground`` takes every impulse its body's ``impulse`` takes, directly and at its rate (one
        of two grounds left out, a delayed edge or a coupler stepping every 2 met the body with the
        wrong answer, or none)."""
        return {"ground": ("body", "impulse")}

    def answers(self) -> dict[str, str]:
        """The wrench and the added mass go back to the body whose state it reads (wired to another
        body, one stone was pushed by the water another met: 305 m/s)."""
        answers = {}
        if self.flags & ~(DISPLACEMENT | ADDED_MASS):
            answers["wrench"] = "body"
        if self.added_mass_on:
            answers["added_mass"] = "body"
        return answers

    def idle_outputs(self) -> dict[str, str]:
        if self.added_mass_on:
            return {}
        return {"added_mass": "it publishes none without the effect added_mass (not in the default effects)"}

    def input_max_age(self, port: str) -> tuple[float, str] | None:
        """The water's patch must come at least every ``lookahead`` seconds when the window is asked
        for that far ahead (the displacement ring on): a patch kept longer no longer reaches the
        body, which would fall through the water as if off its edge."""
        if port == "water" and self._ring_on and self.params.lookahead > 0:
            return self.params.lookahead, "lookahead"
        return None

    def max_stable_step(self) -> float:
        """Largest stable step [s] from the last evaluated state (inf when the body is far from water).

        min of DAMPING_SAFETY / lambda, with lambda = max(sum dF/dv / m, sum d(torque)/d(omega) / I_min)
        (pressure: rho (C_L |u| + C_N u.n) dA per advancing element; friction: rho C_f |u| dA per wet
        element), SPRING_SAFETY / sqrt(k / m), with k the growth of the pressure force with depth
        plus rho g A_waterline, and MOTION_FRACTION R / (|v| + R |omega|) while near the water.
        """
        return self.bound

    def _restepped(self, n: int) -> int:
        """The substeps this step takes, ``n`` as the scheduler set them, or more when the bound of
        the body's state just evaluated (:attr:`bound`) is shorter than ``n`` of them: the
        scheduler's count came from the state before (:meth:`max_stable_step` is the last
        evaluation's), and the wrench published now is held over the body's next step from this
        state. Its force was published unrefined, and the scheduler substepped the step after: a
        1.6 g disk meeting the water at 10 m/s took a 0.1 ms step whole against its state's 16 us
        and skipped off at 12.9 m/s, given the water's energy. Decided as the scheduler decides a
        step's substeps (:meth:`~cosim.component.Component.restep`): under on_unstable: error the
        run fails here, the force never published. ``n`` itself for a coupler driven by hand,
        outside a step, and for a bound of 0 or less or NaN, of forces that overflowed: the step's
        check of its outputs names the field that is not finite (the scheduler refuses the bound at
        the next step, as :meth:`_predict` leaves it)."""
        if not self.bound > 0.0:
            return n
        more = self.restep(self.bound)
        return n if more is None else more

    def summary(self) -> list[str]:
        label = "water coupler" if self.name == "coupler" else f"water coupler {self.name}"  # several: which
        return [f"{label}: effects {', '.join(self.params.effects) or 'none'}; "
                f"energy taken from the body {self.dissipated:.4g} J"]

    # --- stepping ---------------------------------------------------------------------------------

    def _step_impl(self, t: float, dt: float, inputs: dict[str, Message | None]) -> dict[str, Message]:
        return self._substep(t, dt, 1, inputs)

    def _substep(self, t: float, dt: float, n: int, inputs: dict[str, Message | None]) -> dict[str, Message]:
        answered = _answered(inputs)
        # the wrench's work is booked between the states the body published, as without a ground: the
        # ground charges the correction's jump to the other forces (components.contact.solver, point
        # 4), so the water's book counts the force along it (booked from the corrected states, a ball
        # resting on the bed under water gave its buoyancy's B |c|, 3.4e-6 J, to the books each step)
        self._published = inputs.get("body")  # type: ignore[assignment]
        outputs = self._advance(dt, n, answered)
        if answered is not inputs and self._prev is not None:
            # (the angular velocity stays the answered one: the ground books its angular impulse
            # itself, and the torque's work over the step is from the rate the step began with)
            self._prev["position"] = inputs["body"].position.tolist()  # type: ignore[union-attr]
        return self._with_added_mass(answered.get("body"), self._publishable(outputs))

    def _with_added_mass(self, body: BodyState | None, outputs: dict[str, Message]) -> dict[str, Message]:
        """``outputs`` with this step's added mass when it differs from the one the body holds
        (effect added_mass): the body's, scaled by how far it is a submerged one."""
        if not self.added_mass_on or body is None:
            return outputs
        held = self._added_book.added  # published before, held by the body since
        added = self._carried_water(body)
        self._added_book.hold(body, added)
        if added is not held and added.values() != held.values():
            outputs["added_mass"] = added
        return outputs

    def _carried_water(self, body: BodyState) -> AddedMass:
        """The added mass of ``body`` this step: its full one scaled by how far it is a submerged one
        (none, and nothing worked out, while it is not under water)."""
        share = self._submerged
        if share <= 0.0:
            return ZERO_ADDED_MASS
        return scaled(full_added_mass(body.shape, body.radius, self.params.rho), share)

    def _publishable(self, outputs: dict[str, Message]) -> dict[str, Message]:
        """Idle outputs (zero wrench, empty windows, a dry report) are published once when the body
        moves away from the water and then held by the receivers: a stone in flight costs no column
        work, and its only messages are the requests for the crest where it goes. A request, of
        columns or of the crest alone, is published only when the window the water holds no longer
        covers the body with half its margin."""
        request = outputs.get("request")
        new_request = None
        if request is not None:
            if request is self._held_request:
                del outputs["request"]
            else:
                self._held_request = new_request = request
        if not self._went_idle:
            self.quiet = False
            return outputs
        self._went_idle = False
        if self.quiet:
            # the window still follows the body in flight, so the water is ready when it comes down
            return {} if new_request is None else {"request": new_request}
        self.quiet = True
        return outputs

    def _advance(self, dt: float, n: int, inputs: dict[str, Message | None]) -> dict[str, Message]:
        body = inputs.get("body")
        patch = inputs.get("water")
        if patch is not None and patch.crest >= 0.0:  # else not known (an empty window): the last one holds
            self._crest = float(patch.crest)
        if body is None:
            self.bound = math.inf
            return self._idle(-math.inf)
        pos = body.position
        vel = body.velocity
        omega = body.angular_velocity
        radius = float(body.radius)
        r_bound = _bounding_radius(body)
        if patch is not None and patch.height.size:
            if self.cell == 0.0:  # the water's first patch
                self._check_not_under_the_bed(float(pos[2]) + r_bound, pos, patch)
                # only a body in the water when the run began was there before it; one above it comes
                # in later, and its displacement raises waves, also one that comes in before the water
                # first shows itself (the ricochet's ball, on a water stepping every 14 ticks). Where the
                # body began is known when the run told it (start_inputs); else where it is now
                bottom = self._start_bottom if self._start_bottom is not None else _lowest_of(body)
                self._start_in_water = bottom < float(patch.rest_level)
            else:  # at any level: a beach's bed rises above the rest level
                # its own top, not its bounding sphere's: a disk's is far lower, and the stage monitor,
                # seeing it dry below the level, would first have said it left the pond
                self._check_not_through_the_bed(_top_of(body), pos, patch)
            self.rest_level = float(patch.rest_level)
            self.cell = float(patch.cell)
        elif patch is not None and patch.off_grid and self.cell == 0.0:
            # the water answered that it has no columns where the body is: no still water is assumed
            # there, and the body falls through as off any edge of the water
            self.rest_level, self.cell = float(patch.rest_level), float(patch.cell)
        elif patch is not None and self.cell == 0.0 and patch.cell > 0.0:
            # an empty patch (nothing asked for yet) still says where the water's surface rests: taken
            # as 0 instead, a body let go over a pond resting at 0.5 m was dry to the coupler, asked
            # for no water, and fell through the pond onto its bed
            self.rest_level = float(patch.rest_level)
        booked = self._published if isinstance(self._published, BodyState) else body
        self._account_work(booked.position, booked.angular_velocity, dt, bool(body.attitude_locked))
        self._submerged = 0.0
        if self.added_mass_on:
            # the step that led to the state the body published (held from the answered one before it)
            self.dissipated += self._added_book.settle(booked, dt)
        # fast exit: the bounding sphere's bottom, even after falling for two steps, is above any crest:
        # the allowance, or the crest the water says stands where the body goes when that is higher (a
        # wave another body raised; the body, far, asks for that crest alone: _far_request)
        z_bottom = float(pos[2]) - r_bound
        level = self.rest_level
        # (and over the longer time a slower water takes to answer its first request for columns: a
        # stone on a water stepping every 50 ms fell 13 cm into it before its window came)
        reach = min(0.0, float(vel[2])) * (2.0 * dt + self._water_lag(dt))
        if self.flags == 0 or z_bottom + reach > level + max(self.params.wave_allowance, self._crest):
            self.bound = math.inf
            self._prev = None
            if self.cell != 0.0:
                self._start_in_water = False  # dry with the water known: whatever it displaces later is new
            return self._idle(level - z_bottom, self._far_request(pos, vel, dt, r_bound))
        if n == 1 and patch is not None and patch.height.size != 0 and self._ring_on and not self.params.smoothing:
            outputs = self._ring_advance(body, _fill_body_vector(self._bv, body), patch, dt)  # the usual step
            if outputs is not None:
                return outputs
            n = self._restepped(1)  # the state's own bound is shorter than the step: in substeps
        bv = self._body_vector(body)
        vx, vy = float(vel[0]), float(vel[1])
        assumed = False
        axes = np.empty((3, 3))
        x_low, y_low, z_low, half_x, half_y = step_kernel.body_pose(int(body.shape), bv, axes)
        low = (x_low, y_low, z_low)
        half = (half_x, half_y)
        request = self._request((float(pos[0]) + vx * dt, float(pos[1]) + vy * dt), half, (vx, vy), dt,
                                float(body.radius), self._depth_spread(2.0 * float(pos[2]) - z_low, radius) > 0.0)
        if (patch is None or patch.height.size == 0) and self.cell == 0.0 and low[2] < level:
            # in the water before the water has sent anything: it is still, at the rest level,
            # until its first patch says otherwise (a large step or a slow water would let the
            # stone fall through unopposed); the forces only, nothing displaced into a grid not
            # yet known
            patch, assumed = self._assumed_still_water(pos, half, level), True
        if patch is None or patch.height.size == 0:
            # off the water's grid (the water said so) no water can meet the body: its request reaches
            # ahead of it, so columns come before it could meet any (see _dry_bound)
            off = patch is not None and patch.off_grid
            self.bound = math.inf if off else min(self._motion_bound(body), self._approach_bound(body))
            self._prev = {"force": [0.0, 0.0, 0.0], "torque": [0.0, 0.0, 0.0], "position": pos.tolist(),
                          "omega": omega.tolist()}
            return {"wrench": self._zero_wrench, "occupied": self._empty_occupied, "request": request,
                    "contact": self._dry_contact(level - low[2])}
        elements = self._elements_for(body)
        x0 = patch.origin_x + patch.i0 * patch.cell
        y0 = patch.origin_y + patch.j0 * patch.cell
        height = np.ascontiguousarray(patch.height, dtype=np.float64)
        wvel = np.ascontiguousarray(patch.velocity, dtype=np.float64)
        bottom = np.ascontiguousarray(patch.bottom, dtype=np.float64)
        if self._b_geo.shape != height.shape:
            self._b_geo = np.zeros(height.shape)
        nsub = self._subsamples(body, float(patch.cell))
        held = np.ascontiguousarray(patch.occupied, dtype=np.float64)
        already = self._already_displaced(held)
        water = (x0, y0, float(patch.cell), height, wvel, bottom,
                 held if self._mound_raised(held, height, assumed, already) else None)
        met = water
        self._planing_share = planing_share(body, self.params.g)
        if self._ring_on and not assumed:
            met_height, met_velocity = self.met.read(int(patch.i0), int(patch.j0), height, wvel,
                                                     self._planing_share)
            met = (x0, y0, float(patch.cell), met_height, met_velocity, bottom, water[6])
        planing, wave_depth = self._immersion(pos, low, met)
        stats = self._evaluate(body, pos, vel, omega, axes, half, low, met, elements, nsub,
                               self._b_geo, self._stats, self._local, planing, wave_depth)
        if self.added_mass_on:
            self._submerged = 1.0 - planing
        ring = self._ring(body, pos, axes, half, low, water, elements, nsub) if self._ring_on else None
        if assumed and ring is not None:
            ring = ring._replace(window=None)  # the buoyancy, but no displacement into a grid not yet known
        if ring is not None:
            self._add_hydrostatics(stats, ring, int(body.shape) == kernel.SHAPE_SPHERE)
        self.bound = self._stability_bound(body, stats)
        if stats[kernel.S_VOLUME] == 0.0 and stats[kernel.S_AREA] == 0.0:  # dry, as in _ring_advance
            self.bound = self._dry_bound(body, patch, dt)
        self.work = {"columns": int(stats[kernel.S_COLUMNS]), "elements": int(stats[kernel.S_ELEMENTS])}
        mean = stats[:kernel.S_TOTAL + 6]
        n = self._restepped(n)
        wet_within = (0.0, 0.0)  # the most volume and wetted area a substep after the first met
        if n > 1:
            mean, wet_within = self._predict(body, n, dt, stats, water, met, elements, nsub)
        force = mean[kernel.S_TOTAL:kernel.S_TOTAL + 3].copy()
        torque = mean[kernel.S_TOTAL + 3:kernel.S_TOTAL + 6].copy()
        self._prev = {"force": force.tolist(), "torque": torque.tolist(), "position": pos.tolist(),
                      "omega": omega.tolist()}
        h_low = stats[kernel.S_SURFACE_LOW]
        depth = (level if math.isnan(h_low) else float(h_low)) - low[2]
        volume = float(stats[kernel.S_VOLUME])
        area = float(stats[kernel.S_AREA])
        displaced = 0.0 if ring is None else float(ring.rest[kernel.S_VOLUME])
        # a contact met only within the step's substeps (the body dry as it began and as it ends) is a
        # contact of this step: its forces are in the mean, and the report says it wetted
        quiet = self._quiet_when_clear(max(volume, wet_within[0]), max(area, wet_within[1]), displaced, depth,
                                       request)
        if quiet is not None:
            return quiet
        under = self._top_under(pos, low, water) if volume > 0.0 else None
        fraction = self._submerged_fraction(body, volume, math.nan if under is None else under)
        contact = self._contact(volume, area, fraction, mean[:kernel.S_TOTAL + 6].copy(), float(depth),
                                float(body.radius), wet_within)
        if ring is not None:
            occupied = self._empty_occupied if ring.window is None else OccupiedHeight(
                int(patch.i0) + ring.window[0], int(patch.j0) + ring.window[1], ring.window[2],
                already_displaced=already)
        else:
            occupied = self._occupied(patch, volume)
            if occupied.b.size and already:
                occupied = OccupiedHeight(occupied.i0, occupied.j0, occupied.b, already_displaced=True)
        if self._start_in_water and not assumed and (occupied.b.size == 0 or held.any()):
            self._start_in_water = False  # dry at the water's first patch, or the water holds it now
        return {"wrench": Wrench(force, torque), "occupied": occupied, "request": request,
                "contact": contact}

    # --- pieces -----------------------------------------------------------------------------------

    def _quiet_when_clear(self, volume: float, area: float, displaced: float, depth: float,
                          request: PatchRequest) -> dict[str, Message] | None:
        """Whether the body is still in contact with the surface it met, from this step's submerged
        ``volume`` [m^3], wetted ``area`` [m^2], volume ``displaced`` under the rest level [m^3] and
        the ``depth`` [m] of its lowest point; when it is dry and clear of the surface, the outputs
        of a body far away (published once, then held) with ``request`` still asked for, since the
        body is near the water; else None."""
        # the surface the body met holds until it is well clear of it (quiet_above), so that its
        # take-off is judged against the water it planed on, not against the waves it left
        self.met.in_contact = volume > 0.0 or area > 0.0 or displaced > 0.0 or (
            self.met.in_contact and depth > -self.params.quiet_above)
        if volume == 0.0 and area == 0.0 and displaced == 0.0 and depth < -self.params.quiet_above:
            self._prev = None
            quiet = self._idle(depth)
            quiet["request"] = request
            return quiet
        return None

    def _contact(self, volume: float, area: float, fraction: float, forces: np.ndarray,
                 depth: float, radius: float, wet_within: tuple[float, float] = (0.0, 0.0)) -> WaterContact:
        """The contact report from this step's submerged ``volume`` [m^3], wetted ``area`` [m^2],
        submerged ``fraction`` [-], the effects' forces in ``forces`` (kernel.S_* layout, an array
        the report keeps: its force arrays are views of it), the ``depth`` [m] of the body's lowest
        point and the body's ``radius`` [m]. Wetted means more than round-off: a body lying on dry
        land, its lowest point on the bed where the surface is the bed itself, met a film of no
        water and was wetted over 1e-20 m^2 now and then, every force zero (a stone sliding up a dry
        beach was said to slide in the water a dozen times). ``wet_within``: the most volume [m^3] and
        wetted area [m^2] a substep after the first met (:meth:`_predict`): the body wetted in the step
        when it did, though it began dry (a 5 mm stone on 46 substeps bounced within one step, and the
        stage monitor, told it was dry, counted no contact)."""
        b, p, f, w = kernel.S_BUOYANCY, kernel.S_PRESSURE, kernel.S_FRICTION, kernel.S_WAVE
        floor = WET_FLOOR * radius * radius
        wetted = max(volume, wet_within[0]) > floor * radius or max(area, wet_within[1]) > floor
        return WaterContact(
            wetted=bool(wetted), submerged_fraction=fraction, wetted_area=area,
            buoyancy=forces[b:b + 3], pressure=forces[p:p + 3], friction=forces[f:f + 3],
            wave_drag=forces[w:w + 3], depth=depth, dissipated_energy=self.dissipated)

    @staticmethod
    def _submerged_fraction(body: BodyState, volume: float, top_under: float) -> float:
        """The share of the body's volume under water [-] from its submerged ``volume`` [m^3] and
        how far its top is under the surface, ``top_under`` [m] (NaN off the patch).

        The column sum samples the body, so a body wholly under water sums to about its volume, not
        exactly (0.987-1.013 of it for a level 5 cm disk on 1 cm cells, with where it lies on the
        grid): a body whose top (the point opposite its lowest one) is under the surface there is
        wholly submerged."""
        radius = float(body.radius)
        body_volume = (math.pi * radius * radius * float(body.thickness) if body.shape == Shape.DISK
                       else 4.0 / 3.0 * math.pi * radius**3)
        fraction = min(1.0, volume / body_volume) if body_volume > 0 else 0.0
        if volume > 0.0 and top_under > 0.0:
            fraction = 1.0
        return fraction

    def _already_displaced(self, held: np.ndarray) -> bool:
        """Whether this step's displacement was there before the run began: the body has been in
        the water since its start and the water holds nothing of it yet (``held``: the occupied
        height the patch echoes)."""
        return self._start_in_water and not held.any()

    def _mound_raised(self, held: np.ndarray, height: np.ndarray, assumed: bool, already: bool) -> bool:
        """Whether the window published this step raises the water's level by itself, so that the
        ring's lift reads the level minus the occupied height ``held`` [m] plus that window
        (:meth:`_ring_field`): the patch says what it holds (``held`` over the ``height`` [m] columns),
        and the window is not one that never reaches the water as a mound, of a body that began in
        the water: published over the ``assumed`` still water (before the water's first patch: no
        window is sent), or ``already`` displaced (the water takes it as there at rest, its surface
        flat). Counting that mound lifted a pine disk let go at its equilibrium draft with 2.1, then
        1.47 times its weight on its first steps: it jumped 1.15 mm (its draft is 12 mm) at 3 cm/s.
        A body that came down from above into the water, even before the water's first patch (the
        ricochet's ball, on a water stepping every 14 ticks), is not already displaced: its window
        raises the water, and its mound is counted."""
        if held.shape != height.shape:
            return False
        began_in_water = self._start_bottom is not None and self._start_bottom < self.rest_level
        return not ((assumed or already) and began_in_water)

    def _body_vector(self, body: BodyState) -> np.ndarray:
        """The body's pose, motion and mass as :mod:`step_kernel`'s body vector (B_* layout): a new
        array (the usual step fills the one it keeps, :attr:`_bv`, with the same values)."""
        return _fill_body_vector(np.empty(step_kernel.N_BODY), body)

    def _ring_advance(self, body: BodyState, bv: np.ndarray, patch: HeightPatch, dt: float
                      ) -> dict[str, Message] | None:
        """The usual step of :meth:`_advance` (the ring displacement, one step at a time, a patch in
        hand, no smoothing): the met surface (:meth:`MetSurface.plan`), the body's pose,
        :meth:`_evaluate`, :meth:`_ring`, :meth:`_add_hydrostatics` and :meth:`_stability_bound` in
        one call of :func:`step_kernel.met_ring_step`, whose numbers are read back once as Python
        floats to steer, and whose stats are copied once for the messages' arrays; the same outputs
        as the general path, bit for bit. None, with nothing published, when the bound of the body's
        state is shorter than the step (:meth:`_restepped`): the general path then takes it in
        substeps."""
        pos, vel = body.position, body.velocity
        level = self.rest_level
        cell = float(patch.cell)
        i0, j0 = int(patch.i0), int(patch.j0)
        height = np.ascontiguousarray(patch.height, dtype=np.float64)
        wvel = np.ascontiguousarray(patch.velocity, dtype=np.float64)
        held = np.ascontiguousarray(patch.occupied, dtype=np.float64)
        already = self._already_displaced(held)
        has_held = self._mound_raised(held, height, False, already)  # else the lift reads the patch alone
        elements = self._elements_for(body)
        share = self._planing_share = planing_share(body, self.params.g)
        freeze, mi0, mj0, m_h, m_v, fr_h, fr_v, met_h, met_v = self.met.plan(i0, j0, height, wvel, share)
        scratch = self._scratch
        if scratch is None or scratch.shape != height.shape or scratch.rest_level != level:
            scratch = self._scratch = step_kernel.RingScratch(height.shape, level)
        shape = int(body.shape)
        numbers = scratch.numbers
        step_kernel.met_ring_step(
            freeze, i0, j0, mi0, mj0, m_h, m_v, fr_h, fr_v,
            shape, bv, self._parameters_of(shape), self.flags, self._local,
            self._subsamples(body, cell), level, share,
            float(patch.origin_x + patch.i0 * patch.cell), float(patch.origin_y + patch.j0 * patch.cell), cell,
            met_h, met_v, height, wvel, np.ascontiguousarray(patch.bottom, dtype=np.float64),
            held if has_held else height, has_held,
            elements.pos, elements.nrm, elements.area, elements.t1, elements.t2, elements.sub, elements.whole,
            elements.world_fixed,
            scratch.planes, numbers, scratch.work_for(elements.area.shape[0]))
        steer = numbers[kernel.S_VOLUME:kernel.S_SURFACE_LOW + 1].tolist()
        volume, area, h_low = steer[0], steer[kernel.S_AREA - kernel.S_VOLUME], steer[-1]
        (planing, top_under, self.bound, i_lo, i_hi, j_lo, j_hi, displaced,
         _) = numbers[step_kernel.NUM_RESULTS:step_kernel.NUM_RESULTS + step_kernel.N_RESULTS].tolist()
        z_low, half_x, half_y = numbers[step_kernel.NUM_POSE + 2:step_kernel.NUM_POSE + step_kernel.N_POSE].tolist()
        self._submerged = 1.0 - planing
        if volume == 0.0 and area == 0.0:  # dry: the step that wets it must be stable already
            self.bound = self._dry_bound(body, patch, dt)
        if self._restepped(1) > 1:
            # the general path takes the step in substeps from here (the met surface it plans again is
            # this one: the freeze just done is the window it holds, and freezing it again copies it)
            return None
        px, py = pos[:2].tolist()
        vx, vy = vel[:2].tolist()
        request = self._request((px + vx * dt, py + vy * dt), (half_x, half_y), (vx, vy), dt, float(body.radius),
                                self._depth_spread(2.0 * float(pos[2]) - z_low, float(body.radius)) > 0.0)
        self.work = {"columns": int(steer[kernel.S_COLUMNS - kernel.S_VOLUME]),
                     "elements": int(steer[kernel.S_ELEMENTS - kernel.S_VOLUME])}
        wrench = numbers[kernel.S_TOTAL:kernel.S_TOTAL + 6].tolist()
        self._prev = {"force": wrench[:3], "torque": wrench[3:], "position": pos.tolist(),
                      "omega": body.angular_velocity.tolist()}
        depth = (level if math.isnan(h_low) else h_low) - z_low
        quiet = self._quiet_when_clear(volume, area, displaced, depth, request)
        if quiet is not None:
            return quiet
        forces = numbers[:kernel.S_TOTAL + 6].copy()  # the messages' arrays are views of one copy
        contact = self._contact(volume, area, self._submerged_fraction(body, volume, top_under), forces, depth,
                                float(body.radius))
        occupied = self._empty_occupied
        if i_lo <= i_hi:
            i_lo, i_hi, j_lo, j_hi = int(i_lo), int(i_hi), int(j_lo), int(j_hi)
            occupied = OccupiedHeight(i0 + i_lo, j0 + j_lo, scratch.b_out[j_lo:j_hi + 1, i_lo:i_hi + 1].copy(),
                                      already_displaced=already)
        if self._start_in_water and (occupied.b.size == 0 or held.any()):
            self._start_in_water = False  # dry at the water's first patch, or the water holds it now
        return {"wrench": Wrench(forces[kernel.S_TOTAL:kernel.S_TOTAL + 3], forces[kernel.S_TOTAL + 3:]),
                "occupied": occupied, "request": request, "contact": contact}

    def _evaluate(self, body, pos, vel, omega, axes, half, low, water, elements, nsub, b_geo, stats, flags,
                  planing, wave_depth):
        """The named effects' forces on ``body`` over ``water`` into ``stats``, the pressure following
        the planing law in the share ``planing``, the wave drag faded with the top's depth
        ``wave_depth`` [m] (:meth:`_immersion` of the same pose and water)."""
        p = self.params
        x0, y0, cell, height, wvel, bottom, _ = water
        c_d = p.c_d_disk if body.shape == Shape.DISK else p.c_d_sphere
        kernel.evaluate(
            int(body.shape), float(body.radius), float(body.thickness),
            pos, axes, vel, omega, float(half[0]), float(half[1]), low[0], low[1], low[2],
            float(x0), float(y0), cell, height, wvel, bottom,
            elements.pos, elements.nrm, elements.area, elements.t1, elements.t2, elements.sub, elements.whole,
            elements.world_fixed,
            p.rho, p.g, p.c_l, p.c_n, p.c_b, p.c_f, p.c_w, p.c_min, p.wet_ramp, flags, nsub,
            b_geo, _NO_WATERLINE, stats, planing, c_d, wave_depth)
        return stats

    def _immersion(self, pos: np.ndarray, low: tuple[float, float, float], water) -> tuple[float, float]:
        """(the share [-] of the pressure that follows the planing law, the depth [m] of the body's
        top under the surface): the share is 1 while the body's highest point is above the surface,
        falling to 0 as it goes ``closure_depth`` under; the depth is 0 while the body pierces the
        surface or is off the water (the wave drag's depth, :func:`forces.wave_drag_magnitude`).

        The planing law holds for a face meeting the flow at the free surface, with the splash
        sheet ahead and an air cavity behind the body. Once the water closes over the body's top,
        the cavity is gone and the body is a submerged one: buoyancy, pressure drag along its
        motion and no planing lift, so a stone that goes wholly under does not come back out as if
        it were skimming."""
        under = self._top_under(pos, low, water)
        if under is None:
            return 1.0, 0.0
        return min(1.0, max(0.0, 1.0 - under / self.params.closure_depth)), max(0.0, under)

    @staticmethod
    def _top_under(pos: np.ndarray, low: tuple[float, float, float], water) -> float | None:
        """How far [m] the body's highest point (its lowest mirrored through the centre, for a disk
        or a sphere) is under the surface of ``water`` (negative: above it); None off the patch or
        over dry land (no water above the bed)."""
        x0, y0, cell, height, wvel, bottom, _ = water
        top = 2.0 * pos - np.asarray(low)
        ok, h_top, _, depth = kernel.sample_water(float(top[0]), float(top[1]), x0, y0, cell, height, wvel, bottom)
        return float(h_top - top[2]) if ok and depth > 0.0 else None

    def _elements_for(self, body: BodyState) -> Elements:
        p = self.params
        key = (body.shape, body.radius, body.thickness)
        if self._elements_key != key or self._elements is None:
            key = (int(body.shape), float(body.radius), float(body.thickness))
            if body.shape == Shape.DISK:
                self._elements = disk_elements(key[1], key[2], p.face_elements, p.rim_elements)
            else:
                self._elements = sphere_elements(key[1], p.sphere_bands)
            self._elements_key = key
        return self._elements

    def _subsamples(self, body: BodyState, cell: float) -> int:
        """Sub-cells per column side: the scene's ``column_subsamples``, else about SUBSAMPLES_PER_RADIUS
        samples per body radius, and at least SAMPLES_ACROSS across the narrowest width of its
        horizontal footprint (at most MAX_AUTO_SUBSAMPLES). A disk standing nearly on edge is as
        narrow as its thickness: a 6 mm disk on 1 cm columns was crossed by one or two lines of
        samples, and its buoyancy read 0.56 to 1.11 of Archimedes' with where it stood on the grid,
        its torque 50 times the true one and of either sign (now within 7%: a line of samples more
        or less across a slab a few millimetres wide)."""
        if self.params.column_subsamples > 0:
            return self.params.column_subsamples
        radius = float(body.radius)
        wanted = SUBSAMPLES_PER_RADIUS * cell / radius
        if body.shape == Shape.DISK:
            ax, ay, az = quat.body_axis(body.orientation.tolist())
            # its footprint is 2 (R |a_z| + e/2 sqrt(a_x^2 + a_y^2)) wide across, along the axis's
            # horizontal direction: leaning less than SAMPLES_ACROSS / SUBSAMPLES_PER_RADIUS / 2 from
            # upright, the radius's count does (the rest, 2-3 us a step, is paid only by a disk nearly on edge)
            if abs(az) * 2.0 * SUBSAMPLES_PER_RADIUS < SAMPLES_ACROSS:
                narrowest = radius * abs(az) + 0.5 * float(body.thickness) * math.hypot(ax, ay)
                if narrowest > 0.0:
                    wanted = max(wanted, SAMPLES_ACROSS * cell / (2.0 * narrowest))
        return max(1, min(MAX_AUTO_SUBSAMPLES, math.ceil(wanted - 1e-9)))

    def _request(self, centre: tuple[float, float], half: tuple[float, float], vel: tuple[float, float],
                 dt: float, radius: float, spreading: bool = False) -> PatchRequest:
        """The window of water needed next step around the body's horizontal ``centre`` [m] then,
        for its horizontal velocity ``vel`` [m/s], its ``radius`` [m] (the displacement's band) and
        whether its displacement is ``spreading`` over its depth (:meth:`_depth_spread`)."""
        p = self.params
        if not self.flags & (COLUMN_MASK | ELEMENT_MASK):
            return self._empty_request
        # the band reaches twice its half-width outside the outline (its floor in columns waits for
        # the first patch to tell the cell size)
        margin = self._margin_cells()
        if self.flags & DISPLACEMENT:
            margin += 2.0 * kernel.band_width(p.ring_cells, p.ring_share, self.cell, radius)
            if spreading:
                # the widest spread's reach, not this step's: the window lags the request by up to a
                # water step, over which a sinking body's spread grows (sigma by 1.47 times the depth
                # it sinks), and its reach is rounded up to a whole column
                margin += kernel.SPREAD_REACH * kernel.SPREAD_CAP * radius + self.cell
        margin += math.hypot(vel[0], vel[1]) * dt  # the window lags one step
        # ahead along the motion, the window reaches as far as the body goes in `lookahead`, so that
        # the surface it meets during a contact was in the window before it touched down (met_surface)
        return self._window(centre, half, vel, margin, p.lookahead if self._ring_on else 0.0, True,
                            self._water_lag(dt))

    def _far_request(self, pos: np.ndarray, vel: np.ndarray, dt: float, r_bound: float) -> PatchRequest:
        """The window whose crest alone (``columns`` False) a body far above the water asks for: its
        bounding circle of radius ``r_bound`` [m] at its next place, with the margin cells and the
        distance one step covers, reaching ahead along its motion as far as it goes in ``lookahead``.
        Without it a body higher than ``wave_allowance`` was far however high the water stood, and
        fell through any higher wave untouched (a stone let go inside a 20 cm crest did for 50 ms)."""
        if not self.flags & (COLUMN_MASK | ELEMENT_MASK):
            return self._empty_request
        vx, vy = float(vel[0]), float(vel[1])
        return self._window((float(pos[0]) + vx * dt, float(pos[1]) + vy * dt), (r_bound, r_bound), (vx, vy),
                            self._margin_cells() + math.hypot(vx, vy) * dt, self.params.lookahead, False,
                            self._water_lag(dt))

    def _water_lag(self, dt: float) -> float:
        """How much longer [s] than this component's step ``dt`` the water may take to answer a
        request: a water stepping every W seconds takes a new request only at its next step's start,
        up to W later, and publishes its window at that step's end, W after that (0 when the water's
        step is not known: a coupler driven by hand)."""
        water_step = self.source_steps.get("water", 0.0)
        return max(0.0, 2.0 * water_step - dt) if water_step > 0.0 else 0.0

    def _margin_cells(self) -> float:
        """The request's margin of ``margin_cells`` columns [m], DEFAULT_MARGIN before the first patch
        tells the cell size."""
        return self.params.margin_cells * self.cell if self.cell > 0 else DEFAULT_MARGIN

    def _window(self, centre: tuple[float, float], half: tuple[float, float], vel: tuple[float, float],
                margin: float, lookahead: float, columns: bool, lag: float) -> PatchRequest:
        """The request of ``columns`` (or of the crest alone) over the body's outline, ``half`` [m]
        either side of ``centre`` [m], widened by ``margin`` [m] and reaching ahead along ``vel``
        [m/s] as far as the body goes in ``lookahead`` [s], or in the water's ``lag`` [s] (its
        answer's delay beyond a step, :meth:`_water_lag`) if longer; the held request of the same kind
        while it still covers the body, its margin less half the margin cells, and ahead of it as far
        as the body goes before the water answers a new one. (Renewed only within half the margin
        cells of its edge, a window on a water stepping every 15 ms ran out 15 ms before its answer
        came: the stone, still 1.5 cm under the surface, was dry to the coupler.)"""
        cx, cy = centre
        held = self._held_request
        if held is not None and held.columns == columns and held.x_min <= held.x_max:
            need = margin - 0.5 * self._margin_cells()
            on_x, on_y = vel[0] * lag, vel[1] * lag
            if (held.x_min <= cx - half[0] - need + min(on_x, 0.0)
                    and cx + half[0] + need + max(on_x, 0.0) <= held.x_max
                    and held.y_min <= cy - half[1] - need + min(on_y, 0.0)
                    and cy + half[1] + need + max(on_y, 0.0) <= held.y_max):
                return held
        lookahead = max(lookahead, lag)
        ahead_x, ahead_y = vel[0] * lookahead, vel[1] * lookahead
        return PatchRequest(cx - half[0] - margin + min(ahead_x, 0.0), cx + half[0] + margin + max(ahead_x, 0.0),
                            cy - half[1] - margin + min(ahead_y, 0.0), cy + half[1] + margin + max(ahead_y, 0.0),
                            columns=columns)

    def _rest_pass(self, body: BodyState, pos, axes, half, low, water, elements, nsub: int,
                   b_rest: np.ndarray, waterline: np.ndarray, stats: np.ndarray) -> np.ndarray:
        """The columns of the body under a flat surface at the rest level: the occupied height b_rest
        [m] and the waterline (3, nj, ni) of each column (area [m^2] and first moments [m^3] of the
        sub-columns the rest level cuts); in ``stats`` the displaced volume V_rest [m^3] and, when the
        buoyancy is on, Archimedes' force rho g V_rest [N] and torque [N m] about the centre of mass."""
        p = self.params
        x0, y0, cell, height, _, bottom, _ = water
        flat, still = self._still_water(height.shape)
        kernel.evaluate(
            int(body.shape), float(body.radius), float(body.thickness),
            pos, axes, _ZERO3, _ZERO3, float(half[0]), float(half[1]),
            low[0], low[1], low[2], float(x0), float(y0), cell, flat, still, bottom,
            elements.pos, elements.nrm, elements.area, elements.t1, elements.t2, elements.sub, elements.whole,
            elements.world_fixed,
            p.rho, p.g, p.c_l, p.c_n, p.c_b, p.c_f, p.c_w, p.c_min, p.wet_ramp,
            DISPLACEMENT | (self.flags & BUOYANCY), nsub, b_rest, waterline, stats, 1.0, 0.0, 0.0)
        return stats

    def _ring(self, body: BodyState, pos, axes, half, low, water, elements, nsub: int,
              scratch: dict[str, np.ndarray] | None = None) -> _Ring:
        """This step's ring displacement and the buoyancy that goes with it.

        The ring carries the volume the body holds below the REST level (its shape under a flat
        surface), not below the local surface. The height field does not see the body, so waves run
        under it; measured against the local surface, every wave crossing the body would change the
        displaced volume, which the ring would re-emit as a new wave: a loop that amplifies (a body
        held still in the water pumps up the waves without bound, a floating disk rocks ever
        harder). Against the rest level, the displacement follows the body's motion only (a source,
        as in thin-ship wave theory): a body held still makes no waves after it is put in, a heaving
        or rocking one radiates. :func:`kernel.ring_deposit` pushes each column's volume out into the
        band next to it, spread further over the body's depth once it is under the rest level
        (:meth:`_depth_spread`), and :func:`kernel.ring_lift` reads back the water's level there,
        through the same spread (see :meth:`_add_hydrostatics`). ``scratch`` holds the arrays of a
        predictor's substeps (else the component's own are used).
        """
        p = self.params
        x0, y0, cell, height, _, _, held = water
        work = self._ring_arrays(height.shape) if scratch is None else scratch
        if low[2] >= self.rest_level:  # nothing of the body below the rest level: no displacement
            work["stats"][:] = 0.0
            return _Ring(work["stats"], np.zeros(3), None)
        rest = self._rest_pass(body, pos, axes, half, low, water, elements, nsub, work["b_rest"],
                               work["waterline"], work["stats"])
        if rest[kernel.S_VOLUME] <= 0.0:
            return _Ring(rest, np.zeros(3), None)
        ring = kernel.ring_map(int(body.shape), float(body.radius), float(body.thickness), pos, axes,
                               float(x0), float(y0), cell, work["b_rest"],
                               kernel.band_width(p.ring_cells, p.ring_share, cell, float(body.radius)))
        i_lo, i_hi, j_lo, j_hi = kernel.ring_deposit(work["b_rest"], *ring, work["b_out"])
        if i_lo > i_hi:
            return _Ring(rest, np.zeros(3), None)
        # (a disk and a sphere are symmetric about their centre: the top is as far above it as the
        # lowest point is below, step_kernel.ring_step's reckoning)
        sigma = self._depth_spread(2.0 * float(pos[2]) - float(low[2]), float(body.radius)) / cell
        i_lo, i_hi, j_lo, j_hi, window, spread = self._smoothed(work["b_out"], i_lo, i_hi, j_lo, j_hi, sigma)
        region = (slice(j_lo, j_hi + 1), slice(i_lo, i_hi + 1))
        field = self._ring_field(height, held, region, window)
        if p.smoothing or spread is not None:
            # the water receives the deposit spread and smoothed, S G b, so the levels are read through
            # the same filters the other way round (each is symmetric: sum eta (S G b) = sum (G S eta) b)
            part = field[region].copy()
            if p.smoothing:
                kernel.smooth_conservative(part, p.smoothing)
            if spread is not None:
                kernel.spread_gaussian(part[spread], sigma)  # in place, through the view
            field[region] = part
        kernel.ring_lift(work["waterline"], field, *ring, work["lifted"])
        return _Ring(rest, work["lifted"].copy(), (i_lo, j_lo, window))

    def _ring_field(self, height: np.ndarray, held: np.ndarray | None, region: tuple[slice, slice],
                    window: np.ndarray) -> np.ndarray:
        """The water above the rest level [m] as this step's displacement will leave it: the patch,
        minus the occupied height it already holds (``held``), plus the one published now (``window``
        over ``region``); the patch alone when ``held`` is None: the patch does not say what it holds,
        or the window raises no mound (:meth:`_mound_raised`: the water is assumed, or takes the
        window as already at rest).

        The water applies a displacement only at its next step, and a slower water component
        (``every`` > 1) holds one patch over several of ours. Read straight from the patch, the
        level would miss the body's own latest displacement, the mound it has just raised: the body
        would push the water up without paying for it (a cork disk heaving with only displacement
        and buoyancy on a 2 ms water step: its coupled energy quadrupled in 2 s).
        """
        field = height - self.rest_level
        if held is not None:
            field -= held
            field[region] += window
        return field

    def _ring_arrays(self, shape: tuple[int, int]) -> dict[str, np.ndarray]:
        """Work arrays of :meth:`_ring` for a patch of ``shape`` (reused while the shape holds)."""
        work = self._ring_work
        if work is None or work["b_rest"].shape != shape:
            work = self._ring_work = _ring_scratch(shape)
        return work

    def _add_hydrostatics(self, stats: np.ndarray, ring: _Ring, sphere: bool) -> None:
        """Put the buoyancy that goes with the ring displacement into ``stats`` (its force, torque
        and the total).

        The water receives column k's displaced volume where the ring puts it, at a mean height
        level_k above the rest level (the shares' mean of the water there, :func:`kernel.ring_lift`).
        Moving the body by dq therefore changes the water's potential energy by
        rho g s^2 sum_k level_k db_k (b_k: the column's occupied height under the rest level). The
        buoyancy that does the opposite work on the body, so that what the water gains the body
        loses, is Archimedes' force against the rest level (its potential the body's) plus
        rho g level_k on every waterline sub-column of column k, at the sub-column (-db_k/dz is its
        waterline area, -db_k/dtheta that area's lever arm)::

            F = rho g V_rest(q) + rho g sum_k level_k A_k(q)         (up; A_k: waterline area)

        It is the buoyancy under the rest level raised, column by column, to where the body's water
        went, to first order in that rise; in still water it is Archimedes' force. The heave and
        the rocking then radiate: the level of the mound a body raises pushes it back, and the
        mound's waves carry the energy away. (The deposit also moves with the body across the
        water; that part of the exchange, Froude-Krylov's force of the water's slope on the
        displaced volume, is left out: a body crossing the water still raises its wake for free.)

        Measured against the surface right under the body instead, the buoyancy lagged the waves
        its heave radiates: a floating cork disk took energy from them and gave it back through the
        ring, so it heaved for ever and the water's energy grew without bound (the coupled energy
        fivefold in 3 s; tests/stability/test_floating_energy.py).
        """
        # planing, the mound is the pile-up ahead of the face, whose push is inside C_L (see
        # met_surface): its level lifts a floating body only (by 1 - the planing share); a sphere's
        # pressure acts through its centre: the mound lifts it, turns it not. The compiled step's own
        # arithmetic, so that both paths give the same forces bit for bit
        step_kernel.add_hydrostatics(stats, ring.rest, ring.lifted, self.flags, self.params.rho * self.params.g,
                                     self._planing_share, sphere)

    def _smoothed(self, b_out: np.ndarray, i_lo: int, i_hi: int, j_lo: int, j_hi: int, sigma: float = 0.0):
        """The nonzero window of b_out, spread over a submerged body's depth (a Gaussian of ``sigma``
        [columns], :meth:`_depth_spread`) and then through the conservative smoothing passes if any,
        the window widened so each has room (with no flux through the patch's edges); and where in
        that window the spread acted (a pair of slices), None when it did not."""
        nj, ni = b_out.shape
        window = None
        spread = None
        reach = kernel.spread_reach(sigma)
        if reach:
            i_lo, i_hi = max(0, i_lo - reach), min(ni - 1, i_hi + reach)
            j_lo, j_hi = max(0, j_lo - reach), min(nj - 1, j_hi + reach)
            window = b_out[j_lo:j_hi + 1, i_lo:i_hi + 1].copy()
            kernel.spread_gaussian(window, sigma)
        passes = self.params.smoothing
        if not passes:
            if window is not None:
                spread = (slice(0, window.shape[0]), slice(0, window.shape[1]))
                return i_lo, i_hi, j_lo, j_hi, window, spread
            return i_lo, i_hi, j_lo, j_hi, b_out[j_lo:j_hi + 1, i_lo:i_hi + 1].copy(), None
        inner = (i_lo, i_hi, j_lo, j_hi)
        i_lo, i_hi = max(0, i_lo - passes), min(ni - 1, i_hi + passes)
        j_lo, j_hi = max(0, j_lo - passes), min(nj - 1, j_hi + passes)
        if window is None:
            window = b_out[j_lo:j_hi + 1, i_lo:i_hi + 1].copy()
        else:
            spread = (slice(inner[2] - j_lo, inner[3] - j_lo + 1), slice(inner[0] - i_lo, inner[1] - i_lo + 1))
            wider = np.zeros((j_hi - j_lo + 1, i_hi - i_lo + 1))
            wider[spread] = window
            window = wider
        kernel.smooth_conservative(window, passes)
        return i_lo, i_hi, j_lo, j_hi, window, spread

    def _depth_spread(self, top: float, radius: float) -> float:
        """The width sigma [m] over which the water displaced by a body of ``radius`` [m] whose top is
        at height ``top`` [m] rises beyond its band (:func:`kernel.depth_spread`; 0 without the ring).

        A body under the surface pushes the water it displaces up through the water above it: seen
        from the surface it is a source at its depth, whose flux rises over a width that grows with
        the depth. Put into the band next to its outline, as for a body that pierces the surface, a
        sunk stone's displaced water stood as a mound and a trough over it however deep it was: run
        on past the reference skip's end, the stone 17 cm down, the surface within 15 cm of it
        reached 35 mm under its level, and the water's lattice energy went from 0.8 J as the stone
        went under to 2.0 J (with the deposit spread, 0.83 J: what the glide left before)."""
        if not self._ring_on:
            return 0.0
        return kernel.depth_spread(self.rest_level - top, radius)

    def _occupied(self, patch: HeightPatch, volume: float) -> OccupiedHeight:
        """Mueller's column displacement: the occupied height b under the body (this step's columns
        against the local surface)."""
        if not self.flags & DISPLACEMENT or volume <= 0.0:
            return self._empty_occupied
        b_out = self._b_geo
        nz_j, nz_i = np.nonzero(b_out)
        if nz_i.size == 0:
            return self._empty_occupied
        i_lo, i_hi, j_lo, j_hi = int(nz_i.min()), int(nz_i.max()), int(nz_j.min()), int(nz_j.max())
        i_lo, i_hi, j_lo, j_hi, window, _ = self._smoothed(b_out, i_lo, i_hi, j_lo, j_hi)
        return OccupiedHeight(int(patch.i0) + i_lo, int(patch.j0) + j_lo, window)

    def _still_water(self, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
        """A flat surface at the rest level and zero surface velocity over a patch of ``shape``."""
        cached = self._still
        if cached is None or cached[0].shape != shape or cached[0][0, 0] != self.rest_level:
            cached = (np.full(shape, self.rest_level), np.zeros(shape))
            self._still = cached
        return cached

    def _account_work(self, pos: np.ndarray, omega: np.ndarray, dt: float, attitude_locked: bool) -> None:
        """Add minus the work of the wrench published last step, held over the body's step that just
        ended: F.(x - x_prev) exactly for a held force, torque . (omega_prev + omega)/2 dt. A body whose
        attitude is held takes no torque: the torque does no work on it, however it spins (the held
        skip spun at 20 rev/s was booked 1.1 J its kinetic energy never lost)."""
        prev = self._prev
        if prev is None:
            return
        f, x0, tq, w0 = prev["force"], prev["position"], prev["torque"], prev["omega"]
        pos, omega = pos.tolist(), omega.tolist()
        work = f[0] * (pos[0] - x0[0]) + f[1] * (pos[1] - x0[1]) + f[2] * (pos[2] - x0[2])
        if not attitude_locked:
            work += 0.5 * dt * (tq[0] * (w0[0] + omega[0]) + tq[1] * (w0[1] + omega[1]) + tq[2] * (w0[2] + omega[2]))
        self.dissipated -= float(work)

    def _stability_bound(self, body: BodyState, stats: np.ndarray) -> float:
        """The step bound of :meth:`max_stable_step` [s] from this step's stats: the compiled step's
        own rule (motion, damping and spring bounds), for the steps taken outside it."""
        return float(step_kernel.stability_bound(self._body_vector(body), stats, self._parameters_of(body.shape)))

    def _parameters_of(self, shape: int) -> np.ndarray:
        """The parameter vector (P_* layout) of a body of ``shape``."""
        return self._prm_disk if shape == Shape.DISK else self._prm_sphere

    def start_stable_step(self, inputs: dict[str, Message | None]) -> float:
        """The bound of the body's first steps near or in the water, from its state at the start:
        :meth:`_motion_bound` and :meth:`_approach_bound`, as the run applies them (a wetted body's
        own forces' bound holds the motion's too), so that a body far too light for the scene's step,
        or too fast for it, is refused when the scene loads, not at its first contact; and for a
        body whose lowest point starts under the coupler's water level, also the most its buoyancy
        can do (:meth:`_buoyant_bound`), so that one far too light for the step is refused as it
        loads (one of 1e-300 kg/m^3 failed at its first step with a math domain error, its speed
        overflowed)."""
        body = inputs.get("body")
        if not isinstance(body, BodyState):
            return math.inf
        water = inputs.get("water")
        # the water's own rest level where its first answer gives it (the empty patch before any request)
        known = isinstance(water, HeightPatch) and water.cell > 0.0
        level = float(water.rest_level) if known else self._assumed_level()
        # near the water a step may carry the body only so far (the motion bound), as the step before
        # the water's first patch bounds it: without it here a run the load check passed failed at its
        # first step (the reference skip at dt = 1 ms: 0.85 ms, the stone 9 cm up). In the water too:
        # the bound of its forces holds it. Only the buoyant bound was taken for a body whose bounding
        # sphere dipped under the level, though the body itself did not: a 20 degree disk 10.5 mm above
        # the water, its sphere 4.7 mm under it, thrown at 40 m/s, passed at 7.98 ms against 0.15 ms
        bound = self._motion_bound(body)
        if self.flags & (PRESSURE | FRICTION):
            bound = min(bound, self._approach_bound(body))
        if self.flags & BUOYANCY and _lowest_of(body) < level:
            bound = min(bound, self._buoyant_bound(body))
        return bound

    def _buoyant_bound(self, body: BodyState) -> float:
        """The step [s] in which the water's buoyancy, wholly under, carries a body from rest
        MOTION_FRACTION of its radius: sqrt(2 MOTION_FRACTION R / a), a = rho g V / M (a floating
        pine ball's 39 ms; the bound of its own forces, once it steps, is the one the run applies)."""
        p = self.params
        lift = p.rho * abs(p.g) * shape_volume(Shape(body.shape), float(body.radius), float(body.thickness))
        mass = float(body.mass)
        if not lift > 0.0 or not mass > 0.0:
            return math.inf
        acceleration = lift / mass
        if not math.isfinite(acceleration):
            return 0.0
        return math.sqrt(2.0 * MOTION_FRACTION * float(body.radius) / acceleration)

    def _assumed_level(self) -> float:
        """The rest level [m] taken until the water's first patch gives its own: ``water_level``, or 0."""
        return 0.0 if self.params.water_level is None else float(self.params.water_level)

    def _dry_bound(self, body: BodyState, patch: HeightPatch, dt: float) -> float:
        """The step bound [s] of a dry body over the columns of ``patch``: the bound of this step's
        forces (:attr:`bound`) and :meth:`_approach_bound`, or none for a body beside the water, wholly
        below every bed of the patch even after rising for two steps ``dt``: no water can meet it. A
        body that left the pond over its edge falls on there (under the water's columns the bed's
        check ends the run first); bounded as one near the water, a pine ball that drifted off an open
        edge failed its run at 12 m/s, 8 m below the water, its step exceeding the stable one."""
        top = float(body.position[2]) + _bounding_radius(body) + max(0.0, float(body.velocity[2])) * 2.0 * dt
        if patch.bottom.size and top < float(patch.bottom.min()):
            return math.inf
        return min(self.bound, self._approach_bound(body))

    def _approach_bound(self, body: BodyState) -> float:
        """A bound [s] of :meth:`max_stable_step` for a dry body near the water: APPROACH_SAFETY over
        the damping rate its whole face (a disk's face, a sphere's cross-section) would have meeting
        the water at its speed. The usual bound comes from the step's own forces, so it reaches the
        scheduler only after the step that wets the body; a body far lighter than the water it meets
        (a slate 1 um thin: 21 mg against a face that stops 0.3 kg of water) took that first step
        whole and was thrown out of the water faster than it came (41 km/s from 11 m/s). A first wet
        step wets a sliver of the face, not the whole of it, so the bound is APPROACH_SAFETY times the
        whole face's: it takes hold only where the sliver itself would be far from stable, and the
        step's own bound, from its forces, governs the rest of the contact. For every body of the
        scenes here it is many times the base step."""
        key = (body.shape, body.radius, body.mass)
        per_speed = self._approach_rates.get(key)
        if per_speed is None:  # the damping rate per unit speed [1/m]: the body's, worked out once
            p = self.params
            coefficient = 0.0
            if self.flags & PRESSURE:
                coefficient = (max(p.c_l + p.c_n, p.c_d_disk) if body.shape == Shape.DISK
                               else max(p.c_b, p.c_d_sphere))
            if self.flags & FRICTION:
                coefficient += p.c_f
            radius = float(body.radius)
            per_speed = self._approach_rates[key] = p.rho * coefficient * math.pi * radius * radius / float(body.mass)
        rate = per_speed * _surface_speed(body)
        return APPROACH_SAFETY / rate if rate > 0.0 else math.inf

    def _motion_bound(self, body: BodyState) -> float:
        speed = _surface_speed(body)
        if speed <= 0:
            return math.inf
        return MOTION_FRACTION * float(body.radius) / speed

    def _predict(self, body: BodyState, n: int, dt: float, stats0: np.ndarray, water, met, elements,
                 nsub: int) -> tuple[np.ndarray, tuple[float, float]]:
        """Mean of the effects' forces and torques and their sum (S_TOTAL + 6,) over n substeps of a
        private copy of the body moved by them and gravity (semi-implicit Euler), and the most
        submerged volume [m^3] and wetted area [m^2] a substep after the first met. ``met``: the water
        the surface effects are evaluated on (see :mod:`components.coupler.met_surface`), ``water`` the patch itself.

        A substep longer than the stable step of the forces it meets (:meth:`max_stable_step` of the
        private copy there) takes the rest of the step in substeps that short, and the mean is then
        the forces' impulse over the step: the step's substeps were set from the bound the step began
        with, which for a body meeting the water far faster than thrown stones do (hundreds of m/s)
        is its dry approach's, and the water threw such a body out faster than it came (25 km/s from
        2 km/s). More than MAX_PREDICTED_SUBSTEPS in a step: refused in words."""
        h = dt / n
        mass = float(body.mass)
        inertia_body = np.asarray(body.inertia, dtype=float)
        x = np.array(body.position, dtype=float)
        v = np.array(body.velocity, dtype=float)
        w = np.array(body.angular_velocity, dtype=float)
        q = np.array(body.orientation, dtype=float)
        size = kernel.S_TOTAL + 6
        total = np.zeros(size)  # the substeps' forces summed, while they are all h long
        impulse: np.ndarray | None = None  # once refined: each substep's forces times its length
        b_scratch = np.zeros_like(self._b_geo)
        s_scratch = np.zeros(kernel.N_STATS)
        ring_mode = self._ring_on
        ring_scratch = _ring_scratch(b_scratch.shape) if ring_mode else None
        is_disk = body.shape == Shape.DISK
        radius, thick = float(body.radius), float(body.thickness)
        gravity = np.array([0.0, 0.0, -self.params.g])
        flags = self._local
        # the water the body carries along, as the body will take it (AddedMass.carried, with_inertia):
        # split along the axis it has as the step begins, which the body holds over its step, not the
        # private copy's turning one. The body moves by the mean force split there, and a disk carries
        # hundreds of times its mass along its axis: a 54 mg one under water, turned 10 degrees in
        # the step, had a sixth of the normal force its water held back counted across the axis by
        # the copy, not by the body, which left at 36 m/s from 14
        added = self._carried_water(body) if self.added_mass_on else ZERO_ADDED_MASS
        carried = any(added.values())
        moments = np.array(added.with_inertia(inertia_body.tolist())) if carried else inertia_body
        split_axis = quat.body_axis(q.tolist()) if carried else None
        current = stats0[:size].copy()
        bound = self.bound  # the first substep's own: of stats0, the body as it is
        private = self._body_vector(body)  # the private copy's, for the bound of each substep after
        parameters = self._parameters_of(body.shape)
        left, i = n, 0
        wet_volume = wet_area = 0.0
        while left > 0:
            if i > 0:
                axes = quat_to_matrix(q)
                axis = axes[:, 2]
                low = lowest_point(is_disk, x, axis, radius, thick)
                half = disk_half_extents(axis, radius, thick) if is_disk else (radius, radius)
                stats = self._evaluate(body, x, v, w, axes, half, low, met, elements, nsub,
                                       b_scratch, s_scratch, flags, *self._immersion(x, low, met))
                if ring_mode:
                    self._add_hydrostatics(stats, self._ring(body, x, axes, half, low, water, elements,
                                                             nsub, ring_scratch), not is_disk)
                current = stats[:size].copy()
                wet_volume = max(wet_volume, float(stats[kernel.S_VOLUME]))
                wet_area = max(wet_area, float(stats[kernel.S_AREA]))
                private[step_kernel.B_POS:step_kernel.B_POS + 3] = x
                private[step_kernel.B_QUAT:step_kernel.B_QUAT + 4] = q
                private[step_kernel.B_VEL:step_kernel.B_VEL + 3] = v
                private[step_kernel.B_OMEGA:step_kernel.B_OMEGA + 3] = w
                bound = float(step_kernel.stability_bound(private, stats, parameters))
            # too long for the forces met here: the rest of the step in substeps of the bound (a bound of 0
            # or less is the scheduler's to refuse at the next step)
            if 0.0 < bound < h:
                more = math.ceil(h * left / bound)
                if i + more > MAX_PREDICTED_SUBSTEPS:
                    raise ValueError(
                        f"the water's forces on the body need substeps of {bound:.3g} s here, {i + more} in this "
                        f"step of {dt:.3g} s, more than the limit {MAX_PREDICTED_SUBSTEPS} (the body at "
                        f"{float(np.sqrt(v @ v)):.3g} m/s): a smaller dt")
                if impulse is None:
                    impulse = total * h  # the substeps before, each h long
                h, left = h * left / more, more
            if impulse is None:
                total += current
            else:
                impulse += current * h
            force = current[kernel.S_TOTAL:kernel.S_TOTAL + 3]
            torque = current[kernel.S_TOTAL + 3:kernel.S_TOTAL + 6]
            if carried:
                f = added.carried(mass, split_axis, (force + mass * gravity).tolist())
                v = v + np.array(f) / mass * h
            else:
                v = v + (force / mass + gravity) * h
            if not body.attitude_locked:
                axes = quat_to_matrix(q)
                inertia = axes @ np.diag(moments) @ axes.T
                with np.errstate(over="ignore", invalid="ignore"):
                    w = w + np.linalg.solve(inertia, torque - np.cross(w, inertia @ w)) * h
            x = x + v * h
            _check_predicted_motion(v, w, i, i + left, h)
            if not body.attitude_locked:  # a locked body holds its attitude, whatever its (held) spin
                q = _rotate(q, w * h)
            left -= 1
            i += 1
        return (total / n if impulse is None else impulse / dt), (wet_volume, wet_area)

    def _assumed_still_water(self, pos: np.ndarray, half: tuple[float, float], level: float) -> HeightPatch:
        """Still water at the rest ``level`` over the body's footprint (columns of an eighth of its
        smaller half-extent, at most 64 along the larger, the bed far below), standing in for the
        water until its first patch arrives."""
        cell = max(min(half) / 8.0, max(half) / 64.0, 1e-3)  # a rod 1e20 m long: 64 columns, not 1e22
        ni = math.ceil(2.0 * half[0] / cell) + 5
        nj = math.ceil(2.0 * half[1] / cell) + 5
        shape = (nj, ni)
        return HeightPatch(0, 0, cell, float(pos[0]) - 0.5 * (ni - 1) * cell, float(pos[1]) - 0.5 * (nj - 1) * cell,
                           level, np.full(shape, level), np.zeros(shape), np.full(shape, level - 1e3),
                           np.zeros(shape))

    def _check_not_under_the_bed(self, top: float, pos: np.ndarray, patch: HeightPatch) -> None:
        """A body whose highest point (``top`` [m], its bounding sphere's) is below the water's bed
        where it starts is a mistake in the scene (it would fall through the pond unseen): refuse it,
        at the first patch the water sends. Inside a bed that rises above the rest level (dry land)
        it has flown into the land while the coupler idled above the water (a body starting in it
        is refused as the scene loads, :meth:`check_start_sources`): the run ends, saying so."""
        bed = _bed_under(pos, patch)
        if bed is not None and top < bed and bed > float(patch.rest_level):
            if self.stop_reason is None:
                self.request_stop(_in_dry_land(pos, top, bed, float(patch.rest_level), late=True))
            return
        if bed is not None and self._start_top is not None and self._start_top >= bed:
            # it began above the bed and has gone through it before the water's first answer (a body
            # far faster than thrown stones): it ends as any body through the bed does, not as one
            # started under it
            self._check_not_through_the_bed(top, pos, patch)
            return
        problem = None if bed is None else _under_the_bed(float(pos[2]), top, bed)
        if problem is not None:
            raise ValueError(problem)

    def _check_not_through_the_bed(self, top: float, pos: np.ndarray, patch: HeightPatch) -> None:
        """The water's bed is no solid: a body that sinks (or slides up a beach) onto it goes on
        through it, wholly under the bed, out of every water column, its run from then on no
        physics. End the run there, saying where and what lands a body on the bed, rather than let
        it fall on silently (a ground at the bed stops it: scenarios/float_sphere.yaml)."""
        bed = _bed_under(pos, patch)
        if bed is not None and top < bed and self.stop_reason is None:
            if bed > float(patch.rest_level):  # a beach above the water: dry land
                self.request_stop(_in_dry_land(pos, top, bed, float(patch.rest_level), late=False))
                return
            x, y, z = (float(c) for c in pos)
            where = (f"the body went through the water's bed at x = {x:.4g} m, y = {y:.4g} m (its centre at "
                     f"z = {z:.4g} m, wholly under the bed at z = {bed:.4g} m)")
            grounds = self.input_sources.get("ground")
            if grounds:  # (a ground there answers once a step: a body fast enough went through it within one)
                self.request_stop(f"{where}, and through {', '.join(grounds)} there, within one step: the step is "
                                  "too long for the body's speed to land it; use a smaller dt (or every)")
                return
            self.request_stop(f"{where}: the bed is not solid; to land the body on it, add a SolidGround there (as "
                              "scenarios/float_sphere.yaml does)")

    def _idle(self, depth: float, request: PatchRequest | None = None) -> dict[str, Message]:
        self.met.in_contact = False
        self.work = {"columns": 0, "elements": 0}
        self._went_idle = True
        return {"wrench": self._zero_wrench, "occupied": self._empty_occupied,
                "request": self._empty_request if request is None else request, "contact": self._dry_contact(depth)}

    def _dry_contact(self, depth: float) -> WaterContact:
        if not math.isfinite(depth):
            depth = -1.0e9  # no body yet: far above any water (a finite stand-in)
        return WaterContact(False, 0.0, 0.0, _ZERO3, _ZERO3, _ZERO3, _ZERO3, depth, self.dissipated)


def _answered(inputs: dict[str, Message | None]) -> dict[str, Message | None]:
    """``inputs`` with the body as the grounds' impulse (port ``ground``) leaves it at the start of its
    next step, over which the wrench is held: velocity, angular velocity (unless its attitude is held)
    and position corrected as the body will apply them (:func:`apply_impulse`).

    Met with the state before that answer, the water pushed on a body the bed had already turned
    round: a granite ball striking the bed of a 2 cm pond at 20 m/s was bounced at 4.0 m/s (e = 0.2)
    and then pushed up by the 266 N of its entry over the next 2 ms step, leaving at 5.8 m/s and
    climbing 1.7 m, the water's book -2.6 J. Without a ground (or while it does not answer) the
    inputs are as given."""
    impulse, body = inputs.get("ground"), inputs.get("body")
    if not isinstance(impulse, Impulse) or not isinstance(body, BodyState):
        return inputs
    if not (impulse.linear.any() or impulse.angular.any() or impulse.correction.any()):
        return inputs
    state = RigidState(tuple(body.position.tolist()), tuple(body.orientation.tolist()),  # type: ignore[arg-type]
                       tuple(body.velocity.tolist()), tuple(body.angular_velocity.tolist()))  # type: ignore[arg-type]
    after = apply_impulse(float(body.mass), tuple(body.inertia.tolist()), state,  # type: ignore[arg-type]
                          tuple(impulse.linear.tolist()), tuple(impulse.angular.tolist()),  # type: ignore[arg-type]
                          tuple(impulse.correction.tolist()), rotate=not body.attitude_locked)  # type: ignore[arg-type]
    velocity = np.array(after.velocity)
    moved = body.replace(position=np.array(after.position), velocity=velocity,
                         angular_velocity=np.array(after.angular_velocity), speed=float(np.linalg.norm(velocity)))
    return {**inputs, "body": moved}


def _fill_body_vector(bv: np.ndarray, body: BodyState) -> np.ndarray:
    """``bv`` (step_kernel.N_BODY,) filled with ``body``'s pose, motion and mass (B_* layout)."""
    bv[step_kernel.B_POS:step_kernel.B_POS + 3] = body.position
    bv[step_kernel.B_QUAT:step_kernel.B_QUAT + 4] = body.orientation
    bv[step_kernel.B_VEL:step_kernel.B_VEL + 3] = body.velocity
    bv[step_kernel.B_OMEGA:step_kernel.B_OMEGA + 3] = body.angular_velocity
    bv[step_kernel.B_RADIUS] = body.radius
    bv[step_kernel.B_THICKNESS] = body.thickness
    bv[step_kernel.B_MASS] = body.mass
    bv[step_kernel.B_INERTIA_MIN] = min(body.inertia.tolist())
    return bv


def _ring_scratch(shape: tuple[int, int]) -> dict[str, np.ndarray]:
    """Work arrays of WaterCoupler._ring over a patch of ``shape``."""
    return {"b_rest": np.zeros(shape), "waterline": np.zeros((3, *shape)), "b_out": np.zeros(shape),
            "stats": np.zeros(kernel.N_STATS), "lifted": np.zeros(3)}


MAX_PREDICTED_SUBSTEPS = 100_000  # substeps of one coupler step's prediction, refined included


def _check_predicted_motion(v: np.ndarray, w: np.ndarray, i: int, n: int, h: float) -> None:
    """Refuse, in words, a substep prediction whose velocity ``v`` [m/s] or angular velocity ``w``
    [rad/s] has left a float's range (substep ``i`` of ``n``, each ``h`` [s] long): the water's
    forces on the body change it faster than the substeps can follow (a body kilometres across
    dropped deep into the water does)."""
    with np.errstate(over="ignore", invalid="ignore"):
        speed, spin = float(np.sqrt(v @ v)), float(np.sqrt(w @ w))
    if math.isfinite(speed) and math.isfinite(spin):
        return
    raise ValueError(f"the body's motion over this step left a float's range after {i + 1} of {n} substeps "
                     f"of {h:.3g} s (velocity {speed:.3g} m/s, angular velocity {spin:.3g} rad/s): the water's "
                     "forces on it change it faster than the step can follow; a smaller body or a smaller dt")


def _rotate(q: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """Quaternion q (w, x, y, z) turned by the world-frame rotation vector ``rotation`` [rad]."""
    angle = float(np.linalg.norm(rotation))
    if angle < 1e-300:
        return q
    s = math.sin(0.5 * angle) / angle
    dw, dx, dy, dz = math.cos(0.5 * angle), rotation[0] * s, rotation[1] * s, rotation[2] * s
    w, x, y, z = q
    out = np.array([dw * w - dx * x - dy * y - dz * z,
                    dw * x + dx * w + dy * z - dz * y,
                    dw * y - dx * z + dy * w + dz * x,
                    dw * z + dx * y - dy * x + dz * w])
    return out / np.linalg.norm(out)
