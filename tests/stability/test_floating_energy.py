"""A floating body and the waves it makes share one energy: on the hard-case 2 ms water step the
coupled books never gain more than 1% (they lose 6% over 3 s, and on a water stepping every 0.2 ms
gain 9%: docs/validation.md section 7, an open error of the ring's books).

A cork disk (240 kg/m^3, R = 5 cm, 6 mm thick, attitude locked: a pure heave) dropped from 1 cm onto
the explicit `wave` model of the closed hard-case basin, with only the displacement and the buoyancy
switched on: nothing dissipates, so the body's mechanical energy, its Archimedes potential and the
water's wave energy must add up to a constant, and the heave must radiate into the waves.

The water's energy here is the physical one of the linear shallow-water waves the height field
carries (not its lattice invariant, :func:`components.water.diagnostics.energy`): the surface's
potential energy 1/2 rho g sum eta^2 s^2 plus the kinetic energy of the horizontal flow, whose
divergence moves the columns, (rho / 2d) s^2 v.(-L)^-1 v (L the grid's Laplacian, reflecting walls),
in the shadow form the explicit step keeps exactly (minus rho g s^2 dt/2 sum v eta, dt the water's
step).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.fft import dctn

from cosim.scheduler import BaseObserver, Simulation
from tests.stability.scenes import RHO_WATER, G, scene
from tests.stability.test_densities import float_height

RADIUS = 0.05  # [m]
THICKNESS = 0.006  # [m]
WATER_STEP = 0.002  # [s] the hard-case pond's step (dt 0.2 ms, every 10)


def wave_energy(pond, dt: float) -> float:
    """Energy [J] of the linear shallow-water waves of a closed, uniform pond (see the module
    docstring), in the shadow form the explicit `wave` step of size ``dt`` [s] conserves."""
    grid, eta, v = pond.grid, pond._h, pond._v
    area = grid.cell**2
    ny, nx = eta.shape
    # eigenvalues of -L on the cosine modes of a closed basin (the mean mode carries no flow)
    sx = np.sin(np.pi * np.arange(nx) / (2 * nx)) ** 2
    sy = np.sin(np.pi * np.arange(ny) / (2 * ny)) ** 2
    lam = 4.0 / area * (sy[:, None] + sx[None, :])
    lam[0, 0] = np.inf
    depth = grid.c2_uniform / G
    flow = 0.5 * RHO_WATER / depth * area * float(np.sum(dctn(v, norm="ortho") ** 2 / lam))
    surface = 0.5 * RHO_WATER * G * area * float(np.sum(eta * eta))
    return surface + flow - 0.5 * RHO_WATER * G * area * dt * float(np.sum(v * eta))


def archimedes_potential(z: float) -> float:
    """Potential energy [J] of the buoyancy against still water on a level disk centred at z [m]:
    rho g A int_0^d min(s, e) ds, d the depth of its lower face under the rest level."""
    depth = max(0.0, THICKNESS / 2 - z)
    wet = min(depth, THICKNESS)
    return RHO_WATER * G * math.pi * RADIUS**2 * (0.5 * wet * wet + THICKNESS * (depth - wet))


class Books(BaseObserver):
    """Every 10 ms: time [s], the disk's height [m] and the coupled energy [J]."""

    def __init__(self) -> None:
        self.rows: list[tuple[float, float, float]] = []

    def on_step_complete(self, sim: Simulation) -> None:
        if sim.time_ns % 10_000_000:
            return
        state = sim.components["stone"].body_state()
        z = float(state.position[2])
        energy = (state.kinetic_energy + state.potential_energy + archimedes_potential(z)
                  + wave_energy(sim.components["pond"], WATER_STEP))
        self.rows.append((sim.time_ns / 1e9, z, energy))


def test_a_heaving_cork_disk_radiates_its_energy_into_the_waves_and_gains_none():
    """From 0.3 s (the drop's splash made) to 3 s, the coupled energy never exceeds its value at
    0.3 s by more than 1% (it was 5 times it when the buoyancy read the surface under the disk while
    the displacement went into a ring around it), and the heave decays: its peak-to-peak over the
    last half second is under half what it was over 0.3-0.8 s (it stayed at 3 cm)."""
    level = float_height("disk", 240.0, RADIUS, THICKNESS)
    books = Books()
    sim = Simulation(scene("components.stone.density=240", "components.stone.velocity=[0, 0, 0]",
                           f"components.stone.position=[1.5, 0.5, {level + THICKNESS + 0.01!r}]",
                           "components.stone.tilt_deg=0", "components.stone.lock_attitude=true",
                           "components.coupler.effects=[displacement, buoyancy]",
                           "components.stages.stop_after=0", "components.pond.model=wave", "until=3.0"),
                     observers=[books])
    sim.run()
    t, z, energy = np.array(books.rows).T
    assert np.isfinite(energy).all()
    settled = t >= 0.3
    assert energy[settled].max() <= 1.01 * energy[settled][0]
    early = np.ptp(z[(t >= 0.3) & (t < 0.8)])
    late = np.ptp(z[t >= 2.5])
    assert late < 0.5 * early
