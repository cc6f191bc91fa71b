"""Summed water forces over columns and wetted elements (components.coupler.kernel) against closed forms.

All cases are hand-made: a BodyState in a given pose over a flat HeightPatch (still water at level 0).
"""

import math

import numpy as np
import pytest

from components.coupler import WaterCoupler, WaterCouplerParams
from components.coupler.fixtures import body, disk_at_depth, pitched, still_water
from components.coupler.forces import plate_force, segment_area
from components.coupler.kernel import smooth_conservative
from components.messages import Shape

RHO_G = 1000.0 * 9.81
R = 0.05
E = 0.006


def run(b, patch, **params):
    """One coupler step (1 us, so no stability bound interferes) at state b over patch."""
    c = WaterCoupler("c", WaterCouplerParams(**params))
    return c, c.step(0, 1000, {"body": b, "water": patch})


def cap_volume(radius, h):
    h = min(max(h, 0.0), 2 * radius)
    return math.pi * h * h * (3 * radius - h) / 3


@pytest.mark.parametrize("depth", [0.25 * R, 0.5 * R, R, 1.5 * R, 2.5 * R])
def test_archimedes_for_a_sphere_at_1cm(depth):
    """The summed column buoyancy of a sphere equals rho g V_cap within 2% on 1 cm columns."""
    b = body(Shape.SPHERE, position=(0.0013, -0.0021, R - depth), radius=R)
    _, out = run(b, still_water(0.01), effects=["buoyancy"])
    assert out["wrench"].force[2] == pytest.approx(RHO_G * cap_volume(R, depth), rel=0.02)
    assert np.abs(out["wrench"].force[:2]).max() == 0.0


def test_archimedes_converges_with_finer_columns():
    """With one sample per column, the buoyancy error shrinks as the columns get finer."""
    b = body(Shape.SPHERE, position=(0.0013, -0.0021, 0.3 * R), radius=R)
    exact = RHO_G * cap_volume(R, 0.7 * R)
    errors = []
    for cell in (0.02, 0.01, 0.005, 0.0025):
        _, out = run(b, still_water(cell), effects=["buoyancy"], column_subsamples=1)
        errors.append(abs(out["wrench"].force[2] / exact - 1))
    assert errors[-1] < 2e-3
    assert errors[-1] < errors[0] / 4


def test_fully_submerged_disk_buoyancy_is_rho_g_pi_r2_e():
    """A disk deep under water, at any tilt, is pushed up by rho g pi R^2 e with no torque."""
    for attack in (0.0, math.radians(30)):
        b = body(position=(0.002, 0.003, -0.1), orientation=pitched(attack))
        _, out = run(b, still_water(0.01), effects=["buoyancy"])
        assert out["wrench"].force[2] == pytest.approx(RHO_G * math.pi * R * R * E, rel=0.01)
        # the exact torque is zero; sampling leaves well under 1% of force x radius
        assert np.abs(out["wrench"].torque).max() < 0.01 * out["wrench"].force[2] * R


def test_tilted_floating_disk_gets_a_righting_torque():
    """A floating slab tilted by theta is turned back by about rho g tan(theta) pi R^4 cos^3(theta) / 4."""
    theta = math.radians(3)
    thick = 0.01
    # +x side down (rotation about +y); the water cuts both sides of the rim
    b = body(orientation=(math.cos(theta / 2), 0.0, math.sin(theta / 2), 0.0), thickness=thick)
    _, out = run(b, still_water(0.01), effects=["buoyancy"])
    analytic = RHO_G * math.tan(theta) * math.pi * R**4 * math.cos(theta) ** 3 / 4
    torque = out["wrench"].torque
    assert torque[1] < 0  # turns +x back up
    assert -torque[1] == pytest.approx(analytic, rel=0.08)
    assert abs(torque[0]) < 1e-6 * analytic


@pytest.mark.parametrize(("attack_deg", "impact_deg"), [(20, 20), (10, 15), (45, 10)])
@pytest.mark.parametrize("s_over_r", [0.1, 0.3, 0.6, 1.0, 1.5, 1.9])
def test_pressure_on_still_water_is_the_segment_law(attack_deg, impact_deg, s_over_r):
    """The summed pressure is 1/2 rho C_L U^2 S(s_f) sin(alpha + beta) within 3%, along the face normal."""
    alpha, beta, speed = math.radians(attack_deg), math.radians(impact_deg), 5.0
    s_f = s_over_r * R
    b = body(position=disk_at_depth(s_f * math.sin(alpha), alpha), orientation=pitched(alpha),
             velocity=(speed * math.cos(beta), 0.0, -speed * math.sin(beta)))
    _, out = run(b, still_water(0.01), effects=["pressure"])
    force = out["contact"].pressure
    expected = plate_force(1000.0, 1.0, speed, segment_area(R, s_f), alpha, beta)
    assert np.linalg.norm(force) == pytest.approx(expected, rel=0.03)
    normal = np.array([-math.sin(alpha), 0.0, math.cos(alpha)])  # the upper face's normal
    # along the face normal (the wetted front rim, past s_f = R, tilts it by well under a degree)
    assert force @ normal > math.cos(math.radians(1.0)) * np.linalg.norm(force)
    assert out["contact"].wetted_area >= segment_area(R, s_f) * 0.97


def test_pressure_torque_raises_the_trailing_edge():
    """The pressure acts behind the centre on a skipping disk, so its torque pitches the nose down."""
    alpha = math.radians(20)
    b = body(position=disk_at_depth(0.5 * R * math.sin(alpha), alpha), orientation=pitched(alpha),
             velocity=(5.0, 0.0, -1.0))
    _, out = run(b, still_water(0.01), effects=["pressure"])
    assert out["wrench"].torque[1] > 0  # about +y: front (+x) goes down


def test_newtonian_term_adds_rho_c_n_un2():
    """Switching C_N on adds 1/2 rho C_N (u.n)^2 S to a face pushed straight down (a slab piercing
    the surface, so the planing law holds)."""
    b = body(position=(0.0, 0.0, 0.0), velocity=(0.0, 0.0, -2.0), thickness=0.03)
    _, off = run(b, still_water(0.01), effects=["pressure"])
    _, on = run(b, still_water(0.01), effects=["pressure"], c_n=1.4)
    area = math.pi * R * R
    assert off["contact"].pressure[2] == pytest.approx(0.5 * 1000 * 4.0 * area, rel=1e-3)
    assert on["contact"].pressure[2] - off["contact"].pressure[2] == pytest.approx(
        0.5 * 1000 * 1.4 * 4.0 * area, rel=1e-3)


@pytest.mark.parametrize("speed", [1.0, 4.0])
def test_a_half_immersed_sphere_meets_the_water_as_a_blunt_body(speed):
    """A sphere half in still water moving along x at U feels the impact pressure 1/2 rho C_B (u.n)^2
    on its advancing lower quarter: a drag 1/2 rho U^2 R^2 C_B pi / 4 (a drag coefficient C_B / 2 on
    the immersed half-disk, 0.5 with C_B = 1: a sphere's is 0.47 at these Reynolds numbers) and a
    lift 1/2 rho U^2 R^2 C_B pi / 8; not the planing law of a disk's face (|u| (u.n): 4/3 and 2x
    as much)."""
    b = body(Shape.SPHERE, velocity=(speed, 0.0, 0.0), radius=R)
    _, out = run(b, still_water(0.01), effects=["pressure"])
    q = 0.5 * 1000 * speed * speed * R * R
    assert out["contact"].pressure[0] == pytest.approx(-q * math.pi / 4, rel=0.03)
    assert out["contact"].pressure[2] == pytest.approx(q * math.pi / 8, rel=0.03)
    _, doubled = run(b, still_water(0.01), effects=["pressure"], c_b=2.0)
    assert doubled["contact"].pressure == pytest.approx(2 * out["contact"].pressure, rel=1e-12)


def test_relative_velocity_uses_the_surface_velocity():
    """A disk at rest in water rising at V feels what a disk sinking at V in still water feels, on
    water so deep that the water at its lower face (5 mm down) rises as the surface does (on 1 m of
    water it rises 0.5% slower there: the long-wave profile, see
    test_a_submerged_disk_meets_the_water_moving_as_it_moves_at_its_depth)."""
    pos = (0.0, 0.0, -0.002)
    deep = still_water(0.01, surface_velocity=0.7, depth=1e5)
    _, rising = run(body(position=pos), deep, effects=["pressure"])
    _, sinking = run(body(position=pos, velocity=(0, 0, -0.7)), still_water(0.01, depth=1e5), effects=["pressure"])
    assert rising["contact"].pressure[2] > 0
    assert rising["contact"].pressure == pytest.approx(sinking["contact"].pressure, rel=1e-6)


def test_spin_changes_friction_but_not_pressure():
    """Spin about the disk's axis slides its faces along themselves: no pressure change, a braking torque."""
    alpha = math.radians(20)
    kw = {"position": disk_at_depth(0.02, alpha), "orientation": pitched(alpha), "velocity": (5.0, 0, -1.0)}
    axis = np.array([-math.sin(alpha), 0.0, math.cos(alpha)])
    _, still = run(body(**kw), still_water(0.01))
    _, spun = run(body(**kw, angular_velocity=tuple(400.0 * axis)), still_water(0.01))
    assert spun["contact"].pressure == pytest.approx(still["contact"].pressure, rel=1e-12)
    assert spun["wrench"].torque @ axis < still["wrench"].torque @ axis - 1e-3


def test_friction_on_a_sliding_face_is_half_rho_cf_u2_s():
    """A flat thin disk half-immersed sliding at U feels -1/2 rho C_f U^2 pi R^2 along the motion."""
    b = body(position=(0.0, 0.0, 0.0), velocity=(3.0, 0.0, 0.0), thickness=1e-5)
    _, out = run(b, still_water(0.01), effects=["friction"], c_f=0.1)
    assert out["contact"].friction[0] == pytest.approx(-0.5 * 1000 * 0.1 * 9.0 * math.pi * R * R, rel=1e-3)
    assert abs(out["contact"].friction[2]) < 1e-9


def test_wave_drag_needs_c_min():
    """A floating sphere pushed at 0.2 m/s makes no wave drag; at 1 m/s, the documented drag."""
    def drag(speed):
        b = body(Shape.SPHERE, velocity=(speed, 0.0, 0.0), radius=0.03)
        c, out = run(b, still_water(0.01), effects=["wave_drag"], c_w=0.3)
        return out["contact"].wave_drag, c
    assert np.all(drag(0.2)[0] == 0.0)
    force, _ = drag(1.0)
    volume = 2 / 3 * math.pi * 0.03**3
    c_min = (4 * 9.81 * 0.072 / 1000) ** 0.25
    froude2 = 1.0 / (9.81 * 0.06)
    expected = 0.5 * 1000 * 0.3 * volume / 0.06 * (1 - c_min**2) / (1 + froude2)
    assert force[0] == pytest.approx(-expected, rel=0.02)
    assert force[1] == 0.0


def test_a_stone_smaller_than_a_cell_still_floats():
    """A 3 mm sphere inside one 1 cm column feels its Archimedes force within 1%."""
    b = body(Shape.SPHERE, position=(0.0043, -0.0021, 0.0), radius=0.003)
    _, out = run(b, still_water(0.01), effects=["buoyancy"])
    assert out["wrench"].force[2] == pytest.approx(RHO_G * 2 / 3 * math.pi * 0.003**3, rel=0.01)


@pytest.mark.parametrize("mode", ["ring", "column"])
def test_displacement_conserves_the_submerged_volume(mode):
    """Sum b_ij s^2 equals the submerged volume (to round-off), which is the cap volume within 2%."""
    cell = 0.01
    b = body(Shape.SPHERE, position=(0.0013, -0.0021, 0.02), radius=R)
    _, out = run(b, still_water(cell), effects=["displacement"], displacement_mode=mode)
    occupied = out["occupied"]
    volume = out["contact"].submerged_fraction * 4 / 3 * math.pi * R**3
    assert occupied.b.sum() * cell * cell == pytest.approx(volume, rel=1e-12)
    assert volume == pytest.approx(cap_volume(R, R - 0.02), rel=0.02)
    assert occupied.b.min() >= 0


@pytest.mark.parametrize("rise", [-5e-4, 2e-4, 5e-4])
def test_ring_buoyancy_reads_the_level_of_the_water_around_the_body(rise):
    """With the ring displacement, a flat disk half immersed (3 mm) in water raised uniformly by
    ``rise`` is pushed up by rho g (V_rest + A_w rise): Archimedes' force against the rest level
    plus the rise over its waterline area, the same as under the raised surface itself."""
    b = body(position=(0.0013, -0.0021, 0.0))
    patch = still_water(0.01)
    raised = patch.replace(height=patch.height + rise)
    _, flat = run(b, patch, effects=["displacement", "buoyancy"])
    _, ring = run(b, raised, effects=["displacement", "buoyancy"])
    _, local = run(b, raised, effects=["buoyancy"])  # no displacement: the surface under the body
    area = math.pi * R * R
    assert flat["wrench"].force[2] == pytest.approx(RHO_G * area * 0.5 * E, rel=0.01)
    assert ring["wrench"].force[2] - flat["wrench"].force[2] == pytest.approx(RHO_G * area * rise, rel=0.01)
    assert ring["wrench"].force[2] == pytest.approx(local["wrench"].force[2], rel=1e-12)


def test_ring_displacement_lies_outside_the_body():
    """In ring mode the displaced water goes to columns outside the body's outline, none under it, and
    no further out than the band reaches (twice its half-width, half the radius: one radius)."""
    cell = 0.01
    b = body(Shape.SPHERE, position=(0.0, 0.0, 0.0), radius=R)
    patch = still_water(cell)
    _, out = run(b, patch, effects=["displacement"])
    occ = out["occupied"]
    jj, ii = np.nonzero(occ.b)
    x = patch.origin_x + (occ.i0 + ii) * cell
    y = patch.origin_y + (occ.j0 + jj) * cell
    r = np.hypot(x, y)
    assert r.min() > R and r.max() < 2.0 * R
    assert r.max() > 2.0 * R - 1.5 * cell  # the band reaches that far


def test_a_body_covering_the_whole_window_keeps_its_displaced_volume_in_place():
    """With no water around the body in the window (a disk wider than the patch) the ring has no band
    to push into: each column keeps its own volume, exactly (its shares once divided by zero)."""
    cell = 0.01
    b = body(position=(0.0, 0.0, 0.0), radius=1.0)  # 2 m across, over a 30 cm patch
    _, out = run(b, still_water(cell), effects=["displacement"])
    occ = out["occupied"]
    assert occ.b.shape == (30, 30) and np.all(occ.b == pytest.approx(0.5 * E, rel=1e-12))


def test_skipping_disk_pushes_water_from_its_wet_trailing_edge():
    """A pitched disk wet only at its trailing edge displaces water behind its centre, not ahead."""
    cell = 0.01
    alpha = math.radians(20)
    patch = still_water(cell)
    b = body(position=disk_at_depth(0.01, alpha), orientation=pitched(alpha))
    _, out = run(b, patch, effects=["displacement"])
    occ = out["occupied"]
    jj, ii = np.nonzero(occ.b)
    x = patch.origin_x + (occ.i0 + ii) * cell
    weights = occ.b[jj, ii]
    assert (weights * x).sum() / weights.sum() < -0.03


def test_smoothing_keeps_the_volume():
    """Conservative [1,2,1] smoothing spreads b without changing its sum."""
    rng = np.random.default_rng(1)
    b = rng.random((9, 7))
    total = b.sum()
    smooth_conservative(b, 3)
    assert b.sum() == pytest.approx(total, rel=1e-14)


@pytest.mark.parametrize(("effect", "tolerance"),
                         [("buoyancy", 0.015), ("pressure", 0.005), ("friction", 0.005)])
def test_forces_are_smooth_as_the_body_crosses_cells(effect, tolerance):
    """Moving a wet disk by 0.2 mm steps across 2 cm of 1 cm columns over a wavy surface changes its
    force by less than the tolerance per step (no jump when a rim or waterline crosses a cell)."""
    alpha = math.radians(20)
    z = disk_at_depth(0.5 * R * math.sin(alpha), alpha)[2]
    patch = still_water(0.01)
    n = patch.height.shape[0]
    x, y = np.meshgrid(patch.origin_x + np.arange(n) * 0.01, patch.origin_y + np.arange(n) * 0.01)
    patch = patch.replace(height=0.001 * np.sin(2 * np.pi * x / 0.07) * np.cos(2 * np.pi * y / 0.09))
    c = WaterCoupler("c", WaterCouplerParams(effects=[effect]))
    series = []
    for k, xb in enumerate(np.arange(0.0, 0.02, 2e-4)):
        b = body(position=(xb, 0.0023, z), orientation=pitched(alpha), velocity=(5.0, 0.0, -1.5))
        out = c.step(k * 1000, 1000, {"body": b, "water": patch})
        series.append(np.linalg.norm(out["wrench"].force))
    series = np.array(series)
    assert series.min() > 0
    assert np.abs(np.diff(series)).max() < tolerance * series.mean()


@pytest.mark.parametrize("velocity", [(1.0, 0.3, -0.7), (0.2, -1.1, 0.4)])
def test_the_drag_on_a_submerged_sphere_does_not_turn_it(velocity):
    """The water's pressure is normal to a sphere's surface, so its drag passes through the centre.
    Taken at each surface element, the drag along -u left a torque of 5e-4 to 8e-4 of the drag
    times the radius (the elements' tiling is not symmetric about a slanting motion): enough to set
    float_sphere's granite ball turning while it sank under moving water."""
    b = body(Shape.SPHERE, position=(0.0013, -0.0021, -0.2), radius=0.03, velocity=velocity)
    _, out = run(b, still_water(0.01), effects=["pressure"])
    force = np.asarray(out["wrench"].force)
    assert force @ np.asarray(velocity) < 0.0
    assert np.linalg.norm(out["wrench"].torque) <= 1e-12 * np.linalg.norm(force) * 0.03


def test_a_submerged_spheres_drag_and_skin_friction_make_its_measured_drag_coefficient():
    """A sphere moving at 1.5 m/s under water feels, from the pressure and friction effects together,
    the drag of the measured total C_D = 0.47 (within the elements' sampling, 1%): 1/2 rho 0.47 U^2
    pi R^2. The pressure drag took the whole 0.47, and the friction added 8/3 C_f = 0.013 over it
    (2.8%: a granite ball sank 1.4% slower than its measured drag gives)."""
    speed, radius = 1.5, 0.03
    b = body(Shape.SPHERE, position=(0.0013, -0.0021, -0.2), radius=radius, velocity=(speed, 0.0, 0.0))
    _, out = run(b, still_water(0.01), effects=["pressure", "friction"])
    drag = -(np.asarray(out["contact"].pressure)[0] + np.asarray(out["contact"].friction)[0])
    assert drag == pytest.approx(0.5 * 1000 * 0.47 * speed**2 * math.pi * radius**2, rel=0.01)


@pytest.mark.parametrize("down", [0.05, 0.2, 0.35])
def test_a_submerged_disk_meets_the_water_moving_as_it_moves_at_its_depth(down):
    """Under a surface rising at W on water 0.4 m deep, the water at height z above the bed rises at
    W z / 0.4 (the long-wave profile). A thin disk held level and still, its lower face ``down``
    under, is pushed up by that water's drag alone: 1/2 rho C_D (W (1 - down / 0.4))^2 pi R^2, its
    upper face meeting no oncoming water (the surface's own speed at every depth pushed the disk on
    the bed as hard as one just under the surface)."""
    w, depth, e = 0.5, 0.4, 1e-3
    b = body(position=(0.0013, -0.0021, -down + 0.5 * e), thickness=e)
    _, out = run(b, still_water(0.01, surface_velocity=w, depth=depth), effects=["pressure"])
    force = np.asarray(out["contact"].pressure)
    expected = 0.5 * 1000 * 1.17 * (w * (1.0 - down / depth)) ** 2 * math.pi * R * R
    assert force[2] == pytest.approx(expected, rel=0.02)
    assert np.abs(force[:2]).max() < 1e-9 * force[2]


@pytest.mark.parametrize("attack_deg", [0, 20])
def test_a_wholly_submerged_disk_feels_pressure_drag_not_planing_lift(attack_deg):
    """Under water the pressure is the drag 1/2 rho C_D |u| u A_projected along -u: a thin disk
    pushed face-on at 2 m/s feels C_D = 1.17 of it, and one gliding forward at an attack angle is
    slowed without being lifted (its force has no component across its motion)."""
    alpha = math.radians(attack_deg)
    speed = 2.0
    if attack_deg == 0:
        velocity = (0.0, 0.0, -speed)
    else:
        velocity = (speed, 0.0, 0.0)
    b = body(position=(0.0, 0.0, -0.05), orientation=pitched(alpha), velocity=velocity, thickness=1e-3)
    _, out = run(b, still_water(0.01), effects=["pressure"])
    force = np.asarray(out["contact"].pressure)
    u = np.asarray(velocity) / speed
    projected = np.pi * R * R * abs(math.cos(alpha) * u[2] - math.sin(alpha) * u[0]) + 2 * R * 1e-3 * abs(
        math.cos(alpha) * u[0] + math.sin(alpha) * u[2])
    assert force @ -u == pytest.approx(0.5 * 1000 * 1.17 * speed**2 * projected, rel=0.05)
    assert np.linalg.norm(force - (force @ u) * u) < 1e-9 * np.linalg.norm(force)
