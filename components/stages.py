"""The stage monitor: which stage of a throw the stone is in, the skips, and when to stop.

The contract, in full with the reasons, is docs/stages.md (tested in tests/test_stage_contract.py on
the hard throws). Stages (Tsai et al. 2022 names), decided each step from the body state (vertical
velocity ``vz`` [m/s], up positive) and the contact reports:

- approach: airborne at the start, or coming down again (``vz < 0``) after a fly-away; ends at the
  touchdown (the first wetted step);
- hit: in contact and moving down (``vz < 0``);
- slide: in contact and moving up or level (``vz >= 0``);
- fly-away: after a contact, the stone dry, rising and its lowest point clear of the local surface
  by more than ``takeoff_clearance`` [m]: one skip counted; ends when it comes down (approach).
  A contact goes on while the stone is wetted, and while it is dry but within the clearance of the
  surface (a flicker) or not rising (the water fell away under it, as behind a crest: the
  stone never bounced). Brushing the water while still rising after a fly-away is part of that
  flight, not a new contact;
- sink: touching water slower than ``sink_speed`` [m/s] horizontally, at least a hundredth under
  water and too heavy to float (or on water without buoyancy); or wholly under water, not rising and
  pushed up by the water (the vertical force of all its effects) no harder than its weight (a stone
  under water that the pressure still throws back up is in hit or slide, as is one the solid ground
  pushes); final, except that a sunk stone can come to rest on the bottom, and one thrown wholly back
  out of the water, rising clear of it, is in its fly-away;
- float: what sink is for a stone the water can carry (lighter than water: its mass is less than
  ``water_density`` times its volume, and the water's buoyancy acts); final. Until a hundredth of
  the stone is under water the contact goes on as hit or slide;
- rest: on the solid ground, held by its static friction and slower than ``rest_speed`` [m/s] for
  REST_HOLD on end (from the start of that spell; long enough that a ball turning round on a slope
  comes out of it); final;
- ground: on the solid ground and dry, not at rest (sliding, rolling, bouncing on a beach); ends
  in the water (hit, slide), at rest, or in the air (fly-away rising, approach coming down).

A skip is a contact that began moving down into the water and ended in a fly-away: the vertical
speed changed sign and the stone rose clear; its :class:`SkipRecord` is published at the fly-away.
A stone that leaves the water without having moved down in it (one started in the water, rising)
flies away without a skip, and so does one that touched the solid ground in the contact (thrown
back up by the bed of a shallow pond: a bounce off the ground, counted apart).

Leaving the pond is an outcome, not a stage: the coupler exerts nothing where the water's grid has
no columns and then reports the depth of the lowest point below the rest level, so a stone that is
dry while below the water level has nothing under it. After ``outside_after`` of that the monitor
ends the run ("left the pond") instead of letting the stone fall forever.

The monitor publishes a :class:`Stage` only when the stage changes and a :class:`SkipRecord` at each
fly-away, and can end the run a little after the stone sinks, comes to rest or leaves the pond.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from components.messages import BodyState, GroundContact, Shape, SkipRecord, Stage, StageId, WaterContact
from components.rigid.quaternion import body_axis
from components.rigid.shapes import shape_volume
from components.rigid_body import HEADING_SPEED, gravity_mismatch
from cosim.component import Component, Port
from cosim.messages import Message
from cosim.params import param
from cosim.timebase import NS_PER_S, step_decimals

FULLY_SUBMERGED = 0.999  # submerged volume fraction counted as "under water"
BUOYANCY_READABLE = 0.01  # submerged volume fraction from which the buoyancy tells whether a stone floats
REST_HOLD = 0.2  # [s] how long a body stays slow on the ground before it is at rest (final). A body starting
# to roll or slide from standing is slow for its first steps (a ball let go on a 20 deg slope was at rest
# at its first slow step, and the run ended with it moving at 0.73 m/s), and one rolling up a slope
# and back is slow about its turn for 2 rest_speed / a (a = 5/7 g sin slope: 33 ms on a 5 deg slope,
# 65 ms for a ball drifting up a beach; a 20 ms hold declared it at rest there and the run ended as it
# rolled back down). A turn slower than 2 rest_speed / REST_HOLD (0.1 m/s^2: a ball on a slope under
# 0.8 deg) is not told from rest. Its velocity cannot tell it sooner: a lead disk settled on a pond's
# bed circles on its rim at 3 mm/s, its velocity turning round, as a turning ball's does
STAGE_NAMES = {s: s.name.lower().replace("_", "-") for s in StageId}
LEFT_POND = STAGE_NAMES[StageId.LEFT_POND]  # the outcome of a stone that left the water's grid


@dataclass
class SkipTracker:
    """Running figures of the current contact and the skips so far (plain data for checkpoints)."""

    skips: int = 0
    start_x: float = math.nan
    start_y: float = math.nan
    start_heading: float = 0.0  # direction of the throw's horizontal velocity [rad from +x]
    touchdown_y: float = math.nan
    last_touchdown_x: float = math.nan
    last_touchdown_y: float = math.nan
    touchdown_time: float = math.nan
    touchdown_x: float = math.nan
    speed_in: float = math.nan
    in_contact: bool = False
    peak_g: float = 0.0  # the largest vertical water force over the weight in the current contact [g]
    descended: bool = True  # the current contact has moved down into the water (a skip needs it)
    grounded: bool = False  # the current contact has touched the solid ground (then it is no skip)
    ground_bounces: int = 0  # contacts that ended in a fly-away after touching the ground


def _lasted(since: float, now: float, span: float) -> bool:
    """Whether a spell begun at ``since`` has lasted ``span`` [s] at ``now``, with a nanosecond's
    slack: differences of step times in floating point came out a hair under the span, and the run
    stopped a step late for some starts and not others."""
    return now - since >= span - 1e-9


def contact_goes_on(water: WaterContact | None, vz: float, clearance: float) -> bool:
    """Whether a stone that was touching water and is dry this step is still in the same contact:
    it still skims the surface (its lowest point within ``clearance`` of it), or it is not rising
    (vz <= 0 [m/s]), so the surface dropped away from it rather than the stone bouncing off it.
    Not when it is dry with its lowest point below the level: there is no water under it (it went
    over the grid's edge, or onto land; :func:`off_the_water`)."""
    # (a stone clear of the water but not rising, vz = 0, has not flown away: counted, it made a skip
    # with a take-off angle of 0)
    return water is not None and not off_the_water(water) and (water.depth > -clearance or vz <= 0.0)


def off_the_water(water: WaterContact | None) -> bool:
    """A dry stone whose lowest point is below the level [m]: there is no water under it (inside the
    grid such a point would be wetted; off it, or over land, the coupler reports the depth below
    the rest level)."""
    return water is not None and not water.wetted and water.depth > 0.0


def floats(body: BodyState, water: WaterContact, water_density: float = 1000.0) -> bool:
    """Whether the water could carry the stone wholly under: the buoyancy acts (an effect of the
    scene) and the stone is lighter than ``water_density`` [kg/m^3] times its volume. Not from the
    reported buoyancy: that includes the level of the water the body raises around itself, which
    makes a stone plunging in, or started in the water, seem up to twice as buoyant as it is (a disk
    of 1500 kg/m^3 was said to float as it sank to the bed)."""
    return float(water.buoyancy[2]) > 0.0 and lighter_than_water(body, water_density)


def lighter_than_water(body: BodyState, water_density: float = 1000.0) -> bool:
    """Whether the stone weighs less than ``water_density`` [kg/m^3] times its volume."""
    volume = shape_volume(Shape(body.shape), float(body.radius), float(body.thickness))
    return body.mass < water_density * volume


def classify(previous: StageId, body: BodyState, water: WaterContact | None, ground: GroundContact | None,
             sink_speed: float, rest_speed: float, clearance: float = 0.0, gravity: float = 9.81,
             water_density: float = 1000.0, step: float = 0.0) -> StageId:
    """The stage now, from the previous stage and this step's body and contact reports; ``step`` [s]
    the body's step. A body held still by the ground is reported with up to a step of gravity's speed
    (|g| step: the ground's answer reaches it at its next step), so at rest means slower than
    ``rest_speed`` or than that, whichever is more (at 2 ms a ball on the bed of a pond, 12 mm/s a
    step, never came to rest against 10 mm/s)."""
    if previous is StageId.LEFT_POND:  # final: what the stone does beside the pond is no stage of a throw
        return previous
    if (ground is not None and ground.in_contact and not ground.sliding
            and body.speed < max(rest_speed, abs(gravity) * step)):
        # held by static friction: one slow step of a disk starting to slide down a 35 deg ramp was
        # taken for rest, which is final, and ended the run. (Its turning is not asked about: a body
        # the ground holds publishes a step of the water's torque as a turn, 0.86 rad/s for a lead
        # disk lying flat on a pond's bed, which the ground takes back at its next step)
        return StageId.REST
    # sinking is final, but a sunk stone can come to rest on the bottom; rest is final too (a stone
    # settling on the bottom, or on a slope, rocks a little faster than rest_speed now and then: it
    # went from rest to approach some thirty times on a beach, and the run never ended)
    vz = float(body.velocity[2])
    if (previous is StageId.SINK and water is not None and not water.wetted and vz > 0.0
            and water.depth <= -clearance):  # (above the surface: not a sunk stone off the grid's edge)
        # ... except that a stone thrown wholly back out of the water, rising clear of it, has not sunk:
        # a slow stone landing in a shallow pond whose bed throws it back up (said to have sunk as it
        # came in, and the run ended while it flew 4 cm over the water)
        return StageId.FLY_AWAY
    if previous in (StageId.SINK, StageId.FLOAT, StageId.REST):
        return previous
    horizontal = math.hypot(float(body.velocity[0]), float(body.velocity[1]))
    if water is not None and water.wetted:
        if previous is StageId.FLY_AWAY and vz >= 0:
            # brushing the water (a crest under the climbing stone) before it has come back down is
            # part of the flight, not a new contact: its end would be a skip with no bounce in it; and
            # no sinking either, whatever its speed (a slow stone climbing out through a crest was
            # said to have sunk, which is final)
            return StageId.FLY_AWAY
        if horizontal < sink_speed and vz < sink_speed:
            # (not while it rises faster than that: a stone thrown back up by the bed of a shallow pond
            # was said to have sunk, which is final, as it flew 17 cm up out of the water)
            if water.submerged_fraction >= BUOYANCY_READABLE:
                return StageId.FLOAT if floats(body, water, water_density) else StageId.SINK
            if (water.submerged_fraction > 0.0 and not water.buoyancy[2] > 0.0
                    and not lighter_than_water(body, water_density)):
                # part of a heavy stone under water and no buoyancy on it: this scene's water has
                # none, nothing holds the stone up. (A stone whose lowest point has only reached the
                # surface has nothing under water yet, and no buoyancy for that reason: it goes on.
                # So does a light one: the sliver of one landing on the water it stirred was reported
                # with no buoyancy (its own raised water counted), and a ball that would float was
                # called sunk, which is final; once a hundredth of it is under, the buoyancy tells)
                return StageId.SINK
            return StageId.HIT if vz < 0 else StageId.SLIDE
        if water.submerged_fraction >= FULLY_SUBMERGED and vz <= 0.0:
            # under water, the stone has sunk unless it is rising or the water pushes it back up: a
            # thin stone thrown fast dips wholly under the surface for a few milliseconds while the
            # pressure on it (tens of times its weight) throws it back out
            # Nor while the solid ground pushes it (a stone driven into a shallow pond's bed, wholly
            # under its 3 cm of water and still moving down, the bed's answer a step away: it was said
            # to have sunk, which is final, and flew 10 cm out of the water)
            if (_vertical_water_force(water) <= body.mass * gravity
                    and not (ground is not None and ground.in_contact)):
                return StageId.SINK
        return StageId.HIT if vz < 0 else StageId.SLIDE
    if ground is not None and ground.in_contact:
        # dry on the solid ground (a beach, the bed of a pond run dry): neither airborne nor in the
        # water (a stone sliding up a beach was in its fly-away, then in an approach, lying on it)
        return StageId.GROUND
    if previous in (StageId.HIT, StageId.SLIDE):
        if contact_goes_on(water, vz, clearance):
            return StageId.HIT if vz < 0 else StageId.SLIDE
        # over the edge of the water the contact ends with no bounce: airborne, until it left the pond
        return StageId.APPROACH if off_the_water(water) else StageId.FLY_AWAY
    if previous in (StageId.FLY_AWAY, StageId.GROUND):  # airborne, off the water or the ground
        return StageId.FLY_AWAY if vz >= 0 else StageId.APPROACH
    return StageId.APPROACH


class StageMonitor(Component):
    """Publishes stage changes and per-skip figures; stops the run after sink, float or rest, and as
    the stone leaves the pond."""

    @dataclass(frozen=True)
    class Params:
        sink_speed: float = param(0.5, unit="m/s", ge=0,
                                  doc="touching water slower than this horizontally counts as sinking")
        rest_speed: float = param(0.01, unit="m/s", ge=0, doc="on the ground slower than this is at rest")
        stop_after: float = param(0.3, unit="s", ge=0,
                                  doc="end the run this long after sink, float or rest, and at once when the "
                                      "stone leaves the pond (0: never stop)")
        takeoff_clearance: float = param(0.002, unit="m", ge=0,
                                         doc="a contact ends when the stone rises with its lowest point this far "
                                             "above the surface")
        gravity: float = param(9.81, unit="m/s^2", gt=0,
                               doc="magnitude of the body's gravity: a stone under water sinks unless the "
                                   "water pushes it up harder than its weight")
        water_density: float = param(1000.0, unit="kg/m^3", gt=0,
                                     doc="density of the water (its coupler's rho): a stone lighter than as "
                                         "much water as its volume floats, a heavier one sinks")
        outside_after: float = param(0.05, unit="s", ge=0,
                                     doc="dry while below the water level this long: the stone left the pond "
                                         "(longer than the water's start-up lag; 0: never decided)")

    inputs = {
        "body": Port(BodyState, "the stone's state", required=True),
        "water": Port(WaterContact, "the coupler's contact report"),
        "ground": Port(GroundContact, "the ground's contact report"),
    }
    outputs = {"stage": Port(Stage, "the stage the stone entered, at each change", event=True),
               "skip": Port(SkipRecord, "the figures of each skip, at its fly-away", event=True)}

    def setup(self) -> None:
        self.stage: StageId | None = None  # the first step always publishes
        self.since = 0.0
        self.track = SkipTracker()
        self.timeline: list[tuple[float, str]] = []
        self.records: list[SkipRecord] = []
        self.final_x = math.nan
        self.final_y = math.nan
        self.outside_since = math.nan  # first time of the current dry-below-the-level spell [s]
        self.outside_at = (math.nan, math.nan)  # where the stone was then (x, y) [m]
        self.rest_since = math.nan  # first time of the current slow spell on the ground [s]
        self._step = 0.0  # the last step [s]: the summary gives its times to its last digit
        self.settled_since = math.nan  # floating: since when it moves slower than SETTLED_SPEED [s]
        self.left_at = math.nan  # when the stone was found to have left the pond [s]

    def fed_through(self) -> dict[str, str]:
        """Its contact reports come from the coupler and the ground of the body it watches (fed
        another body's contact, it told that body's skips at this one's times)."""
        return {"water": "body", "ground": "body"}

    def check_start_sources(self, inputs: dict[str, Message | None], sources: dict[str, Component]) -> list[str]:
        """Its gravity must be its body's: it decides sinking against the weight and reports the
        water's push in g; its water density its coupler's: it decides floating against it."""
        problems = []
        mismatch = gravity_mismatch(sources.get("body"), self.params.gravity, "gravity")
        if mismatch is not None:
            problems.append(mismatch)
        coupler = sources.get("water")
        rho = getattr(getattr(coupler, "params", None), "rho", None)
        if isinstance(rho, (int, float)) and not math.isclose(rho, self.params.water_density, rel_tol=1e-9):
            problems.append(f"water_density {self.params.water_density:g} kg/m^3 is not the density of its water "
                            f"({coupler.name}'s rho, {rho:g} kg/m^3): set water_density to {rho:g}")
        return problems

    def start_inputs(self, inputs: dict[str, Message | None]) -> None:
        body = inputs.get("body")
        if body is not None:  # where the throw starts: the body's state at t = 0, not after a step
            self._start_at(body)  # type: ignore[arg-type]

    def _start_at(self, body: BodyState) -> None:
        track = self.track
        track.start_x, track.start_y = float(body.position[0]), float(body.position[1])
        vx, vy = float(body.velocity[0]), float(body.velocity[1])
        # a body let go without horizontal speed is taken as thrown along +x
        track.start_heading = math.atan2(vy, vx) if math.hypot(vx, vy) > HEADING_SPEED else 0.0

    def _step_impl(self, t: float, dt: float, inputs: dict[str, Message | None]) -> dict[str, Message]:
        body: BodyState = inputs["body"]  # type: ignore[assignment]
        water: WaterContact | None = inputs["water"]  # type: ignore[assignment]
        ground: GroundContact | None = inputs["ground"]  # type: ignore[assignment]
        # the body's step, which the gravity-speed rules below are about: a body stepping every 4 (2 ms)
        # under a monitor stepping every 1 rested at g times 2 ms and was never at rest, one rising out
        # of the water took its first step for a descent and made a skip of it
        body_step = self.source_steps.get("body", dt)
        now = t + dt if body_step >= dt else _first_stamp_after(t, body_step)
        self._step = min(dt, body_step)  # [s] (the summary gives its times to this step's last digit)
        x = float(body.position[0])
        track = self.track
        if math.isnan(track.start_x):  # stepped without its inputs at t = 0 (a component driven by hand)
            self._start_at(body)
        if math.isnan(self.left_at) and self.stage not in FINAL_STAGES:
            # where it left the pond, sank, floated or came to rest, its distance ends: a stone of a
            # monitor that ends no run (stop_after 0) falls on beside the water, and its fall is no
            # distance travelled; a sunk stone drifting on under water for stop_after made the
            # distance depend on that setting (held_skip: 7.43 m with 0.05 s, 7.45 m with 0.3 s)
            self.final_x, self.final_y = x, float(body.position[1])
        outputs: dict[str, Message] = {}

        previous = StageId.APPROACH if self.stage is None else self.stage
        stage = classify(previous, body, water, ground, self.params.sink_speed, self.params.rest_speed,
                         self.params.takeoff_clearance, self.params.gravity, self.params.water_density,
                         step=body_step)
        stage = self._held_at_rest(stage, previous, now)
        # a brush while still rising after a fly-away is part of the flight (docs/stages.md): begun as
        # a contact, the dry descent after it would have gone on as one, and the next skip would have
        # taken the brush's touchdown
        wetted = water is not None and water.wetted and not (previous is stage is StageId.FLY_AWAY)
        touching = wetted or (track.in_contact and contact_goes_on(water, float(body.velocity[2]),
                                                                   self.params.takeoff_clearance))
        if wetted and not track.in_contact:
            track.in_contact = True
            track.touchdown_time, track.touchdown_x, track.speed_in = now, x, body.speed
            track.touchdown_y = float(body.position[1])
            track.peak_g = 0.0
            track.descended = False
            track.grounded = False
        if track.in_contact and float(body.velocity[2]) < -abs(self.params.gravity) * body_step:
            # moving down faster than a step of gravity's speed: a body's first step in a scene is
            # under gravity alone (the water's answer reaches it a step later), so a ball started at
            # rest under water reported -g dt, and its rise out of the water was counted a skip
            track.descended = True
        if track.in_contact and ground is not None and ground.in_contact:
            track.grounded = True
        if track.in_contact and water is not None:
            track.peak_g = max(track.peak_g, _vertical_water_force(water) / (float(body.mass) * self.params.gravity))
        if (stage is StageId.FLY_AWAY and self.stage in (StageId.HIT, StageId.SLIDE, StageId.SINK)
                and track.descended):
            if track.grounded:  # the ground turned it, not the water (a shallow pond's bed)
                track.ground_bounces += 1
            else:
                outputs["skip"] = self._finish_skip(now, body)
        if not touching:
            track.in_contact = False
        if stage is not self.stage:
            # (rest is dated from the start of the slow spell that made it: _held_at_rest; the first
            # stage from the run's start, which it describes: it said "approach (0.005 s)" on a 5 ms step)
            since = self.rest_since if stage is StageId.REST else t if self.stage is None else now
            # (and the first stage where the run began: it gave where the body was a step later)
            at = (track.start_x, track.start_y) if self.stage is None else (x, float(body.position[1]))
            self.stage, self.since = stage, since
            self.timeline.append((since, STAGE_NAMES[stage]))
            outputs["stage"] = Stage(stage, STAGE_NAMES[stage], track.skips, at[0], at[1], since)
        if stage is StageId.FLOAT:
            # a floating body is decided as it first comes in slowly, a dropped one as it plunges: the
            # run ends once it has settled, not while it bobs (it ended mid-plunge, 9.5 cm under)
            if not settled(body):
                self.settled_since = math.nan
            elif math.isnan(self.settled_since):
                self.settled_since = now
        if (self.params.stop_after > 0 and stage in (StageId.SINK, StageId.FLOAT, StageId.REST)
                and _lasted(self.settled_since if stage is StageId.FLOAT else self.since, now,
                            self.params.stop_after)):
            self.request_stop(f"{self._body_name()} {STAGE_NAMES[stage]} since t = {self.time_text(self.since)} s")
        self._check_outside(now, body, water, outputs)
        return outputs

    def _body_name(self) -> str:
        """The body it watches, by its name in the scene (a floating ball's monitor said "stone float");
        "stone" when driven by hand."""
        sources = self.input_sources.get("body") or ["stone"]
        return sources[0]

    def _held_at_rest(self, stage: StageId, previous: StageId, now: float) -> StageId:
        """``stage``, or while a body has been slow on the ground (classified at rest) for less than
        REST_HOLD, on the ground (``previous`` if that was a stage in the water): rest is final, and
        a body starting to roll or slide from standing still, or turning round on a slope, is slow
        for a while."""
        if stage is not StageId.REST or previous is StageId.REST:
            self.rest_since = math.nan
            return stage
        if math.isnan(self.rest_since):
            self.rest_since = now
        if _lasted(self.rest_since, now, REST_HOLD):
            return stage
        # not yet: on the ground, unless it was in the water (sunk, or in a contact on a shallow bed)
        return StageId.GROUND if previous in (StageId.APPROACH, StageId.FLY_AWAY) else previous

    def _check_outside(self, now: float, body: BodyState, water: WaterContact | None,
                       outputs: dict[str, Message]) -> None:
        """Decide that the stone left the pond: dry with its lowest point below the water level for
        ``outside_after`` (inside the grid such a point is under water, hence wetted)."""
        if self.params.outside_after <= 0 or not math.isnan(self.left_at):
            return
        if water is None or water.wetted or not water.depth > 0.0:
            self.outside_since = math.nan
            return
        if math.isnan(self.outside_since):
            self.outside_since = now
            self.outside_at = (float(body.position[0]), float(body.position[1]))
        if _lasted(self.outside_since, now, self.params.outside_after) and "stage" not in outputs:
            # (a stage change this step is published first: left-pond follows at the next)
            self.left_at = now
            self.stage, self.since = StageId.LEFT_POND, now
            self.timeline.append((now, LEFT_POND))
            # where it came down beside the water (its lowest point went below the level with no water
            # under it), not where it crossed the water's edge (the monitor knows no edge), nor where it
            # was outside_after later: a throw flying past an 8 m pond "came down at x = 11.2 m", and its
            # distance counted its fall, 10.95 m, where it came down at 10.74 m
            x, y = self.outside_at
            if math.isnan(x):  # (a restart from a state saved before it was kept: where the stone is now)
                x, y = float(body.position[0]), float(body.position[1])
            self.final_x, self.final_y = x, y
            outputs["stage"] = Stage(StageId.LEFT_POND, LEFT_POND, self.track.skips, x, y, now)
            if self.params.stop_after > 0:  # 0: this monitor ends no run (one body of several leaving)
                what = "left the pond" if not math.isnan(self.track.touchdown_time) else "missed the water"
                # to the millimetre (a throw along y = 0 printed "y = -7.93e-17 m"), every digit of it (to
                # three figures, 10.544 m was "10.5 m" beside a distance of 10.24 m from x = 0.3), and the
                # time as the timeline gives it (1.1875 s, not 1.188)
                self.request_stop(f"{self._body_name()} {what}: it came down beside the water at x = {_mm(x)} m, "
                                  f"y = {_mm(y)} m (below the water's level with no water under it since "
                                  f"t = {self.time_text(self.outside_since)} s)")

    def _finish_skip(self, now: float, body: BodyState) -> SkipRecord:
        track = self.track
        track.skips += 1
        first = math.isnan(track.last_touchdown_x)
        previous_x = track.start_x if first else track.last_touchdown_x
        previous_y = track.start_y if first else track.last_touchdown_y
        vx, vy, vz = (float(v) for v in body.velocity)
        record = SkipRecord(
            index=track.skips, touchdown_time=track.touchdown_time, touchdown_x=track.touchdown_x,
            contact_time=now - track.touchdown_time,
            takeoff_angle_deg=math.degrees(math.atan2(vz, math.hypot(vx, vy))),
            distance=self._along_throw_line(track.touchdown_x - previous_x, track.touchdown_y - previous_y),
            speed_in=track.speed_in, speed_out=body.speed,
            drift=self._beside_throw_line(track.touchdown_x, track.touchdown_y),
            heading_deg=_turned_deg(math.atan2(vy, vx) - track.start_heading), peak_g=track.peak_g,
            touchdown_y=track.touchdown_y)
        track.last_touchdown_x, track.last_touchdown_y = track.touchdown_x, track.touchdown_y
        self.records.append(record)
        return record

    def _along_throw_line(self, dx: float, dy: float) -> float:
        """How far [m] a move (dx, dy) goes along the line the stone was thrown along (its heading at
        t = 0): a throw's distances whatever its direction (dx itself for a throw along +x)."""
        h = self.track.start_heading
        return dx * math.cos(h) + dy * math.sin(h)

    def travelled(self) -> float:
        """The distance [m] from the throw's start to where the stone was at the monitor's last step,
        along the throw's line; NaN before its first step."""
        track = self.track
        return self._along_throw_line(self.final_x - track.start_x, self.final_y - track.start_y)

    def _touchdown_y_of(self, record: SkipRecord) -> float:
        """The y [m] of a skip's touchdown, from its x and its drift (the throw's line not along y),
        else the last contact's."""
        track = self.track
        h = track.start_heading
        if abs(math.cos(h)) < 0.5:
            return track.touchdown_y
        return track.start_y + (record.drift + (record.touchdown_x - track.start_x) * math.sin(h)) / math.cos(h)

    def _beside_throw_line(self, x: float, y: float) -> float:
        """Signed distance [m] of the point (x, y) from the line the stone was thrown along (left of
        the throw positive)."""
        track = self.track
        h = track.start_heading
        return -(x - track.start_x) * math.sin(h) + (y - track.start_y) * math.cos(h)

    def get_state(self) -> dict[str, Any]:
        return {"stage": None if self.stage is None else int(self.stage), "since": self.since,
                "track": vars(self.track).copy(),
                "timeline": [list(e) for e in self.timeline], "final_x": self.final_x, "final_y": self.final_y,
                "records": [[getattr(r, f) for f in _SKIP_FIELDS] for r in self.records],
                "outside_since": self.outside_since, "outside_at": list(self.outside_at), "left_at": self.left_at,
                "settled_since": self.settled_since, "rest_since": self.rest_since,
                "step": self._step}  # (a restart taking no step gives its times to the same digits)

    def set_state(self, state: dict[str, Any]) -> None:
        self.stage = None if state["stage"] is None else StageId(state["stage"])
        self.since = state["since"]
        self.track = SkipTracker(**state["track"])
        self.timeline = [(t, label) for t, label in state["timeline"]]
        self.final_x = state["final_x"]
        self.final_y = float(state.get("final_y", self.track.start_y))  # saved before it was kept: along x
        self.records = [SkipRecord(*row) for row in state["records"]]
        if "last_touchdown_y" not in state["track"] and self.records:
            # saved before distances ran along the throw's line: the last touchdown's y from its drift
            self.track.last_touchdown_y = self._touchdown_y_of(self.records[-1])
        self.outside_since = float(state.get("outside_since", math.nan))
        self.outside_at = tuple(float(c) for c in state.get("outside_at", (math.nan, math.nan)))  # type: ignore[assignment]
        self.settled_since = float(state.get("settled_since", math.nan))
        self.rest_since = float(state.get("rest_since", math.nan))
        self.left_at = float(state.get("left_at", math.nan))
        self._step = float(state.get("step", 0.0))  # (saved before it was kept: the times to 3 decimals)

    def metrics(self) -> dict[str, float | int | str]:
        contact = [r.contact_time for r in self.records]
        return {
            "skips": self.track.skips,
            "ground_bounces": self.track.ground_bounces,  # fly-aways off the solid ground, no skips
            "distance": self.travelled(),
            "outcome": self._outcome(),
            # the throw was cut short by the water's edge: its distance and skips are lower bounds
            "reached_edge": int(not math.isnan(self.left_at)),
            "first_contact_time": contact[0] if contact else math.nan,
            "mean_contact_time": sum(contact) / len(contact) if contact else math.nan,
            "skip_distances": " ".join(f"{r.distance:.4f}" for r in self.records),
            "skip_peaks": " ".join(f"{r.peak_g:.2f}" for r in self.records),  # [g] SkipRecord.peak_g
        }

    def time_text(self, t: float) -> str:
        """``t`` [s] to the last digit of the monitor's step, at least to the millisecond, with no
        trailing zeros past it: on a 0.5 ms step 0.0525 s, not 0.052 s (the stop line said "sink
        since t = 0.0525 s" beside a timeline saying 0.052 s)."""
        # the step's own decimals (a 0.25 ms step has five: "0.00025 s", not "0.0003 s")
        decimals = max(3, step_decimals(round(self._step * NS_PER_S))) if self._step > 0 else 3
        if t == 0.0:
            return "0"  # the run's start (its first stage's): "0.000 s" would claim a rounding
        text = f"{t:.{decimals}f}"
        while decimals > 3 and text.endswith("0"):
            text, decimals = text[:-1], decimals - 1
        return text

    def _outcome(self) -> str:
        if not math.isnan(self.left_at):
            return LEFT_POND
        return STAGE_NAMES[self.stage] if self.stage is not None else "none"

    def summary(self) -> list[str]:
        # named after the monitor ("stages" in most scenes), so that several monitors tell theirs apart
        timeline = ' -> '.join(f'{label} ({self.time_text(t)} s)' for t, label in self.timeline)
        lines = [f"{self.name}: {timeline or 'no stage yet (the run ended before the monitor first stepped)'}"]
        distance = self.travelled()
        # rounded first: a stone that moved back by less than 5 mm travelled 0.00 m, not -0.00 m
        travelled = f"{round(distance, 2) + 0.0:.2f} m" if not math.isnan(distance) else "none yet"
        outcome = self._outcome()
        if outcome == LEFT_POND and math.isnan(self.track.touchdown_time):
            outcome += " (it never touched the water)"
        bounces = self.track.ground_bounces
        off_ground = (f" ({bounces} bounce{'s' if bounces != 1 else ''} off the ground, not counted)"
                      if bounces else "")
        lines.append(f"skips: {self.track.skips}{off_ground}; distance travelled: {travelled}; final stage: {outcome}")
        # a throw that curves (a spinning stone) says how far, per skip; a straight one stays quiet
        curved = any(abs(r.drift) >= CURVE_DRIFT or abs(r.heading_deg) >= CURVE_HEADING_DEG for r in self.records)
        # a throw along x is told by its touchdowns' x; one along another line by how far along it they
        # are (a throw along +y said "x = 1.75 m" at every skip: true, and nothing of where they were)
        along_x = abs(math.sin(self.track.start_heading)) < 1e-9
        along = 0.0
        for r in self.records:
            along += r.distance
            where = f"at x = {r.touchdown_x:.2f} m" if along_x else f"{along:.2f} m along the throw"
            # rounded first: a drift or turn smaller than the last digit is +0, not -0
            drift, heading = round(r.drift, 2) + 0.0, round(r.heading_deg, 1) + 0.0
            curve = f"; drift {drift:+.2f} m, heading {heading:+.1f} deg" if curved else ""
            touchdown = self.time_text(r.touchdown_time)
            lines.append(f"  skip {r.index}: touchdown {where}, t = {touchdown} s; "
                         f"contact {r.contact_time * 1e3:.1f} ms, peak {r.peak_g:.1f} g; "
                         f"take-off {r.takeoff_angle_deg:.1f} deg; "
                         f"speed {r.speed_in:.2f} -> {r.speed_out:.2f} m/s{curve}")
        return lines


FINAL_STAGES = (StageId.SINK, StageId.FLOAT, StageId.REST)  # (and left-pond, which ends the distance too)
CURVE_DRIFT = 0.005  # [m] sideways offset from which a throw is reported as curving
CURVE_HEADING_DEG = 0.1  # [deg] turn of the heading from which a throw is reported as curving
SETTLED_SPEED = 0.01  # [m/s] a floating body slower than this has settled: the run may end


def settled(body: BodyState) -> bool:
    """Whether a floating body has settled: its kinetic energy, moving and (a disk) rocking, less
    than that of moving at SETTLED_SPEED. A disk's rocking is its turn across its axis, weighed by
    its radius of gyration about a diameter (sqrt(I / m)): a disk let go tilted rocked at 3.5 deg and
    1.2 rad/s (3 cm/s so weighed) when its centre had been slower than 1 cm/s for 0.3 s and the run
    ended; rocking at 0.3 deg and 0.2 rad/s it has settled. (A turn about the axis, or a ball's,
    moves no water up or down.)"""
    rock = 0.0
    if body.shape == Shape.DISK:
        axis = body_axis(tuple(float(c) for c in body.orientation))  # type: ignore[arg-type]
        w = [float(c) for c in body.angular_velocity]
        along = w[0] * axis[0] + w[1] * axis[1] + w[2] * axis[2]
        across_sq = sum((w[k] - along * axis[k]) ** 2 for k in range(3))
        rock = across_sq * float(body.inertia[0]) / float(body.mass)  # [m^2/s^2]
    return body.speed * body.speed + rock < SETTLED_SPEED * SETTLED_SPEED


def _first_stamp_after(t: float, step: float) -> float:
    """The time [s] of the body's state a monitor stepping less often than its body reads in its step
    from ``t`` [s]: the body, stepping every ``step`` [s], has run its step that holds ``t`` (it comes
    first in the tick), so the newest state is stamped at that step's end, not the monitor's. (Dated
    at the monitor's end instead, a monitor stepping every 4 base steps of 0.5 ms put the reference
    skip's touchdown at 0.062 s, with the x of the state stamped 0.0605 s; the stone wetted at 0.0595.)"""
    t_ns, step_ns = round(t * NS_PER_S), round(step * NS_PER_S)
    return (t_ns // step_ns + 1) * step_ns / NS_PER_S


def _mm(length: float) -> str:
    """``length`` [m] to the millimetre, without trailing zeros: 10.544, 0.8, 0 (never -0)."""
    return f"{round(length, 3) + 0.0:.3f}".rstrip("0").rstrip(".")


def _vertical_water_force(water: WaterContact) -> float:
    """The water's vertical force on the body [N]: the sum of its effects' (WaterContact)."""
    return (float(water.buoyancy[2]) + float(water.pressure[2]) + float(water.friction[2])
            + float(water.wave_drag[2]))


def _turned_deg(angle: float) -> float:
    """An angle difference [rad] as degrees in (-180, 180]."""
    return math.degrees(math.atan2(math.sin(angle), math.cos(angle)))


_SKIP_FIELDS = [f for f in SkipRecord.__dataclass_fields__]
