"""The displaced water's band has a physical width: the same source on 1 cm and 5 mm columns.

A band a fixed number of columns wide (1.5) was a sharper source the finer the columns: on 5 mm
columns a slate disk gliding just under the surface near the water's wave speed fed grid-scale
waves that threw it out of the water. The band is now half the body's radius wide (at least 1.5
columns), so refining the columns refines the band's shape instead of narrowing it.
"""

from __future__ import annotations

import numpy as np
import pytest

from components.coupler import kernel
from tests.glide_scene import glide

RADIUS = 0.05  # [m] the reference stone


def test_band_width_is_a_share_of_the_radius_with_a_floor_in_columns():
    assert kernel.band_width(1.5, 0.5, 0.005, RADIUS) == pytest.approx(0.025)
    assert kernel.band_width(1.5, 0.5, 0.01, RADIUS) == pytest.approx(0.025)
    # a small body on coarse columns: the band keeps 1.5 columns
    assert kernel.band_width(1.5, 0.5, 0.02, 0.01) == pytest.approx(0.03)
    assert kernel.band_width(1.5, 0.0, 0.005, RADIUS) == pytest.approx(0.0075)  # the old band


def _mean_distance_outside(cell: float) -> float:
    """Volume-weighted mean distance [m] outside the outline of the water a flat disk (R = 5 cm),
    sunk 1 cm under the rest level, pushes into its band on columns of ``cell`` [m]."""
    n = round(0.4 / cell)
    x0 = y0 = -0.2 + 0.5 * cell
    xs = x0 + cell * np.arange(n)
    dx, dy = np.meshgrid(xs, xs)
    b_geo = np.where(np.hypot(dx, dy) < RADIUS, 0.01, 0.0)
    width = kernel.band_width(1.5, 0.5, cell, RADIUS)
    ring = kernel.ring_map(kernel.SHAPE_DISK, RADIUS, 0.015, np.zeros(3), np.eye(3), x0, y0, cell, b_geo, width)
    b_out = np.zeros_like(b_geo)
    kernel.ring_deposit(b_geo, *ring, b_out)
    assert b_out.sum() == pytest.approx(b_geo.sum(), rel=1e-12)  # the volume is kept
    return float((b_out * (np.hypot(dx, dy) - RADIUS)).sum() / b_out.sum())


def test_the_band_has_the_same_place_on_1_cm_and_5_mm_columns():
    coarse, fine = _mean_distance_outside(0.01), _mean_distance_outside(0.005)
    assert fine == pytest.approx(coarse, rel=0.15)
    assert fine == pytest.approx(0.025, rel=0.2)  # the tent's peak, half a radius outside


def test_a_stone_just_under_the_surface_at_the_wave_speed_is_not_thrown_out_on_fine_columns():
    fine_peak, fine_top = glide(0.005)
    coarse_peak, coarse_top = glide(0.01)
    # it starts at -12 mm and sinks: the water never lifts it to the surface
    assert fine_top < -0.011 and coarse_top < -0.011
    # the same source on both: the finer columns' waves are no more than twice as fast (a band 1.5
    # columns wide, ring_share 0: 3.7 times, 106 against 28 m/s, and the stone thrown out of the water)
    assert fine_peak < 2.0 * coarse_peak
