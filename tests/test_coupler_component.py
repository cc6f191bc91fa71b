"""The WaterCoupler component (components.coupler.component): ports, effects, far exit, stability,
substepping, state, energy books.

Topology it is built for (the scheduler is not needed here; messages are hand-made)::

    stone.state --(direct)--> coupler.body        coupler.wrench   --(delay 1)--> stone.wrench
    pond.patch  --(direct)--> coupler.water       coupler.occupied --(delay 1)--> pond.occupied
                                                  coupler.request  --(delay 1)--> pond.request
"""

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from components.coupler import EFFECTS, WaterCoupler, WaterCouplerParams
from components.coupler.fixtures import axis_angle, body, disk_at_depth, pitched, still_water
from components.coupler.forces import C_MIN, wave_drag_magnitude
from components.coupler.geometry import quat_to_matrix
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
from cosim.cli import main
from cosim.errors import SimulationError
from cosim.messages import messages_equal
from cosim.params import build
from cosim.registry import resolve
from cosim.scenario import load

DT_NS = 100_000  # 0.1 ms
ALPHA = math.radians(20)


def skipping_disk(speed=5.0, depth=0.01, **kw):
    """A pitched disk at the given depth, moving forward and down at 15 degrees."""
    beta = math.radians(15)
    return body(position=disk_at_depth(depth, ALPHA), orientation=pitched(ALPHA),
                velocity=(speed * math.cos(beta), 0.0, -speed * math.sin(beta)), **kw)


def step(coupler, b, patch, k=0, **kw):
    return coupler.step(k * DT_NS, DT_NS, {"body": b, "water": patch}, **kw)


def test_ports_and_type_names():
    """Inputs body/water/ground and outputs wrench/occupied/request/contact/added_mass carry the physics
    messages; the type is reachable as WaterCoupler and as Coupler."""
    assert {k: p.type for k, p in WaterCoupler.inputs.items()} == {"body": BodyState, "water": HeightPatch,
                                                                   "ground": Impulse}
    assert WaterCoupler.inputs["ground"].event and not WaterCoupler.inputs["ground"].required
    assert {k: p.type for k, p in WaterCoupler.outputs.items()} == {
        "wrench": Wrench, "occupied": OccupiedHeight, "request": PatchRequest, "contact": WaterContact,
        "added_mass": AddedMass}
    assert resolve("WaterCoupler") is WaterCoupler
    assert resolve("Coupler") is WaterCoupler


def test_scene_parameters_reject_unknown_effects_listing_the_valid_ones():
    """An unknown effect in a scene is reported with its path and the valid names."""
    problems: list[str] = []
    build(WaterCouplerParams, {"effects": ["buoyancy", "lift"]}, "components.contact", problems)
    assert problems == ["components.contact.effects: unknown effect 'lift' (valid: displacement, buoyancy, "
                        "pressure, friction, wave_drag, added_mass)"]


def test_constructing_with_an_unknown_effect_fails():
    """A coupler built directly with an unknown effect refuses to start."""
    with pytest.raises(ValueError, match="unknown effect 'spray'"):
        WaterCoupler("c", WaterCouplerParams(effects=["spray"]))


def test_initial_outputs_are_quiet():
    """At t = 0: zero wrench, empty occupied window, empty request, dry contact; with the added mass
    named, no water carried along either."""
    out = WaterCoupler("c").initial_outputs()
    assert set(out) == set(WaterCoupler.outputs) - {"added_mass"}  # not named: the default forces only
    carried = WaterCoupler("c", WaterCouplerParams(effects=["buoyancy", "added_mass"])).initial_outputs()
    assert set(carried) == set(WaterCoupler.outputs) and not any(carried["added_mass"].values())
    assert not out["wrench"].force.any() and not out["wrench"].torque.any()
    assert out["occupied"].b.size == 0
    assert out["request"].x_min > out["request"].x_max
    assert not out["contact"].wetted


def test_far_body_costs_no_column_work():
    """A body high above the water gets a zero wrench, an empty window and no work; it asks for the
    water's crest where it goes, not its columns."""
    c = WaterCoupler("c")
    out = step(c, body(position=(0.0, 0.0, 1.0), velocity=(5.0, 0.0, -1.0)), still_water())
    assert set(out) == set(WaterCoupler.outputs) - {"added_mass"}
    assert c.work == {"columns": 0, "elements": 0}
    assert not out["wrench"].force.any()
    assert out["occupied"].b.size == 0
    assert not out["request"].columns
    assert out["contact"].depth == pytest.approx(-(1.0 - math.hypot(0.05, 0.003)))
    assert c.max_stable_step() == math.inf


def test_a_body_far_above_the_water_asks_for_the_crest_where_it_goes_and_meets_a_higher_one():
    """A body 20 cm up is far from water whose crest where it goes stands 4 cm high (wave_allowance
    5 cm): it asks for that crest alone (columns False) over its next footprint and what lies ahead.
    Told of a 30 cm crest (a wave another body raised), it is near: it asks for the columns. Before,
    only the allowance counted, and a body above it fell through any higher wave untouched."""
    from dataclasses import replace

    b = body(position=(0.0, 0.0, 0.2), velocity=(5.0, 0.0, -1.0))
    far = step(WaterCoupler("c"), b, replace(still_water(), crest=0.04))["request"]
    assert not far.columns and far.x_min < 0.0 < far.x_max and far.y_min < 0.0 < far.y_max
    assert far.x_max > 5.0 * WaterCoupler("c").params.lookahead  # as far ahead as it goes in the lookahead
    near = step(WaterCoupler("c"), b, replace(still_water(), crest=0.3))["request"]
    assert near.columns and near.x_min < 0.0 < near.x_max and near.y_min < 0.0 < near.y_max
    unknown = step(WaterCoupler("c"), b, still_water())["request"]  # hand-made water says no crest
    assert not unknown.columns


def test_body_near_water_requests_its_next_footprint():
    """Before any patch arrives, a body near the water asks for its footprint at x + v dt plus a margin,
    reaching ahead along its motion as far as it goes in ``lookahead`` (and no further behind or aside)."""
    c = WaterCoupler("c")
    b = body(position=(1.0, 2.0, 0.04), velocity=(10.0, 0.0, -1.0))
    out = step(c, b, None)
    req = out["request"]
    x_next = 1.0 + 10.0 * DT_NS * 1e-9
    assert req.x_min < x_next - 0.05 and req.x_max > x_next + 0.05
    assert req.y_min < 2.0 - 0.05 and req.y_max > 2.0 + 0.05
    # behind: the footprint (5 cm), the margin before the cell size is known (5 cm) and the reach of
    # the displaced water's band (twice half the radius, 5 cm), the window lagging one step (1 mm)
    assert req.x_min == pytest.approx(x_next - 0.05 - 0.05 - 0.05 - 10.0 * DT_NS * 1e-9, abs=1e-9)
    assert req.x_max == pytest.approx(x_next + 10.0 * c.params.lookahead + (req.x_min - x_next) * -1, abs=1e-9)
    assert req.y_max - req.y_min < 0.32
    assert not out["wrench"].force.any()


def test_request_margin_follows_the_cell_size():
    """Once a patch has told the cell size, the margin is margin_cells (+ the ring band) cells."""
    c = WaterCoupler("c", WaterCouplerParams(effects=["buoyancy"], margin_cells=3))
    b = body(position=(0.0, 0.0, 0.0))
    req = step(c, b, still_water(0.02))["request"]
    assert req.x_max == pytest.approx(0.05 + 3 * 0.02)


def test_each_effect_can_be_switched_off_alone():
    """Dropping one effect zeroes its force and leaves every other effect's force unchanged, bit for bit."""
    patch = still_water(0.01)
    b = skipping_disk(depth=0.015, angular_velocity=(0.0, 3.0, 20.0))
    full = step(WaterCoupler("c"), b, patch)["contact"]
    for name in EFFECTS:
        out = step(WaterCoupler("c", WaterCouplerParams(effects=[e for e in EFFECTS if e != name])), b, patch)
        for force in ("buoyancy", "pressure", "friction", "wave_drag"):
            value = getattr(out["contact"], force)
            if force == name:
                assert not value.any()
            else:
                assert value.tobytes() == getattr(full, force).tobytes()
                assert value.any()
        total = out["contact"].buoyancy + out["contact"].pressure + out["contact"].friction + \
            out["contact"].wave_drag
        assert out["wrench"].force == pytest.approx(total, abs=1e-12)
        assert (out["occupied"].b.size == 0) == (name == "displacement")


@pytest.mark.parametrize("substeps", [1, 2])
def test_a_body_deep_under_water_makes_almost_no_waves(substeps):
    """A slate ball (R 2 cm) moving at 1 m/s with its top 18 cm under still water feels the wave drag
    of the surface-piercing law times exp(-2 g d / U^2) = 0.029, in the one-call step and in the
    substepped one alike (its mean over two substeps, the ball slowing, within 0.5%); half under,
    the law's whole drag (it was the same at every depth: 0.034 N, a sixth of the ball's pressure
    drag, at 20 cm or at 40 cm)."""
    c = WaterCoupler("c")
    deep = body(Shape.SPHERE, position=(0.0, 0.0, -0.2), velocity=(1.0, 0.0, 0.0), radius=0.02)
    patch = still_water(depth=1.0)
    if substeps == 1:
        out = step(c, deep, patch)
    else:
        c.setup()
        out = c._substep(0.0, 5e-4, substeps, {"body": deep, "water": patch})
    volume = 4.0 / 3.0 * math.pi * 0.02**3
    surface_law = wave_drag_magnitude(1.0, volume, 0.04, 1000.0, 0.3, C_MIN, 9.81)
    assert out["contact"].submerged_fraction == 1.0
    assert -out["contact"].wave_drag[0] == pytest.approx(surface_law * math.exp(-2 * 9.81 * 0.18), rel=5e-3)
    half = step(WaterCoupler("c"), body(Shape.SPHERE, velocity=(1.0, 0.0, 0.0), radius=0.02), patch)
    assert -half["contact"].wave_drag[0] == pytest.approx(
        wave_drag_magnitude(1.0, 0.5 * volume, 0.04, 1000.0, 0.3, C_MIN, 9.81), rel=2e-2)


def test_no_effects_means_no_work_but_all_outputs():
    """With no effect named the coupler does no column or element work and still publishes every port
    of the forces (the added mass has a port of its own, published with its effect)."""
    c = WaterCoupler("c", WaterCouplerParams(effects=[]))
    out = step(c, skipping_disk(depth=0.02), still_water())
    assert set(out) == set(WaterCoupler.outputs) - {"added_mass"}
    assert c.work == {"columns": 0, "elements": 0}
    assert not out["wrench"].force.any()
    assert out["occupied"].b.size == 0


def test_contact_report_of_a_pitched_disk():
    """The report gives the lowest point's depth, the wetted area and the submerged fraction."""
    c = WaterCoupler("c")
    contact = step(c, skipping_disk(depth=0.012), still_water())["contact"]
    assert contact.wetted
    assert contact.depth == pytest.approx(0.012, abs=1e-12)
    assert 0.0 < contact.submerged_fraction < 0.5
    assert contact.wetted_area > 0.0
    dry = step(WaterCoupler("c"), skipping_disk(depth=-0.005), still_water())["contact"]
    assert not dry.wetted and dry.depth == pytest.approx(-0.005)


def test_occupied_window_is_in_grid_indices():
    """The occupied window's i0, j0 are grid indices: the patch's offset plus the local position."""
    b = body(Shape.SPHERE, position=(0.0, 0.0, 0.0), radius=0.03)
    local = step(WaterCoupler("c"), b, still_water(0.01))["occupied"]
    shifted = step(WaterCoupler("c"), b, still_water(0.01, i0=40, j0=7))["occupied"]
    assert (shifted.i0, shifted.j0) == (local.i0 + 40, local.j0 + 7)
    assert shifted.b == pytest.approx(local.b, rel=1e-9, abs=1e-15)


def test_body_partly_off_the_patch_is_partly_dry():
    """Where the patch ends (the domain edge) there is no water: the body is only partly buoyed."""
    b = body(Shape.SPHERE, position=(0.15, 0.0, 0.0), radius=0.03)
    inside = step(WaterCoupler("c", WaterCouplerParams(effects=["buoyancy"])), b,
                  still_water(0.01, half_width=0.3))["wrench"].force[2]
    edge = step(WaterCoupler("c", WaterCouplerParams(effects=["buoyancy"])), b,
                still_water(0.01, half_width=0.15))["wrench"].force[2]
    assert 0.3 * inside < edge < 0.7 * inside


def test_max_stable_step_near_and_far():
    """The bound is inf far from water. Wetted, the 6 mm slate's is its motion bound, a quarter of
    its radius over its speed (4.17 ms at 3 m/s, 0.417 ms at 30 m/s); a slate 0.1 mm thin, 60 times
    lighter, is bound by the water's damping instead, whose rate grows with the speed and falls with
    the mass: its bound is 10 times shorter at 30 m/s than at 3, and halves with its mass."""
    patch = still_water()
    c = WaterCoupler("c")
    step(c, body(position=(0.0, 0.0, 1.0)), patch)
    assert c.max_stable_step() == math.inf

    def bound(speed: float, **kw) -> float:
        c = WaterCoupler("c")
        # (substepped: the thin slate's own bound at 30 m/s is under the step, which on_unstable: error
        # refuses in the step that meets it)
        step(c, skipping_disk(speed=speed, depth=0.01, **kw), patch, on_unstable="substep")
        return c.max_stable_step()

    for speed in (3.0, 30.0):
        assert bound(speed) == pytest.approx(0.25 * 0.05 / speed, rel=1e-12)
    thin = {"thickness": 1e-4, "density": 2700.0}
    slow, fast = bound(3.0, **thin), bound(30.0, **thin)
    assert slow < 0.25 * 0.05 / 3.0 / 10
    assert slow / fast == pytest.approx(10.0, rel=1e-3)
    assert bound(3.0, **(thin | {"density": 1350.0})) == pytest.approx(0.5 * slow, rel=1e-9)


def test_floating_body_at_rest_has_a_finite_bound():
    """A floating body at rest is bounded by its buoyancy stiffness sqrt(rho g A / m)."""
    c = WaterCoupler("c")
    b = body(Shape.SPHERE, radius=0.03, density=500.0)
    step(c, b, still_water())
    omega = math.sqrt(1000 * 9.81 * math.pi * 0.03**2 / b.mass)
    assert c.max_stable_step() == pytest.approx(1.0 / omega, rel=0.05)


def test_too_large_a_step_is_an_error_naming_the_bound():
    """With on_unstable: error, a step above the bound fails with the bound and the step in the message."""
    c = WaterCoupler("c")
    step(c, skipping_disk(speed=30.0, depth=0.01), still_water())
    with pytest.raises(SimulationError, match="exceeds the stable step"):
        c.step(0, 10_000_000, {"body": skipping_disk(speed=30.0, depth=0.01), "water": still_water()})


def _entry(dt, on_unstable="substep", duration=0.02, speed=30.0):
    """A locked disk entering still water at `speed`, moved by the held wrench (semi-implicit Euler)."""
    c = WaterCoupler("c", WaterCouplerParams())
    alpha, beta = math.radians(10), math.radians(10)
    m = body().mass
    x = np.array([0.0, 0.0, 0.05 * math.sin(alpha) + 0.004])
    v = np.array([speed * math.cos(beta), 0.0, -speed * math.sin(beta)])
    force = np.zeros(3)
    dt_ns = round(dt * 1e9)
    most = 1
    for k in range(round(duration / dt)):
        v = v + (force / m + np.array([0.0, 0.0, -9.81])) * dt
        x = x + v * dt
        patch = still_water(0.01, half_width=0.15, centre=(round(x[0] / 0.01) * 0.01, 0.0))
        out = c.step(k * dt_ns, dt_ns, {"body": body(position=x, orientation=pitched(alpha), velocity=v,
                                                         attitude_locked=True),
                                        "water": patch}, on_unstable=on_unstable)
        most = max(most, c.last_substeps)
        force = out["wrench"].force if "wrench" in out else force  # a quiet coupler holds its wrench
    return v, most


def test_substepping_keeps_a_30_m_s_entry_stable_at_a_coarse_step():
    """At a 1 ms step a 30 m/s entry substeps and leaves the water close to a 0.01 ms reference: its
    speed within 1%, its rebound within 25% (the wrench is held a step behind the body over a contact
    of five steps; the rebound was within 15% while the first wet step, whose own bound is a quarter
    of the radius over the speed, 0.42 ms, was taken whole: a run's first step is bound by it from
    the start, and gives this one)."""
    fine, fine_subs = _entry(1e-5)
    coarse, coarse_subs = _entry(1e-3)
    assert fine_subs == 1 and coarse_subs > 1
    assert coarse[2] > 0  # it bounced
    assert coarse[0] == pytest.approx(fine[0], rel=0.01)
    assert coarse[2] == pytest.approx(fine[2], rel=0.25)
    with pytest.raises(SimulationError, match="stable step"):
        _entry(1e-3, on_unstable="error")


def test_state_round_trip_reproduces_the_run_bit_for_bit():
    """set_state(get_state()) on a fresh coupler gives the same outputs, bit for bit, for the same inputs."""
    patch = still_water()
    states = [skipping_disk(depth=d, speed=6.0) for d in (-0.004, 0.002, 0.006, 0.009, 0.011, 0.012)]
    first = WaterCoupler("c")
    for k, b in enumerate(states[:3]):
        step(first, b, patch, k)
    saved = first.get_state()
    second = WaterCoupler("c")
    second.set_state(saved)
    for k, b in enumerate(states[3:], start=3):
        a = step(first, b, patch, k)
        z = step(second, b, patch, k)
        assert a.keys() == z.keys()
        for port in a:
            assert messages_equal(a[port], z[port]), port
    assert first.get_state()["dissipated"] == second.get_state()["dissipated"]


def test_request_is_published_only_when_the_held_window_no_longer_covers_the_body():
    """A body moving a little stays inside the window the water holds: no new request; one that
    moves past half the margin gets a new window."""
    c = WaterCoupler("c")
    patch = still_water()
    first = step(c, skipping_disk(depth=0.005), patch, 0)
    assert "request" in first
    nudged = skipping_disk(depth=0.005)
    nudged = nudged.replace(position=nudged.position + np.array([0.001, 0.0, 0.0]))
    assert "request" not in step(c, nudged, patch, 1)
    ahead = float(nudged.velocity[0]) * c.params.lookahead  # the window reaches this far ahead already
    moved = nudged.replace(position=nudged.position + np.array([0.05 + ahead, 0.0, 0.0]))
    out = step(c, moved, patch, 2)
    assert out["request"].x_max > first["request"].x_max + 0.04


def test_dissipated_energy_is_minus_the_work_of_the_held_wrench():
    """The energy books add -F.(x1 - x0) - tau.(w0 + w1)/2 dt for the wrench held over the body's step."""
    c = WaterCoupler("c")
    b0 = skipping_disk(depth=0.01, angular_velocity=(0.0, 2.0, 0.0))
    out0 = step(c, b0, still_water())
    b1 = skipping_disk(depth=0.0105, angular_velocity=(0.0, 3.0, 0.0))
    b1 = b1.replace(position=b1.position + np.array([0.0004, 0.0, 0.0]))
    out1 = step(c, b1, still_water(), 1)
    work = out0["wrench"].force @ (b1.position - b0.position)
    work += out0["wrench"].torque @ (0.5 * (b0.angular_velocity + b1.angular_velocity)) * DT_NS * 1e-9
    assert out1["contact"].dissipated_energy == pytest.approx(-work, rel=1e-12)
    assert out1["contact"].dissipated_energy > 0  # the water took energy from the body pushing into it


def test_lock_attitude_predictor_keeps_the_orientation():
    """For a body whose attitude is locked (it holds its orientation, whatever its angular velocity:
    a held spin), substeps move the private body copy without turning it, as the body itself does
    not turn; the mean torque is still reported. The copy was turned by the angular velocity (6e-3
    of a quaternion a substep for 50 rad/s across its axis), meeting the water at an attitude the
    body never had; a free body's copy turns."""
    def axes_met(attitude_locked: bool) -> list[np.ndarray]:
        c = WaterCoupler("c", WaterCouplerParams())
        b = skipping_disk(speed=30.0, depth=0.01, attitude_locked=attitude_locked, angular_velocity=(0.0, 50.0, 0.0))
        met = []
        evaluate = c._evaluate

        def spy(body, pos, vel, omega, axes, *args):
            met.append(np.array(axes))
            return evaluate(body, pos, vel, omega, axes, *args)

        c._evaluate = spy
        out = c._substep(0.0, 1e-3, 4, {"body": b, "water": still_water()})
        assert out["wrench"].torque.any()
        assert len(met) == 4  # the step's own evaluation, then one for each substep after the first
        return met

    locked = axes_met(True)
    assert all(np.array_equal(a, locked[0]) for a in locked)
    free = axes_met(False)
    assert not np.allclose(free[-1], free[0], atol=1e-4)


def test_a_body_held_still_in_the_water_makes_no_waves_after_it_is_put_in():
    """The ring carries the volume below the rest level, so waves running under a body held half
    in the water do not change what it displaces: the water's energy stays at what the insertion
    gave it (measured against the local surface, the loop pumped it up twofold every half second)."""
    from components.water import WaterParams, WaterSurface

    pond = WaterSurface("pond", WaterParams(nx=40, ny=40, cell=0.01, depth=0.2,
                                            origin_x=-0.195, origin_y=-0.195))
    coupler = WaterCoupler("c", WaterCouplerParams(effects=["displacement", "buoyancy"]))
    above = body(position=(0.0, 0.0, 0.1), thickness=0.02, density=500.0)
    disk = body(position=(0.0, 0.0, 0.0), thickness=0.02, density=500.0)
    dt_ns = 1_000_000
    patch = pond.step(0, dt_ns, {})["patch"]
    held = coupler.initial_outputs()  # a port that did not change publishes nothing: hold its value
    energy = []
    for k in range(1, 1500):
        placed = above if k < 20 else disk  # dry over the water first, then put in and held there
        held.update(coupler.step(k * dt_ns, dt_ns, {"body": placed, "water": patch}))
        inputs = {"occupied": held["occupied"], "request": held["request"]}
        patch = pond.step(k * dt_ns, dt_ns, inputs)["patch"]
        if k % 500 == 0:
            energy.append(pond.energy())
    assert energy[0] > 0.0
    assert max(energy) < 1.2 * energy[0]


def test_a_body_in_the_water_when_the_run_begins_makes_no_waves():
    """A disk held half in the water from the start was there before the run: its displacement is
    part of the water at rest (OccupiedHeight.already_displaced), so the surface stays flat and the
    water's energy zero, and the water's volume (bodies excluded) is what it was at its first step."""
    from components.water import WaterParams, WaterSurface

    pond = WaterSurface("pond", WaterParams(nx=40, ny=40, cell=0.01, depth=0.2,
                                            origin_x=-0.195, origin_y=-0.195, boundary="reflecting"))
    coupler = WaterCoupler("c", WaterCouplerParams(effects=["displacement", "buoyancy"]))
    disk = body(position=(0.0, 0.0, 0.0), thickness=0.02, density=500.0)
    dt_ns = 1_000_000
    patch = pond.step(0, dt_ns, {})["patch"]
    held = coupler.initial_outputs()
    flags = []
    for k in range(1, 300):
        held.update(coupler.step(k * dt_ns, dt_ns, {"body": disk, "water": patch}))
        flags.append(held["occupied"].already_displaced)
        patch = pond.step(k * dt_ns, dt_ns, {"occupied": held["occupied"], "request": held["request"]})["patch"]
    assert pond.energy() == 0.0 and not pond._h.any()
    assert pond._b.sum() > 0.0  # the water holds the disk's displacement
    assert pond.volume() == pytest.approx(pond.initial_volume, rel=1e-14)
    assert any(flags) and not flags[-1]  # said until the water's patch showed it held it


def test_the_ring_buoyancy_counts_the_displacement_the_water_has_not_applied_yet():
    """A patch saying its water holds no displacement (``occupied`` all zero) lifts a floating disk
    by the mound its ring is about to raise, as much as a patch whose water holds that mound already
    (it is not counted twice); a patch that does not say (hand-made still water) is read as it is,
    and the disk feels Archimedes' force alone."""
    b = body(position=(0.0, 0.0, 0.0))  # 6 mm disk, half immersed
    patch = still_water()
    c = WaterCoupler("c", WaterCouplerParams(effects=["displacement", "buoyancy"]))
    archimedes = step(c, b, patch)["wrench"].force[2]
    fresh = step(c, b, patch.replace(occupied=np.zeros_like(patch.height)), 1)
    mound = np.zeros_like(patch.height)
    ring = fresh["occupied"]
    mound[ring.j0:ring.j0 + ring.b.shape[0], ring.i0:ring.i0 + ring.b.shape[1]] = ring.b
    applied = step(c, b, patch.replace(height=patch.height + mound, occupied=mound), 2)
    assert archimedes == pytest.approx(1000.0 * 9.81 * math.pi * 0.05**2 * 0.003, rel=0.02)  # 1 cm columns
    # the disk's half volume spread over its band (5 cm wide) raises the water there by about 0.4 of
    # its immersion
    assert fresh["wrench"].force[2] > 1.3 * archimedes
    assert applied["wrench"].force[2] == pytest.approx(fresh["wrench"].force[2], rel=1e-12)


def _buoyancy_under_a_level_rise(b, rise: float) -> float:
    """The coupler's vertical force [N] on ``b`` (displacement and buoyancy) with the water standing
    level ``rise`` [m] above the rest level and holding the body's displacement (its occupied height
    fed back, the mound it raised gone)."""
    c = WaterCoupler("c", WaterCouplerParams(effects=["displacement", "buoyancy"]))
    water = still_water(half_width=0.3)
    held = np.zeros_like(water.height)
    for k in range(3):
        out = step(c, b, water.replace(height=water.height + rise, occupied=held), k)
        ring = out["occupied"]
        held = np.zeros_like(water.height)
        held[ring.j0:ring.j0 + ring.b.shape[0], ring.i0:ring.i0 + ring.b.shape[1]] = ring.b
    return float(out["wrench"].force[2])


def test_in_waves_the_buoyancy_is_linear_in_the_waters_rise_as_docs_validation_says():
    """docs/validation.md, "In waves the buoyancy is linear in the water's rise": a ball of 5 cm centred
    at the rest level is lifted by rho g (V under the rest level + rise x its waterline area there),
    the first order of Archimedes' force under the risen level: 1.07 of it under a 3 cm rise, 0.43
    in a 3 cm trough; a disk lying flat, one waterline area through its thickness, is lifted by
    Archimedes' force under the level itself until the water leaves its faces."""
    rho_g, r = 1000.0 * 9.81, 0.05

    def under(h):  # the ball's volume [m^3] under z = h
        d = min(max(h, -r), r) + r
        return math.pi * d * d * (3.0 * r - d) / 3.0

    ball = body(Shape.SPHERE, position=(0.0, 0.0, 0.0), density=500.0)
    ratios = {}
    for rise in (-0.03, -0.01, 0.0, 0.01, 0.03):
        force = _buoyancy_under_a_level_rise(ball, rise)
        # (to 2% of the force at rest: the 1 cm columns sample the waterline circle 1.3% large)
        assert force == pytest.approx(rho_g * (under(0.0) + rise * math.pi * r * r), abs=0.02 * rho_g * under(0.0))
        ratios[rise] = force / (rho_g * under(rise))
    assert ratios[0.0] == pytest.approx(1.0, abs=0.005)
    assert ratios[0.03] == pytest.approx(1.07, abs=0.01) and ratios[-0.03] == pytest.approx(0.43, abs=0.01)
    disk = body(position=(0.0, 0.0, 0.0), thickness=0.015, density=500.0)
    flat = [_buoyancy_under_a_level_rise(disk, rise) / (0.0075 + rise) for rise in (-0.005, 0.0, 0.005, 0.007)]
    assert max(flat) == pytest.approx(min(flat), rel=1e-9)  # force in proportion to the depth under the level


def test_a_body_wholly_under_water_reports_a_submerged_fraction_of_one():
    """A pitched disk whose top is under the surface is wholly submerged (fraction exactly 1), though
    its sampled column volume sums to a little less; one whose top breaks the surface is not."""
    c = WaterCoupler("c")
    _, _, z = disk_at_depth(0.08, ALPHA)
    deep = body(position=(0.0, 0.005, z), orientation=pitched(ALPHA))  # here the columns sum to 0.993
    assert step(c, deep, still_water())["contact"].submerged_fraction == 1.0
    breaking = step(c, body(position=(0.0, 0.0, -0.0025)), still_water(), 1)["contact"]
    assert 0.9 < breaking.submerged_fraction < 1.0


def test_a_quiet_coupler_still_moves_its_window_with_the_body():
    """In flight near the water the coupler publishes nothing, except a new window request when the
    body moves past the one the water holds, so the patch is ready when the body comes down."""
    c = WaterCoupler("c")
    patch = still_water(half_width=0.5)
    flying = skipping_disk(depth=-0.03)  # dry, 3 cm above the surface
    step(c, flying, patch, 0)
    assert step(c, flying, patch, 1) == {}  # quiet: everything held
    ahead = float(flying.velocity[0]) * c.params.lookahead  # the window reaches this far ahead already
    far_along = flying.replace(position=flying.position + np.array([0.2 + ahead, 0.0, 0.0]))
    out = step(c, far_along, patch, 2)
    assert set(out) == {"request"}
    assert out["request"].x_min > flying.position[0]


def test_a_body_in_the_water_before_the_first_patch_meets_still_water():
    """Before the water has sent anything, a stone already in it (a large step, a slow water) is
    pressed as if by still water at the rest level, not let through: the same upward push as over a
    still patch, within sampling; nothing is displaced into a grid not yet known."""
    b = skipping_disk(depth=0.005)
    assumed = step(WaterCoupler("c"), b, None)
    over_patch = step(WaterCoupler("c"), b, still_water())
    assert assumed["wrench"].force[2] > 0
    assert assumed["wrench"].force[2] == pytest.approx(over_patch["wrench"].force[2], rel=0.05)
    assert assumed["occupied"].b.size == 0


def test_a_stone_thrown_with_a_huge_step_meets_the_water_instead_of_falling_through_it():
    """With dt = 50 ms the water's first patch comes after the stone reaches it: the stone still
    hits the water (and sinks, such a step being far too coarse to skip), it does not 'leave the
    pond' 1.5 m into an 8 m pond. The water then answers every 0.2 s (4 ticks): longer than the
    coupler's 60 ms look-ahead, which the scene refuses, so the look-ahead is raised to match."""
    from cosim.errors import ScenarioError
    from cosim.scenario import load
    from cosim.scheduler import Simulation

    skip = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    with pytest.raises(ScenarioError, match=r"comes from pond every 0\.2 s, longer than the 0\.06 s"):
        load(skip, ["dt=0.05"])
    sim = Simulation(load(skip, ["dt=0.05", "components.coupler.lookahead=0.2"]))
    sim.run()
    stages = [name for _, name in sim.components["stages"].timeline]
    assert "hit" in stages and "left-pond" not in stages


def test_a_column_displacement_under_a_buoyant_body_is_warned_of_as_the_scene_loads(capsys):
    """displacement_mode: column reads the surface its own displacement raised: a floating body gains
    energy without bound (tests/stability/test_floating_energy.py holds the ring mode's book). The
    scene still loads and keeps one notice naming the coupler, which `cosim validate` (as `run` and
    `sweep`) says as one warning line; the default, or column without buoyancy, has none. A notice
    is no Python warning: turned into errors, warnings do not refuse the scene."""
    scene = Path(__file__).resolve().parents[1] / "scenarios" / "tilted_float.yaml"
    column = "components.coupler.displacement_mode=column"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        (notice,) = load(scene, [column]).notices
        assert load(scene).notices == []
        assert load(scene, [column, "components.coupler.effects=[displacement]"]).notices == []
    assert notice.startswith("components.coupler: displacement_mode: column reads the surface its own "
                             "displacement raised, so a floating or slow body gains energy")
    assert main(["validate", str(scene), "--set", column]) == 0
    assert capsys.readouterr().err == f"warning: {notice}\n"


@pytest.mark.parametrize("connection, port", [
    ("  - {from: coupler.wrench, to: stone.wrench, delay: 1, initial: {force: [0, 0, 0], torque: [0, 0, 0]}}\n",
     "wrench"),
    ("  - {from: coupler.request, to: pond.request, delay: 1, initial: {x_min: 1, x_max: 0, y_min: 1, y_max: 0}}\n",
     "request"),
    ("  - {from: coupler.occupied, to: pond.occupied, delay: 1, initial: {i0: 0, j0: 0, b: []}}\n", "occupied"),
])
def test_a_scene_that_leaves_out_a_connection_an_effect_needs_is_refused_naming_it(connection, port):
    """Without the wrench the stone fell through the water (and the water 'took' 6434 J from it);
    without the request or the occupied height the pond never moved while the summary listed the
    effects. Each is refused at load, naming the output and the connection to add."""
    from cosim.errors import ScenarioError
    from cosim.scenario import loads

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    text = scene.read_text(encoding="utf-8")
    assert connection in text
    with pytest.raises(ScenarioError) as info:
        loads(text.replace(connection, ""), str(scene))
    (problem,) = info.value.problems
    assert problem.startswith(f"components.coupler: its output {port!r} feeds nothing, but ")
    assert f"{{from: coupler.{port}, to: " in problem


SINKING_GRANITE = """
dt: 0.001
until: 2.0
components:
  granite: {type: RigidBody, shape: sphere, radius: 0.02, density: 2700, position: [0.0, 0.0, 0.0],
            integrator: semi_implicit_euler}
  pond: {type: WaterSurface, nx: 40, ny: 40, cell: 0.01, depth: 0.1, origin_x: -0.195, origin_y: -0.195,
         boundary: absorbing, every: 2}
  water: {type: WaterCoupler, effects: [displacement, buoyancy, pressure, friction]}
connections:
  - granite.state -> water.body
  - pond.patch -> water.water
  - {from: water.wrench, to: granite.wrench, delay: 1, initial: {force: [0, 0, 0], torque: [0, 0, 0]}}
  - {from: water.occupied, to: pond.occupied, delay: 1, initial: {i0: 0, j0: 0, b: []}}
  - {from: water.request, to: pond.request, delay: 1, initial: {x_min: 1, x_max: 0, y_min: 1, y_max: 0}}
"""


def test_a_body_that_sinks_through_the_waters_bed_ends_the_run_naming_the_remedy():
    """The water's bed is no solid: a granite ball sinking in a pond without a ground went on
    through it (a stone ended 6 m under a 0.5 m pond). The run stops where the ball is wholly under
    the bed, saying where and what lands a body on it; with a ground at the bed it rests."""
    from cosim.scenario import loads
    from cosim.scheduler import Simulation

    through = Simulation(loads(SINKING_GRANITE))
    result = through.run()
    assert result.status == "stopped" and result.reason.startswith("water: the body went through the water's bed at ")
    assert result.reason.endswith("wholly under the bed at z = -0.1 m): the bed is not solid; to land the body on it, "
                                  "add a SolidGround there (as scenarios/float_sphere.yaml does)")
    assert 0.1 < result.time_ns / 1e9 < 0.5
    grounded = SINKING_GRANITE + """  - granite.state -> bed.body
  - {from: bed.impulse, to: granite.impulse, delay: 1, initial: {linear: [0, 0, 0], angular: [0, 0, 0],
                                                                   correction: [0, 0, 0]}}
""".replace("connections:", "")
    grounded = grounded.replace("connections:\n", "  bed: {type: SolidGround, point: [0, 0, -0.1], restitution: 0.2}\n"
                                "connections:\n", 1)
    sim = Simulation(loads(grounded))
    assert sim.run().status == "ok"
    assert sim.components["granite"].body_state().position[2] == pytest.approx(-0.08, abs=2e-3)


def test_a_body_under_another_gravity_than_its_coupler_and_monitor_is_refused():
    """The body's gravity changed alone (a lunar throw) left the coupler's buoyancy and the monitor's
    weight at 9.81: a pine ball floated 10% under instead of Archimedes' 60%. Each is refused,
    naming the key to set; the same gravity everywhere loads."""
    from cosim.errors import ScenarioError

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    with pytest.raises(ScenarioError) as info:
        load(scene, ["components.stone.gravity=[0, 0, -1.62]"])
    assert info.value.problems == [
        "components.coupler: g 9.81 m/s^2 is not the gravity of its body stone ([0.0, 0.0, -1.62] m/s^2): "
        "set g to 1.62",
        "components.stages: gravity 9.81 m/s^2 is not the gravity of its body stone ([0.0, 0.0, -1.62] m/s^2): "
        "set gravity to 1.62"]
    with pytest.raises(ScenarioError) as info:  # upwards: no value of g would do
        load(scene, ["components.stone.gravity=[0, 0, 9.81]"])
    assert info.value.problems[0] == ("components.coupler: g 9.81 m/s^2 needs its body stone to fall straight "
                                      "down (along -z) under as much gravity; its gravity is [0.0, 0.0, 9.81] m/s^2")
    load(scene, ["components.stone.gravity=[0, 0, -1.62]", "components.coupler.g=1.62",
                 "components.stages.gravity=1.62"])


def test_two_bodies_wired_to_one_waters_single_ports_are_told_to_name_them_in_bodies():
    """Two couplers on one pond's occupied and request inputs: refused, saying how several bodies
    share a water (it said only that the message type is not additive)."""
    import re

    from cosim.errors import ScenarioError
    from cosim.scenario import loads

    text = (Path(__file__).resolve().parents[1] / "scenarios" / "two_stones.yaml").read_text(encoding="utf-8")
    unnamed = re.sub(r"\n    bodies: \[left, right\][^\n]*", "", text)
    assert unnamed != text
    one_body = re.sub(r"\.(occupied|request|patch)_(left|right)", r".\1", unnamed)
    with pytest.raises(ScenarioError) as info:
        loads(one_body)
    occupied = [p for p in info.value.problems if p.startswith("connections: input pond.occupied is connected 2")]
    assert occupied and occupied[0].endswith("is not additive; for several bodies on one water, name them in its "
                                             "bodies: [a, b], each body's coupler then on its own ports occupied_a, "
                                             "request_a, patch_a, ... (scenarios/two_stones.yaml)")


def test_the_added_mass_connected_without_its_effect_is_said_as_the_scene_loads():
    """A coupler publishes no added mass without the effect (not in the default effects): the
    connection delivers only its initial zeros, which was silent. It is a notice, not a refusal:
    switching the effect off by --set leaves the connection, which then delivers nothing."""
    scene = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    off = load(scene, ["components.coupler.effects=[displacement, buoyancy, pressure, friction, wave_drag]"])
    assert off.notices == [
        "components.coupler: its output 'added_mass' feeds stone.added_mass, but it publishes none without the "
        "effect added_mass (not in the default effects); the connection delivers only its initial value"]
    assert load(scene).notices == []


def test_a_body_wider_than_its_water_is_refused():
    """A radius typed in centimetres (5 for 0.05 m) made a 10 m disk on a 3.5 m pond, which left
    the water with 5e7 J from a 20 J throw. Refused at load, saying how wide each is."""
    from cosim.errors import ScenarioError

    scene = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    with pytest.raises(ScenarioError) as info:
        load(scene, ["components.stone.radius=5"])
    assert info.value.problems == ["components.coupler: the body is 10 m across, wider than the water feeding it "
                                   "(3.5 m at its narrowest): is its radius in metres?"]


def test_a_level_disk_spinning_at_the_surface_feels_no_net_friction_either_way():
    """A level 6 mm disk, its lower face 1 mm under, spinning about its axis at +-100 rad/s: by symmetry
    its friction is a pure torque, equal and opposite for the two spins. The rim strips, wet below
    the surface and centred above it, slide along themselves (u.n = 0): their friction was scaled by
    the ventilation factor of a depth of 0, which is 1 at u.n = 0 and 0 at u.n = -1e-17, so half of
    them lost it by the sign of a rounding (a net 1e-3 N sideways, torques 0.2% apart)."""
    results = []
    for spin in (100.0, -100.0):
        b = body(position=(0.0, 0.0, -0.001 + 0.003), angular_velocity=(0.0, 0.0, spin))
        c = WaterCoupler("c", WaterCouplerParams(effects=["friction"]))
        results.append(c.step(0, DT_NS, {"body": b, "water": still_water(cell=0.005, half_width=0.2)})["wrench"])
    up, down = results
    assert np.abs(up.force).max() < 1e-12 and np.abs(down.force).max() < 1e-12
    assert up.torque[2] < 0.0 and down.torque[2] == pytest.approx(-up.torque[2], rel=1e-12)


@pytest.mark.parametrize("thickness", [0.006, 0.007, 0.015])
@pytest.mark.parametrize("azimuth", [0.0, 45.0])
def test_a_disk_standing_nearly_on_edge_is_buoyed_by_its_volume_wherever_it_stands_on_the_grid(thickness, azimuth):
    """A disk tilted 89.9 deg (nearly on edge), its axis along x or at 45 deg, its centre 1 cm under,
    moved across one 1 cm column in steps of 0.5 mm: its buoyancy is Archimedes' force within 7%
    everywhere (point samples across a slab a few millimetres wide: a line more or less). Its
    footprint is as narrow as it is thick, and the sub-samples, set from the radius alone (3 per
    column side), crossed it with one or two lines: the buoyancy read 0.56 to 1.11 of Archimedes'
    with where it stood."""
    from components.rigid import quaternion as quat

    r, depth = 0.05, 0.01
    q = quat.mul(tuple(axis_angle((0.0, 0.0, 1.0), math.radians(azimuth))),
                 tuple(axis_angle((0.0, 1.0, 0.0), math.radians(89.9))))
    # the face nearly upright: the circle's part under the surface, a chord 1 cm above its centre
    under = math.pi * r * r - (r * r * math.acos(depth / r) - depth * math.sqrt(r * r - depth * depth))
    archimedes = 1000.0 * 9.81 * under * thickness
    water = still_water(cell=0.01, half_width=0.4)
    for x in np.linspace(0.0, 0.01, 21):
        b = body(position=(float(x), 0.0, -depth), orientation=q, thickness=thickness)
        c = WaterCoupler("c", WaterCouplerParams(effects=["buoyancy"]))
        force = c.step(0, DT_NS, {"body": b, "water": water})["wrench"].force[2]
        assert force == pytest.approx(archimedes, rel=0.07), x


@pytest.mark.parametrize("direction", [(1.0, 0.0, 0.0), (0.0, 0.0, -1.0), (0.6, 0.0, 0.8)])
def test_a_body_wholly_under_water_has_its_whole_skin_friction(direction):
    """A 5 cm ball 0.3 m down moving at 2.1 m/s: no air reaches its back, so its skin friction is the
    whole of 1/2 rho C_f U^2 (8/3) pi R^2 (0.231 N; the integral of sin^2 over the sphere), in any
    direction. Its receding half was ventilated as a skipping stone's upper face is (a factor of its
    depth): 0.217 N, and the measured drag (its pressure drag C_D = 0.47 less this friction) was
    short by the difference."""
    r, speed = 0.05, 2.1
    u = speed * np.asarray(direction)
    ball = body(Shape.SPHERE, position=(0.0, 0.0, -0.3), velocity=u, radius=r, density=2700.0)
    c = WaterCoupler("c", WaterCouplerParams(effects=["friction"]))
    contact = c.step(0, DT_NS, {"body": ball, "water": still_water(cell=0.005, half_width=0.1)})["contact"]
    whole = 0.5 * 1000.0 * 0.005 * speed**2 * 8.0 / 3.0 * math.pi * r * r
    friction = np.asarray(contact.friction)
    assert float(np.linalg.norm(friction)) == pytest.approx(whole, rel=0.02)
    assert float(friction @ u) / (float(np.linalg.norm(friction)) * speed) == pytest.approx(-1.0, abs=1e-3)


def _sloped_water(slope: float, cell: float = 0.005, half_width: float = 0.25) -> HeightPatch:
    """A patch whose surface is the plane h = slope x (which bilinear sampling gives exactly)."""
    n = round(2 * half_width / cell)
    origin = -(n - 1) / 2 * cell
    x = origin + np.arange(n) * cell
    return HeightPatch(0, 0, cell, origin, origin, 0.0, np.tile(slope * x, (n, 1)), np.zeros((n, n)),
                       np.full((n, n), -1.0))


@pytest.mark.parametrize("slope", [0.0, 0.1, -0.1])
def test_a_face_on_a_sloping_surface_is_wetted_where_the_plane_covers_it(slope):
    """A held disk (R 5 cm, 6 mm) at 20 deg, 3.5 m/s, its lower face cut by the plane h = slope x:
    the wetted area the pressure acts on is the area of the face under that plane within 0.5%
    (counted exactly over 1,000,000 points of the face) at five depths. Each 6 mm square of the face
    read the surface at its centre and wetted its pieces against that level: on a slope of 0.1 the
    area was 3.7% short to 5% over."""
    radius, thickness, attack, speed = 0.05, 0.006, math.radians(20.0), 3.5
    velocity = np.array([speed * math.cos(attack), 0.0, -speed * math.sin(attack)])
    grid = (np.arange(1000) + 0.5) / 1000 * 2 * radius - radius
    gx, gy = np.meshgrid(grid, grid)
    inside = gx * gx + gy * gy <= radius * radius
    face = np.column_stack([gx[inside], gy[inside], np.full(inside.sum(), -thickness / 2)])
    axes = quat_to_matrix(pitched(attack))
    normal = -axes[:, 2]
    pressure = 0.5 * 1000.0 * speed * float(velocity @ normal)  # C_L = 1, C_N = 0: the planing law's
    for z in np.linspace(0.008, 0.012, 5):
        b = body(position=(0.0, 0.0, z), orientation=pitched(attack), velocity=tuple(velocity), radius=radius,
                 thickness=thickness)
        out = WaterCoupler("c", WaterCouplerParams(effects=["pressure"])).step(
            0, DT_NS, {"body": b, "water": _sloped_water(slope)})
        model = -float(np.asarray(out["contact"].pressure) @ normal) / pressure
        points = face @ axes.T + [0.0, 0.0, z]
        exact = float((points[:, 2] < slope * points[:, 0]).sum()) * (2 * radius / 1000) ** 2
        assert model == pytest.approx(exact, rel=5e-3)
