"""The coupler's one-call step (components.coupler.step_kernel) against the separate kernels it
replaces: the same stats, ring window, lifted levels, top depth and stability bound, bit for bit,
for floating, planing and sunk bodies over still and wavy water, with and without the occupied
height the patch holds."""

import math
from typing import NamedTuple

import numpy as np
import pytest

from components.coupler import WaterCoupler, kernel, step_kernel
from components.coupler.fixtures import body, disk_at_depth, pitched, still_water
from components.coupler.geometry import Elements
from components.coupler.met_surface import MetSurface, planing_share
from components.messages import HeightPatch, Shape

ALPHA = math.radians(20)


def wavy(patch: HeightPatch, amplitude: float, with_held: bool) -> HeightPatch:
    """``patch`` with a ripple on its surface and velocity, and (optionally) an occupied height held."""
    nj, ni = patch.height.shape
    jj, ii = np.mgrid[0:nj, 0:ni]
    ripple = amplitude * np.sin(0.7 * ii + 0.3 * jj)
    held = np.where((ii + jj) % 3 == 0, 0.2 * amplitude, 0.0) if with_held else np.zeros((0, 0))
    return HeightPatch(patch.i0, patch.j0, patch.cell, patch.origin_x, patch.origin_y, patch.rest_level,
                       patch.height + ripple, 0.5 * ripple, patch.bottom, held)


BODIES = {
    "floating ball": body(Shape.SPHERE, position=(0.003, -0.002, 0.0), velocity=(0.3, 0.1, -0.05),
                          density=500.0),
    "planing disk": body(position=disk_at_depth(0.008, ALPHA), orientation=pitched(ALPHA),
                         velocity=(5.0, 0.2, -1.3), angular_velocity=(0.0, 0.0, 60.0)),
    "sunk disk": body(position=(0.01, 0.0, -0.05), orientation=pitched(0.3), velocity=(0.2, 0.0, -0.4)),
    "disk above the rest level": body(position=(0.0, 0.0, 0.012), velocity=(1.0, 0.0, -0.5)),
    # its displaced water spread over its depth (kernel.depth_spread), within the patch and past its edge
    "disk just under": body(position=(0.002, 0.001, -0.0045), velocity=(0.5, 0.0, -0.3)),
    "sunk ball": body(Shape.SPHERE, position=(-0.004, 0.003, -0.08), radius=0.02, velocity=(0.1, 0.2, -0.3)),
}


class _Inputs(NamedTuple):
    body_vector: np.ndarray
    axes: np.ndarray
    low: tuple[float, float, float]
    half: tuple[float, float]
    water: tuple
    elements: Elements
    nsub: int


def _inputs(coupler: WaterCoupler, b, patch: HeightPatch) -> _Inputs:
    """What _advance hands to either path for body ``b`` over ``patch``."""
    coupler.cell = patch.cell
    coupler._planing_share = planing_share(b, coupler.params.g)
    bv = coupler._body_vector(b)
    axes = np.empty((3, 3))
    x_low, y_low, z_low, hx, hy = step_kernel.body_pose(int(b.shape), bv, axes)
    x0 = patch.origin_x + patch.i0 * patch.cell
    y0 = patch.origin_y + patch.j0 * patch.cell
    held = patch.occupied if patch.occupied.shape == patch.height.shape else None
    water = (x0, y0, patch.cell, patch.height, patch.velocity, patch.bottom, held)
    return _Inputs(bv, axes, (x_low, y_low, z_low), (hx, hy), water, coupler._elements_for(b),
                   coupler._subsamples(b, patch.cell))


def _separate(coupler: WaterCoupler, b, patch: HeightPatch):
    """The separate kernels, as _advance calls them for a substepped step: (stats, ring, the top's
    depth, the bound)."""
    x = _inputs(coupler, b, patch)
    coupler._b_geo = np.zeros(patch.height.shape)
    stats = coupler._evaluate(b, b.position, b.velocity, b.angular_velocity, x.axes, x.half, x.low, x.water,
                              x.elements, x.nsub, coupler._b_geo, np.zeros_like(coupler._stats),
                              coupler._local, *coupler._immersion(b.position, x.low, x.water))
    ring = coupler._ring(b, b.position, x.axes, x.half, x.low, x.water, x.elements, x.nsub)
    coupler._add_hydrostatics(stats, ring, int(b.shape) == kernel.SHAPE_SPHERE)
    return stats, ring, coupler._top_under(b.position, x.low, x.water), coupler._stability_bound(b, stats)


def _fused_step(coupler: WaterCoupler, b, patch: HeightPatch, dt: float = 5e-4):
    """One usual step of ``coupler`` (its one-call path) on body ``b`` over ``patch``: its outputs."""
    coupler.cell = patch.cell
    coupler._prev = None
    return coupler._ring_advance(b, coupler._body_vector(b), patch, dt)


def _check_fused_against_separate(fused: WaterCoupler, b, patch: HeightPatch) -> None:
    """The messages of one fused step carry what the separate kernels compute, bit for bit: the
    wrench (the stats' total), each effect's force, the submerged fraction's top test, the ring's
    window, the bound, and the body's axes, lowest point, half-extents and top depth."""
    stats_ref, ring_ref, under_ref, bound_ref = _separate(WaterCoupler("reference"), b, patch)
    out = _fused_step(fused, b, patch)
    x = _inputs(WaterCoupler("pose"), b, patch)
    np.testing.assert_array_equal(fused._scratch.axes, x.axes)
    pose = fused._scratch.numbers[step_kernel.NUM_POSE:step_kernel.NUM_POSE + step_kernel.N_POSE].tolist()
    assert (tuple(pose[:3]), tuple(pose[3:])) == (x.low, x.half)
    under = float(fused._scratch.results[step_kernel.R_TOP_UNDER])
    assert (math.isnan(under) and under_ref is None) or under == under_ref
    np.testing.assert_array_equal(fused._scratch.stats, stats_ref)
    np.testing.assert_array_equal(fused._scratch.rest_stats, ring_ref.rest)
    np.testing.assert_array_equal(fused._scratch.lifted, ring_ref.lifted)
    assert fused.bound == bound_ref
    total = step_kernel.kernel.S_TOTAL
    wrench, contact, occupied = out["wrench"], out["contact"], out["occupied"]
    if contact.wetted or ring_ref.rest[step_kernel.kernel.S_VOLUME] > 0.0:
        np.testing.assert_array_equal(wrench.force, stats_ref[total:total + 3])
        np.testing.assert_array_equal(wrench.torque, stats_ref[total + 3:total + 6])
        for name, at in (("buoyancy", 0), ("pressure", 6), ("friction", 12), ("wave_drag", 18)):
            np.testing.assert_array_equal(getattr(contact, name), stats_ref[at:at + 3])
        assert contact.wetted_area == stats_ref[step_kernel.kernel.S_AREA]
        if under_ref is not None and under_ref > 0.0 and contact.wetted:
            assert contact.submerged_fraction == 1.0
    if ring_ref.window is None:
        assert occupied.b.size == 0
    else:
        i_lo, j_lo, window = ring_ref.window
        assert (occupied.i0, occupied.j0) == (patch.i0 + i_lo, patch.j0 + j_lo)
        np.testing.assert_array_equal(occupied.b, window)


@pytest.mark.parametrize("with_held", [False, True])
@pytest.mark.parametrize("amplitude", [0.0, 0.004])
@pytest.mark.parametrize("name", list(BODIES))
def test_one_call_step_equals_the_separate_kernels(name, amplitude, with_held):
    """the body's pose, stats, the ring's window and levels, the top's depth and the bound are those
    of the separate kernels, bit for bit, and so are the messages built from them."""
    b = BODIES[name]
    patch = wavy(still_water(half_width=0.12), amplitude, with_held)
    _check_fused_against_separate(WaterCoupler("fused"), b, patch)


def test_one_call_steps_in_a_row_leave_nothing_behind():
    """The fused step keeps its work planes from step to step and clears only the columns it wrote
    last: through a run of steps with the body moving and sinking, the window sliding over the
    water's grid and the surface changing, every step equals a fresh evaluation, bit for bit (a
    column left over from an earlier step would show as a wrong volume, deposit or level)."""
    fused = WaterCoupler("fused")
    order = ["planing disk", "sunk disk", "disk above the rest level", "floating ball", "planing disk",
             "sunk disk", "planing disk"]
    for step, name in enumerate(order):
        b = BODIES[name]
        shift = (0.013 * step, -0.007 * step, 0.0)
        b = b.replace(position=np.asarray(b.position) + shift)
        patch = wavy(still_water(half_width=0.12, centre=shift[:2], i0=3 * step, j0=10 - step),
                     0.002 * (step % 3), step % 2 == 1)
        fused.met = MetSurface()  # read the live surface, as the reference does
        _check_fused_against_separate(fused, b, patch)


def test_a_step_above_the_rest_level_leaves_nothing_behind():
    """A step with the body wholly above the rest level (no pass under it) between two steps with
    it under the rest level, its columns elsewhere in the same window: each step equals a fresh
    evaluation, bit for bit (what the first step left under the rest level must not reach the
    third)."""
    fused = WaterCoupler("fused")
    patch = still_water(half_width=0.12)
    sunk = BODIES["sunk disk"]
    above = BODIES["disk above the rest level"]
    above = above.replace(position=np.asarray(above.position) + np.array([0.06, 0.05, 0.0]))
    for b in (sunk, above, BODIES["planing disk"]):  # the last one under the rest level by 8 mm only
        fused.met = MetSurface()
        _check_fused_against_separate(fused, b, patch)


def _read_with_numpy(met, i0, j0, height, velocity, share):
    """The met surface's read as numpy slices (its first form): the reference for the compiled one."""
    if not met["in_contact"] or met["met"] is None:
        met["met"] = (i0, j0, height, velocity)
        return height, velocity
    mi0, mj0, m_h, m_v = met["met"]
    nj, ni = height.shape
    ia, ib = max(i0, mi0), min(i0 + ni, mi0 + m_h.shape[1])
    ja, jb = max(j0, mj0), min(j0 + nj, mj0 + m_h.shape[0])
    h, v = height.copy(), velocity.copy()
    if ia < ib and ja < jb:
        h[ja - j0:jb - j0, ia - i0:ib - i0] = m_h[ja - mj0:jb - mj0, ia - mi0:ib - mi0]
        v[ja - j0:jb - j0, ia - i0:ib - i0] = m_v[ja - mj0:jb - mj0, ia - mi0:ib - mi0]
    met["met"] = (i0, j0, h, v)
    if share < 1.0:
        h = share * h + (1.0 - share) * height
        v = share * v + (1.0 - share) * velocity
    return h, v


def test_met_surface_read_is_the_numpy_form():
    """While in contact, the met surface hands back the window frozen at first contact (columns new
    to the window live), blended by the planing share, as the numpy form does, bit for bit, however
    often its work arrays turn over and whichever way the window moves."""
    met, reference = MetSurface(), {"in_contact": False, "met": None}
    rng = np.random.default_rng(1)
    for step, (di, dj, share) in enumerate([(0, 0, 1.0), (1, 0, 1.0), (2, -1, 0.3), (3, 1, 1.0),
                                            (1, 2, 0.0), (-2, 0, 0.9), (40, 0, 1.0)]):
        live = still_water(half_width=0.05, i0=5 + di, j0=5 + dj)
        height, velocity = rng.standard_normal((2, *live.height.shape))
        got = met.read(live.i0, live.j0, height, velocity, share)
        want = _read_with_numpy(reference, live.i0, live.j0, height, velocity, share)
        np.testing.assert_array_equal(got[0], want[0])
        np.testing.assert_array_equal(got[1], want[1])
        met.in_contact = reference["in_contact"] = step >= 0


def test_the_met_surface_made_in_the_step_is_the_one_read_before_it():
    """In contact, the usual step makes the met surface inside its one compiled call
    (``MetSurface.plan`` then ``step_kernel.met_ring_step``): through a run of steps with the window
    moving and the planing share below and at 1, every number and plane it writes equals
    ``MetSurface.read`` followed by ``ring_step``, bit for bit, and the met surface it leaves is the
    same."""
    coupler = WaterCoupler("fused")
    b = BODIES["planing disk"]
    planned, read = MetSurface(), MetSurface()
    rng = np.random.default_rng(7)
    for step, (di, dj, share) in enumerate([(0, 0, 1.0), (1, 0, 0.999), (3, -1, 1.0), (4, 1, 0.3), (6, 0, 1.0)]):
        live = wavy(still_water(half_width=0.12, i0=5 + di, j0=5 + dj), 0.003, step % 2 == 0)
        height = live.height + 1e-4 * rng.standard_normal(live.height.shape)
        velocity = live.velocity + 1e-3 * rng.standard_normal(live.height.shape)
        held = live.occupied if live.occupied.shape == height.shape else height
        x = _inputs(coupler, b, live)
        elements = x.elements
        outputs = []
        for met, fused in ((planned, True), (read, False)):
            scratch = step_kernel.RingScratch(height.shape, 0.0)
            common = (int(b.shape), x.body_vector, coupler._prm_disk, coupler.flags, coupler._local, x.nsub,
                      0.0, share, x.water[0], x.water[1], live.cell)
            tail = (height, velocity, live.bottom, held, held is not height, elements.pos, elements.nrm,
                    elements.area, elements.t1, elements.t2, elements.sub, elements.whole, elements.world_fixed,
                    scratch.planes,
                    scratch.numbers, scratch.work_for(elements.area.shape[0]))
            if fused:
                freeze, mi0, mj0, m_h, m_v, fr_h, fr_v, met_h, met_v = met.plan(live.i0, live.j0, height,
                                                                                 velocity, share)
                step_kernel.met_ring_step(freeze, live.i0, live.j0, mi0, mj0, m_h, m_v, fr_h, fr_v,
                                          *common, met_h, met_v, *tail)
            else:
                met_h, met_v = met.read(live.i0, live.j0, height, velocity, share)
                step_kernel.ring_step(*common, met_h, met_v, *tail)
            outputs.append((scratch.numbers.copy(), scratch.planes.copy(), met_h.copy(), met_v.copy()))
            met.in_contact = True
        for got, want in zip(*outputs, strict=True):
            np.testing.assert_array_equal(got, want)
        assert planned._met[:2] == read._met[:2]
        np.testing.assert_array_equal(planned._met[2], read._met[2])
        np.testing.assert_array_equal(planned._met[3], read._met[3])
