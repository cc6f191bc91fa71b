"""The coupler's one-call step (components.coupler.step_kernel) against the separate kernels it
replaces: the same stats, ring window, lifted levels, top depth and stability bound, bit for bit,
for floating, planing and sunk bodies over still and wavy water, with and without the occupied
height the patch holds."""

import math
from typing import NamedTuple

import numpy as np
import pytest

from components.coupler import WaterCoupler, step_kernel
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
                   coupler._subsamples(float(b.radius), patch.cell))


def _separate(coupler: WaterCoupler, b, patch: HeightPatch):
    """The separate kernels, as _advance calls them for a substepped step: (stats, ring, the top's
    depth, the bound)."""
    x = _inputs(coupler, b, patch)
    coupler._b_geo = np.zeros(patch.height.shape)
    stats = coupler._evaluate(b, b.position, b.velocity, b.angular_velocity, x.axes, x.half, x.low, x.water,
                              x.elements, x.nsub, coupler._b_geo, np.zeros_like(coupler._stats),
                              coupler._local_flags())
    ring = coupler._ring(b, b.position, x.axes, x.half, x.low, x.water, x.elements, x.nsub)
    coupler._add_hydrostatics(stats, ring)
    return stats, ring, coupler._top_under(b.position, x.low, x.water), coupler._stability_bound(b, stats)


@pytest.mark.parametrize("with_held", [False, True])
@pytest.mark.parametrize("amplitude", [0.0, 0.004])
@pytest.mark.parametrize("name", list(BODIES))
def test_one_call_step_equals_the_separate_kernels(name, amplitude, with_held):
    """the body's pose, stats, the ring's window and levels, the top's depth and the bound are those
    of the separate kernels, bit for bit."""
    b = BODIES[name]
    patch = wavy(still_water(half_width=0.12), amplitude, with_held)
    stats_ref, ring_ref, under_ref, bound_ref = _separate(WaterCoupler("reference"), b, patch)
    fused = WaterCoupler("fused")
    x = _inputs(fused, b, patch)
    stats, ring, under, axes, low, half = fused._ring_step(b, x.body_vector, x.water, x.water, x.elements,
                                                           x.nsub)
    np.testing.assert_array_equal(axes, x.axes)
    assert (low, half) == (x.low, x.half)
    np.testing.assert_array_equal(stats, stats_ref)
    np.testing.assert_array_equal(ring.lifted, ring_ref.lifted)
    np.testing.assert_array_equal(ring.rest, ring_ref.rest)
    assert (ring.window is None) == (ring_ref.window is None)
    if ring.window is not None:
        assert ring.window[:2] == ring_ref.window[:2]
        np.testing.assert_array_equal(ring.window[2], ring_ref.window[2])
    assert under == under_ref
    assert fused.bound == bound_ref


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
