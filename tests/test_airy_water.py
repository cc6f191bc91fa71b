"""The ``airy`` water model: water's dispersion, omega^2 = (g k + gamma k^3 / rho) tanh(k d), each basin
mode stepped exactly.

The height field's other models carry every wave at sqrt(g d); real short waves are far slower
(deep water: c = sqrt(g / k + gamma k / rho), 0.30 m/s for 5 cm). These tests hold the model to the exact
dispersion relation of linear water waves (Airy; Lamb 1932, section 228), its invariants, and what
it changes for a body: a stone gliding just under the surface at the pond's sqrt(g d) no longer
resonates with its own waves.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from components.water import WaterParams, WaterSurface
from components.water.grid import GRAVITY, SURFACE_TENSION, WATER_DENSITY, build_grid
from components.water.models import AiryModel
from components.water.surface import GaussianBump
from cosim.errors import ScenarioError
from cosim.scenario import load
from tests.glide_scene import glide

ROOT = Path(__file__).resolve().parent.parent


def _airy(k: float, depth: float) -> float:
    """Airy's angular frequency [rad/s] of a wave of wavenumber ``k`` [1/m] on water ``depth`` [m]
    deep: gravity and capillarity (Lamb 1932, sections 228 and 267)."""
    return math.sqrt((GRAVITY * k + SURFACE_TENSION * k**3 / WATER_DENSITY) * math.tanh(k * depth))


def _mode(nx: int, m: int) -> np.ndarray:
    """The basin's m-th standing mode along x (a cosine with zero slope at both walls), (2, nx)."""
    i = np.arange(nx)
    return np.tile(np.cos(math.pi * m * (i + 0.5) / nx), (2, 1))


@pytest.mark.parametrize(("cell", "depth", "m"), [
    (0.01, 0.5, 40),    # 5 cm waves on 0.5 m of water: deep, c = sqrt(g / k + gamma k / rho) = 0.30 m/s
    (0.05, 0.1, 4),     # 2.5 m waves on 0.1 m: shallow, c -> sqrt(g d)
    (0.01, 0.05, 10),   # 20 cm waves on 5 cm: in between
    (0.002, 0.3, 20),   # 2 cm ripples: capillarity restores 40% as much as gravity (24% faster than without)
])
def test_a_standing_mode_oscillates_at_airys_frequency(cell, depth, m):
    nx = 100
    grid = build_grid(nx, 2, cell, depth)
    model = AiryModel(grid, None)
    k = math.pi * m / (nx * cell)
    omega = _airy(k, depth)
    h, v = 1e-3 * _mode(nx, m), np.zeros((2, nx))
    h_out, v_out = np.empty_like(h), np.empty_like(v)
    dt, steps = 0.37 / omega, 40  # any step: the rotation is exact
    for _ in range(steps):
        model.advance(h, v, h_out, v_out, dt)
        h, v, h_out, v_out = h_out, v_out, h, v
    t = steps * dt
    assert h == pytest.approx(1e-3 * math.cos(omega * t) * _mode(nx, m), abs=1e-15)
    assert v == pytest.approx(-1e-3 * omega * math.sin(omega * t) * _mode(nx, m), abs=1e-14)


@pytest.mark.parametrize("m", [23, 4])  # 1.7 cm ripples (capillarity restores 0.96 as much as gravity), 10 cm
def test_a_modes_energy_is_its_potential_energy_then_its_flows_kinetic_energy(m):
    """A standing mode of amplitude A at rest holds 1/2 (rho g + gamma k^2) A^2 / 2 per area, gravity's
    and the surface tension's potential energy; a quarter period later the same, as the potential
    flow's kinetic energy 1/2 rho V^2 / (k tanh kd) (Lamb 1932, sections 229, 267). The model's energy
    gave gravity's share alone: half of it for a ripple near c_min."""
    nx, cell, depth, amplitude = 200, 0.001, 0.3, 1e-4
    grid = build_grid(nx, 2, cell, depth)
    model = AiryModel(grid, None)
    k = math.pi * m / (nx * cell)
    exact = 0.5 * (WATER_DENSITY * GRAVITY + SURFACE_TENSION * k * k) * amplitude**2 / 2 * (nx * 2 * cell * cell)
    h, v = amplitude * _mode(nx, m), np.zeros((2, nx))
    assert model.energy(h, v) == pytest.approx(exact, rel=1e-12)
    h_out, v_out = np.empty_like(h), np.empty_like(v)
    model.advance(h, v, h_out, v_out, 0.5 * math.pi / _airy(k, depth))
    assert np.abs(h_out).max() < 1e-12 * amplitude
    kinetic = 0.5 * WATER_DENSITY * float(np.sum(v_out**2)) * cell**2 / (k * math.tanh(k * depth))
    assert model.energy(h_out, v_out) == pytest.approx(exact, rel=1e-12)
    assert kinetic == pytest.approx(exact, rel=1e-12)


def test_a_deep_water_packet_travels_at_its_group_speed():
    """5 cm waves on 0.5 m of water: the packet moves at the group speed d omega / dk = 0.18 m/s (0.14
    without capillarity, which carries a 5 cm wave's group a quarter faster),
    not at the sqrt(g d) = 2.2 m/s every wave has in the other models."""
    nx, cell, depth = 600, 0.005, 0.5
    grid = build_grid(nx, 2, cell, depth)
    model = AiryModel(grid, None)
    x = (np.arange(nx) + 0.5) * cell
    k = 2 * math.pi / 0.05
    omega = _airy(k, depth)
    envelope = np.exp(-((x - 0.8) ** 2) / (2 * 0.15**2))
    h = np.tile(1e-3 * envelope * np.cos(k * x), (2, 1))  # a wave travelling to +x
    v = np.tile(1e-3 * omega * envelope * np.sin(k * x), (2, 1))
    h_out, v_out = np.empty_like(h), np.empty_like(v)
    for _ in range(100):
        model.advance(h, v, h_out, v_out, 0.01)
        h, v, h_out, v_out = h_out, v_out, h, v
    energy = h[0] ** 2 + (v[0] / omega) ** 2
    centre = float(np.sum(x * energy) / np.sum(energy))
    group = (_airy(k * 1.0001, depth) - _airy(k * 0.9999, depth)) / (0.0002 * k)  # d omega / dk
    assert centre - 0.8 == pytest.approx(group * 1.0, rel=0.05)


def test_volume_and_the_modes_energy_are_kept():
    pond = WaterSurface("pond", WaterParams(nx=60, ny=40, cell=0.01, depth=0.3, model="airy",
                                            initial=GaussianBump(x=0.2, y=0.15, amplitude=0.01, width=0.03)))
    volume, energy = pond.volume(), pond.energy()
    for _ in range(300):
        pond.advance(0.004)
    assert pond.volume() == pytest.approx(volume, rel=1e-14)
    assert pond.energy() == pytest.approx(energy, rel=1e-10)
    assert np.abs(pond._h).max() < 0.5 * 0.01  # the bump has spread


@pytest.mark.parametrize(("setting", "field"), [("bottom_slope=[0.01, 0]", "bottom_slope"),
                                                ("wave_speed=0.23", "wave_speed")])
def test_airy_water_needs_a_flat_bed_at_its_own_speeds(setting, field):
    with pytest.raises(ScenarioError, match=f"pond.*{field}.*airy"):
        load(ROOT / "scenarios" / "skip.yaml", ["components.pond.model=airy", f"components.pond.{setting}"])


def test_a_stone_gliding_at_the_ponds_wave_speed_does_not_resonate_with_dispersive_water():
    (wave, _), (airy, _) = glide(0.01), glide(0.01, "components.pond.model=airy")
    assert wave > 5.0  # the one-speed water resonates: its surface moves faster than the stone
    assert airy < 2.2  # dispersive water: slower than the stone that raises it


def test_the_memory_check_counts_airys_arrays():
    """The scene's memory check (WaterSurface.estimate_bytes) covers what an airy pond takes at the
    peak of a step, so a pond too large for the machine is refused before it runs."""
    import tracemalloc

    params = WaterParams(nx=600, ny=400, cell=0.01, depth=0.5, model="airy")
    warm = WaterSurface("warm", WaterParams(nx=8, ny=8, model="airy"))  # imports and first calls, untraced
    warm.advance(0.002)
    tracemalloc.start()
    try:
        pond = WaterSurface("pond", params)
        for _ in range(2):
            pond.advance(0.002)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak <= WaterSurface.estimate_bytes(params) < 1.5 * peak
