"""Water diagnostics: the physical surface energy beside the model's lattice energy."""

from __future__ import annotations

import numpy as np
import pytest

from components.water.diagnostics import energy, surface_energy
from components.water.grid import build_grid


def test_surface_energy_of_a_raised_patch_is_half_rho_g_eta_squared_area():
    """A 1 cm rise over 10 x 10 cells of 1 cm stores 1/2 rho g eta^2 A = 0.0004905 J."""
    grid = build_grid(40, 40, 0.01, 0.5)
    h = np.zeros((40, 40))
    h[10:20, 10:20] = 0.01
    assert surface_energy(grid, h) == pytest.approx(0.5 * 1000 * 9.81 * 0.01**2 * 0.01, rel=1e-12)


def test_lattice_energy_of_short_waves_far_exceeds_their_physical_energy():
    """For a 4 cm standing wave on 0.5 m of water the lattice energy is about (k d)^2 times the
    physical surface energy, as the diagnostics' docstring states."""
    grid = build_grid(64, 4, 0.01, 0.5)
    x = (np.arange(64) + 0.5) * 0.01
    k = 2 * np.pi / 0.04
    h = np.tile(0.001 * np.cos(k * x), (4, 1))
    ratio = energy(grid, h, np.zeros_like(h)) / surface_energy(grid, h)
    k_lattice = 2 * np.sin(k * 0.01 / 2) / 0.01  # the 5-point operator's wavenumber for this wave
    assert ratio == pytest.approx((k_lattice * 0.5) ** 2, rel=0.02)
    assert ratio > 3000
