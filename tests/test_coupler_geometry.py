"""Geometry of the water coupler: chords, partial wetting, surface tilings (components.coupler.geometry)."""

import math

import numpy as np
import pytest

from components.coupler.fixtures import axis_angle
from components.coupler.geometry import (
    FACE_SUBDIVISION,
    _face_squares,
    _numpy_sum,
    box_coverage,
    box_density,
    disk_chord,
    disk_elements,
    disk_half_extents,
    lowest_point,
    quat_to_matrix,
    sphere_chord,
    sphere_elements,
)


@pytest.mark.parametrize(("w1", "w2"), [(0.0, 1.0), (0.3, 1.0), (1.0, 1.0), (0.02, 0.5)])
def test_box_coverage_is_a_cdf_with_the_right_mean(w1, w2):
    """Coverage rises monotonically from 0 to 1 and integrates to the element's mean height (zero)."""
    t = np.linspace(-1.0, 1.0, 20001)
    c = np.array([box_coverage(x, w1, w2) for x in t])
    assert c[0] == 0.0 and c[-1] == 1.0
    assert np.all(np.diff(c) >= 0)
    # E[X] = int (1 - F) - int F over the two half lines = 0 for a symmetric distribution
    assert np.trapezoid(1 - c[t > 0], t[t > 0]) == pytest.approx(np.trapezoid(c[t < 0], t[t < 0]), abs=1e-6)


def test_box_density_is_the_derivative_of_the_coverage():
    """box_density matches a finite difference of box_coverage."""
    for t in np.linspace(-0.6, 0.6, 37):
        fd = (box_coverage(t + 1e-7, 0.4, 0.9) - box_coverage(t - 1e-7, 0.4, 0.9)) / 2e-7
        assert box_density(t, 0.4, 0.9) == pytest.approx(fd, abs=1e-5)


def test_box_coverage_sums_a_straight_waterline_exactly():
    """Unit squares tiled along a sloped plane and wetted by coverage give the exact wetted length."""
    slope = 0.37
    level = 0.123
    xs = np.arange(-50, 50) + 0.5
    # z = slope * x across each unit square: height range slope (along x) and 0 (along y)
    wet = sum(box_coverage(level - slope * x, slope, 0.0) for x in xs)
    assert wet == pytest.approx(50 + level / slope, rel=1e-12)


def _brute_chord(dx, dy, axis, radius, thickness):
    z = np.linspace(-0.2, 0.2, 400001)
    p = np.stack([np.full_like(z, dx), np.full_like(z, dy), z], axis=1)
    s = p @ axis
    radial = np.linalg.norm(p - np.outer(s, axis), axis=1)
    inside = (np.abs(s) <= thickness / 2) & (radial <= radius)
    if not inside.any():
        return None
    return z[inside].min(), z[inside].max()


@pytest.mark.parametrize("tilt_deg", [0.0, 20.0, 60.0, 90.0])
def test_disk_chord_matches_a_brute_force_scan(tilt_deg):
    """The vertical extent of a tilted disk equals a dense point-membership scan along the line."""
    axis = quat_to_matrix(axis_angle((0.3, 1.0, 0.0), math.radians(tilt_deg)))[:, 2]
    for dx, dy in [(0.0, 0.0), (0.02, -0.01), (0.045, 0.004), (-0.03, 0.035), (0.07, 0.0)]:
        lo, hi = disk_chord(dx, dy, *axis, 0.05, 0.006)
        ref = _brute_chord(dx, dy, axis, 0.05, 0.006)
        if ref is None:
            assert lo >= hi
        else:
            assert lo == pytest.approx(ref[0], abs=2e-6)
            assert hi == pytest.approx(ref[1], abs=2e-6)


def test_sphere_chord():
    """A sphere's chord at offset r is +-sqrt(R^2 - r^2), empty outside."""
    assert sphere_chord(0.03, 0.04, 0.1) == pytest.approx((-math.sqrt(0.0075), math.sqrt(0.0075)))
    lo, hi = sphere_chord(0.1, 0.0, 0.1)
    assert lo >= hi


def test_disk_tiling_has_the_disk_area_and_no_first_moment():
    """Each face tiles to pi R^2 with its centroid at the centre; the rim to 2 pi R e."""
    el = disk_elements(0.05, 0.006, across=16, rim=48)
    faces = el.nrm[:, 2] != 0
    for sign in (1.0, -1.0):
        face = el.nrm[:, 2] == sign
        assert el.area[face].sum() == pytest.approx(math.pi * 0.05**2, rel=1e-12)
        assert np.abs(el.area[face] @ el.pos[face, :2]).max() < 1e-12
    assert el.area[~faces].sum() == pytest.approx(2 * math.pi * 0.05 * 0.006, rel=1e-12)
    assert not el.world_fixed


def _face_squares_by_numpy(radius, across, oversample):
    """The face squares as numpy's array calls define them (each mean a ``mean`` of the inside
    points): the oracle the compiled pass must match bit for bit."""
    m = FACE_SUBDIVISION
    side = 2.0 * radius / across
    sub = (np.arange(oversample) + 0.5) / oversample * side
    k = oversample // m
    us, vs, areas, pieces = [], [], [], []
    for i in range(across):
        for j in range(across):
            gx, gy = np.meshgrid(-radius + i * side + sub, -radius + j * side + sub, indexing="ij")
            inside = gx * gx + gy * gy <= radius * radius
            count = int(inside.sum())
            if count == 0:
                continue
            u0, v0 = float(gx[inside].mean()), float(gy[inside].mean())
            piece = np.zeros((m * m, 3))
            for a in range(m):
                for b in range(m):
                    block = (slice(a * k, (a + 1) * k), slice(b * k, (b + 1) * k))
                    mask = inside[block]
                    if mask.any():
                        piece[a * m + b] = (gx[block][mask].mean() - u0, gy[block][mask].mean() - v0,
                                            mask.sum() / count)
            us.append(u0)
            vs.append(v0)
            areas.append(count / oversample**2 * side * side)
            pieces.append(piece)
    return np.array(us), np.array(vs), np.array(areas), np.array(pieces)


@pytest.mark.parametrize(("radius", "across", "oversample"),
                         [(0.05, 16, 16), (0.025, 16, 16), (0.037, 12, 8), (0.05, 16, 32), (0.03, 5, 4)])
def test_the_compiled_face_tiling_is_numpys_to_the_bit(radius, across, oversample):
    """The compiled pass over a disk face's squares gives the very numbers numpy's means gave (so
    every run that tiles a disk is the same, bit for bit), summing as numpy's pairwise sum does."""
    got = _face_squares(radius, across, oversample, FACE_SUBDIVISION)
    want = _face_squares_by_numpy(radius, across, oversample)
    for g, w in zip(got, want, strict=True):
        assert g.shape == w.shape and np.array_equal(g, w)


def test_numpys_sum_is_matched_to_the_bit_at_every_length():
    """Runs of 1 to 300 values and longer (numpy halves a run past 128), with wide magnitudes, from
    any start: the same bits as numpy.add.reduce and numpy's mean."""
    rng = np.random.default_rng(3)
    for n in [*range(1, 300), 511, 1025, 4096]:
        values = rng.standard_normal(n + 3) * 10.0 ** rng.integers(-6, 6, n + 3)
        run = values[3:]
        assert _numpy_sum(values, 3, n) == np.add.reduce(run), n
        assert _numpy_sum(values, 3, n) / n == run.mean(), n


def test_sphere_tiling_has_the_sphere_area_and_unit_normals():
    """The latitude bands tile to 4 pi R^2 with unit outward normals."""
    el = sphere_elements(0.03, bands=24)
    assert el.area.sum() == pytest.approx(4 * math.pi * 0.03**2, rel=1e-12)
    assert np.allclose(np.linalg.norm(el.nrm, axis=1), 1.0)
    assert np.allclose(el.pos, 0.03 * el.nrm)


@pytest.mark.parametrize("bands", [6, 24, 25])
def test_sphere_tiling_is_its_own_mirror_image_across_x_and_y(bands):
    """Each element's mirror image across x = 0 and across y = 0 is an element too, so water moving
    symmetrically about a vertical plane turns a sphere not at all. A band of an odd number of
    pieces is not symmetric across one of the two planes: a ball sinking straight down through
    rising water was set turning about y (3e-3 rad/s on float_sphere's bed)."""
    el = sphere_elements(0.03, bands=bands)
    for mirror in (np.array([-1.0, 1.0, 1.0]), np.array([1.0, -1.0, 1.0])):
        image = el.pos * mirror
        nearest = np.abs(image[:, None, :] - el.pos[None, :, :]).max(axis=2).min(axis=1)
        assert nearest.max() < 1e-15


def test_sphere_tiling_wets_exactly_the_cap_area_in_still_water():
    """Bands wetted by coverage give the spherical cap area 2 pi R h for any immersion h."""
    radius = 0.03
    el = sphere_elements(radius, bands=24)
    for h in (0.001, 0.013, 0.03, 0.047, 0.06):
        level = -radius + h
        wet = sum(a * box_coverage(level - p[2], t1[2], t2[2]) for a, p, t1, t2 in
                  zip(el.area, el.pos, el.t1, el.t2, strict=True))
        assert wet == pytest.approx(2 * math.pi * radius * h, rel=1e-9)


def test_tilings_reject_too_coarse_settings():
    """A tiling too coarse to represent the body is refused with the rule and the value."""
    with pytest.raises(ValueError, match="across >= 2"):
        disk_elements(0.05, 0.006, across=1)
    with pytest.raises(ValueError, match="bands >= 2"):
        sphere_elements(0.05, bands=1)


def test_lowest_point_of_a_pitched_disk():
    """A disk pitched by alpha has its lowest point at z = -R sin(alpha) - e/2 cos(alpha)."""
    alpha = math.radians(25)
    axes = quat_to_matrix(axis_angle((0, 1, 0), -alpha))
    x, y, z = lowest_point(True, np.zeros(3), axes[:, 2], 0.05, 0.006)
    assert z == pytest.approx(-0.05 * math.sin(alpha) - 0.003 * math.cos(alpha), rel=1e-12)
    assert x < 0 and y == pytest.approx(0.0)
    assert lowest_point(False, np.array([1.0, 2.0, 3.0]), axes[:, 2], 0.5, 0.0) == (1.0, 2.0, 2.5)


def test_half_extents_of_a_flat_and_an_edge_on_disk():
    """A flat disk spans R both ways; on edge (axis along x) it spans e/2 along x."""
    assert disk_half_extents(np.array([0.0, 0.0, 1.0]), 0.05, 0.006) == pytest.approx((0.05, 0.05))
    assert disk_half_extents(np.array([1.0, 0.0, 0.0]), 0.05, 0.006) == pytest.approx((0.003, 0.05))


def test_quaternion_matrix_is_a_rotation():
    """quat_to_matrix gives an orthonormal matrix turning x by the quaternion's angle."""
    m = quat_to_matrix(axis_angle((0, 0, 1), math.pi / 2))
    assert np.allclose(m @ m.T, np.eye(3))
    assert np.allclose(m @ [1, 0, 0], [0, 1, 0])
