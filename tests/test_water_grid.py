"""Grid geometry of the water: cell centres, windows, the bed, dry cells and face coefficients."""

from __future__ import annotations

import math

import numpy as np
import pytest

from components.water.grid import GRAVITY, SURFACE_TENSION, WATER_DENSITY, build_grid, wave_speed_of


def test_cell_centres_follow_origin_and_cell_size():
    """Cell (i, j) is centred at (origin_x + i*cell, origin_y + j*cell), arrays indexed [j, i]."""
    g = build_grid(5, 3, 0.1, 1.0, origin_x=-1.0, origin_y=2.0)
    x, y = g.centres()
    assert x.shape == (3, 5)
    assert x[2, 4] == pytest.approx(-1.0 + 4 * 0.1)
    assert y[2, 4] == pytest.approx(2.0 + 2 * 0.1)


def test_window_covers_every_cell_touching_the_rectangle():
    """A cell belongs to the window when its square touches the rectangle (half-open index ranges)."""
    g = build_grid(10, 10, 1.0, 1.0)
    assert g.window(2.6, 4.4, 0.0, 0.0) == (3, 5, 0, 1)
    assert g.window(2.4, 2.4, 3.0, 3.0) == (2, 3, 3, 4)


def test_window_adds_margin_and_clips_to_grid():
    """The margin widens the window on every side and the result never leaves the grid."""
    g = build_grid(10, 8, 1.0, 1.0)
    assert g.window(0.0, 1.0, 6.6, 20.0, margin=2) == (0, 4, 5, 8)


def test_empty_or_outside_request_gives_no_window():
    """An empty rectangle (min > max) or one off the grid gives None."""
    g = build_grid(10, 10, 1.0, 1.0)
    assert g.window(1.0, 0.0, 0.0, 1.0) is None
    assert g.window(20.0, 30.0, 0.0, 1.0) is None


def test_a_request_far_beyond_the_float_range_of_the_grid_is_clipped_like_any_other():
    """A grid 1e308 m from the body: the request's cell index overflows a float, and is still a
    window clipped to the grid (none here; all of it from the other side), not an OverflowError."""
    far = build_grid(10, 10, 0.01, 1.0, origin_x=1e308)
    assert far.window(0.0, 1.0, 0.0, 0.05) is None
    behind = build_grid(10, 10, 0.01, 1.0, origin_x=-1e308)
    assert behind.window(-1e308, 1e308, 0.0, 0.05) == (0, 10, 0, 6)


def test_non_finite_request_is_an_error():
    """A request with NaN or infinite bounds is refused, naming the rectangle."""
    g = build_grid(10, 10, 1.0, 1.0)
    with pytest.raises(ValueError, match="patch request must be finite"):
        g.window(math.nan, 1.0, 0.0, 1.0)


def test_flat_bed_is_uniform_with_physical_speed():
    """A flat pond is uniform: every face carries K = g * depth (c = sqrt(g d))."""
    g = build_grid(6, 4, 0.01, 0.5)
    assert g.c2_uniform == pytest.approx(GRAVITY * 0.5)
    assert np.all(g.kx == g.c2_uniform) and np.all(g.ky == g.c2_uniform)
    assert g.c_max == pytest.approx(math.sqrt(GRAVITY * 0.5))
    assert np.all(g.bed == -0.5) and np.all(g.surface0 == 0.0)


def test_sloped_bed_gives_kass_miller_face_coefficients():
    """On a sloped bed K_face = g (d_a + d_b) / 2 from the rest depths on both sides."""
    g = build_grid(8, 3, 0.1, 0.2, bottom_slope=(0.1, 0.0))
    assert g.c2_uniform is None
    d = g.depth0
    assert np.allclose(g.kx, GRAVITY * 0.5 * (d[:, :-1] + d[:, 1:]))
    assert g.depth0[0, 0] > g.depth0[0, -1]


def test_cells_above_rest_level_are_dry_walls():
    """Cells whose bed rises above the rest level are dry: no water, no flux on their faces."""
    g = build_grid(20, 2, 0.1, 0.3, rest_level=1.0, bottom_slope=(0.5, 0.0))
    assert not g.wet.all() and g.wet.any()
    dry = ~g.wet
    assert np.all(g.depth0[dry] == 0.0)
    assert np.all(g.surface0[dry] == g.bed[dry])
    assert np.all(g.kx[dry[:, :-1] | dry[:, 1:]] == 0.0)


def test_given_wave_speed_applies_on_every_wet_face():
    """A given wave speed sets K = c^2 on every wet face whatever the depth."""
    g = build_grid(8, 3, 0.1, 0.2, bottom_slope=(0.05, 0.0), wave_speed=2.0)
    assert g.c2_uniform == 4.0
    assert np.all(g.kx == 4.0)


def test_a_waves_speed_follows_from_its_length_and_the_depth():
    """grid.wave_speed_of is linear water waves' dispersion, gravity and capillarity together
    (Lamb 1932, section 267): long waves run at sqrt(g d), deep-water ripples at
    sqrt(g / k + gamma k / rho), and the slowest of all, c_min = (4 g gamma / rho)^(1/4) = 0.23 m/s,
    is the wave 2 pi sqrt(gamma / (rho g)) = 1.7 cm long."""
    assert wave_speed_of(1e4, 0.5) == pytest.approx(math.sqrt(GRAVITY * 0.5), rel=1e-6)
    k = 2 * math.pi / 0.1  # tanh(k d) = 1 to round-off at d = 0.5 m
    ripple = math.sqrt(GRAVITY / k + SURFACE_TENSION * k / WATER_DENSITY)
    assert wave_speed_of(0.1, 0.5) == pytest.approx(ripple, rel=1e-12)
    assert ripple == pytest.approx(0.40, abs=0.005)
    slowest = 2 * math.pi * math.sqrt(SURFACE_TENSION / (WATER_DENSITY * GRAVITY))
    c_min = (4 * GRAVITY * SURFACE_TENSION / WATER_DENSITY) ** 0.25
    assert wave_speed_of(slowest, 0.5) == pytest.approx(c_min, rel=1e-12)
    assert min(wave_speed_of(slowest * 1.05, 0.5), wave_speed_of(slowest / 1.05, 0.5)) > c_min
