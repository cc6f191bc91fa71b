"""Extreme densities: lead (11340 kg/m^3) sinks and rests on the pond's bed, cork (240 kg/m^3) floats.

The resting cases add a SolidGround at the bed (``BOTTOM``): the ground's impulses go into the stone's
impulse port and the coupler's wrench into its wrench port, so the stone feels both at once.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.stability.scenes import (
    BOTTOM,
    RHO_WATER,
    assert_finite,
    assert_stone_never_gains_energy,
    assert_volume_kept,
    assert_water_energy_not_growing,
    run,
    scene,
)

BED = -0.5  # [m]

RESTING = {
    "lead sphere": (["components.stone.shape=sphere", "components.stone.radius=0.02",
                     "components.stone.density=11340"], 0.02, 1.2),
    # landed, the disk rolls round its rim tilted by a few tenths of a degree (as Euler's disk does)
    # and settles flat as the water takes that motion's energy: within 0.2 mm after 3 s
    "lead disk, tilted and free": (["components.stone.density=11340", "components.stone.tilt_deg=10",
                                    "components.stone.lock_attitude=false"], 0.003, 3.0),
    "slate disk, tilted and free": (["components.stone.tilt_deg=30", "components.stone.lock_attitude=false"],
                                    0.003, 2.5),
}


@pytest.mark.parametrize("case", [
    "lead sphere",
    "lead disk, tilted and free",
    pytest.param("slate disk, tilted and free", marks=pytest.mark.slow),
])
def test_a_heavy_stone_sinks_and_rests_on_the_bottom(case):
    """Let go at the surface, the stone sinks, lands on the bed (a disk settles flat) and stays there:
    the monitor says 'rest', the centre is one radius (sphere) or half a thickness (disk) above the
    bed within 0.2 mm and moves less than 0.5 mm over the last 0.3 s, and the water, shaken by the
    entry, keeps its volume and does not gain energy while the stone lies still."""
    sets, height, until = RESTING[case]
    r = run(scene("components.stone.position=[1.5, 0.5, 0.05]", "components.stone.velocity=[0, 0, 0]",
                  "components.stages.stop_after=0", f"until={until}", *sets, text=BOTTOM))
    assert_finite(r)
    assert_volume_kept(r)
    assert_stone_never_gains_energy(r)
    assert r.metrics["outcome"] == "rest"
    assert r.sim.components["bed"].in_contact
    assert r.position[-1, 2] == pytest.approx(BED + height, abs=2e-4)
    last = r.t >= r.t[-1] - 0.3
    assert np.abs(r.position[last] - r.position[-1]).max() < 5e-4
    assert r.stone.body_state().attack_angle_deg < 0.5
    landed = r.t[np.argmax(r.position[:, 2] < BED + height + 1e-3)]
    assert_water_energy_not_growing(r, after=landed + 0.05, factor=1.15)


def float_height(shape: str, density: float, radius: float, thickness: float) -> float:
    """Height of the centre above still water for a floating sphere or flat disk (Archimedes) [m]."""
    sigma = density / RHO_WATER
    if shape == "disk":
        return thickness * (0.5 - sigma)
    # sphere: the immersed cap of height d holds sigma of the volume: d^2 (3R - d) = 4 sigma R^3
    lo, hi = 0.0, 2 * radius
    for _ in range(60):
        d = 0.5 * (lo + hi)
        lo, hi = (d, hi) if d * d * (3 * radius - d) < 4 * sigma * radius**3 else (lo, d)
    return radius - 0.5 * (lo + hi)


CORK = {
    "sphere": ["components.stone.shape=sphere", "components.stone.radius=0.03"],
    "disk": ["components.stone.tilt_deg=0"],
}


# Over the last second of the cork runs: (bound on the mean's error, bound on any sample's error) [m]
# against the Archimedes height. Measured: the flat disk's mean within 3.2 um (shallow water) and 1.5 um
# (wave), every sample within 39 um and 185 um; the sphere, bobbing on in the closed basin, its mean
# within 40 um and 136 um, every sample within 1.0 mm and 3.6 mm. A buoyancy 5% too strong raises the
# float height by 69 um (disk) and 0.53 mm (sphere), one 25% too strong by 0.29 mm and 2.3 mm.
CORK_BANDS = {
    ("disk", "shallow_water"): (2e-5, 1e-4),
    ("disk", "wave"): (2e-5, 3e-4),
    ("sphere", "shallow_water"): (3e-4, 1.5e-3),
    ("sphere", "wave"): (3e-4, 5e-3),
}


@pytest.mark.parametrize(("shape", "model"), [
    ("sphere", "shallow_water"),
    ("sphere", "wave"),
    ("disk", "shallow_water"),
    ("disk", "wave"),
])
def test_cork_floats_at_its_archimedes_height(shape, model):
    """A cork sphere (R = 3 cm) or flat disk (6 mm thick) dropped from 1 cm floats at its Archimedes
    height above still water (the disk 1.56 mm, the sphere 10.88 mm): over its last second the
    centre's mean is within 20 um of it (disk) or 0.3 mm (sphere), and every sample within 0.1 mm
    (disk, shallow water), 0.3 mm (disk, wave), 1.5 mm (sphere, shallow water) or 5 mm (sphere,
    wave: still bobbing in the closed basin), see ``CORK_BANDS``; a buoyancy 5% off moves the mean
    out of its band. The water's energy, once the splash has spread (0.3 s), does not grow (at most
    1.2 times its value then)."""
    radius, thickness = (0.03, 0.0) if shape == "sphere" else (0.05, 0.006)
    level = float_height(shape, 240.0, radius, thickness)
    start = level + (radius if shape == "sphere" else thickness) + 0.01
    r = run(scene("components.stone.density=240", "components.stone.velocity=[0, 0, 0]",
                  f"components.stone.position=[1.5, 0.5, {start!r}]", "components.stone.lock_attitude=false",
                  "components.stages.stop_after=0", f"components.pond.model={model}", "until=2.0",
                  *CORK[shape]))
    assert_finite(r)
    assert_volume_kept(r)
    assert_stone_never_gains_energy(r)
    last = r.t >= r.t[-1] - 1.0
    mean_band, swing_band = CORK_BANDS[shape, model]
    assert r.position[last, 2].mean() == pytest.approx(level, abs=mean_band)
    assert np.abs(r.position[last, 2] - level).max() < swing_band
    assert np.abs(r.position[:, :2] - r.position[0, :2]).max() < 0.01
    assert_water_energy_not_growing(r, after=0.3, factor=1.2)
    assert math.isfinite(r.water_energy[-1])


def test_a_body_near_neutral_buoyancy_stops_bobbing_in_an_open_pond():
    """A flat disk of 900 kg/m^3 (relative density 0.9, floating with a tenth of its thickness
    dry) let go 5 mm above the water of an open pond (absorbing edges) radiates its heave away: after
    3 s its vertical speed stays under 1 mm/s and its centre within 0.3 mm of the Archimedes height."""
    level = float_height("disk", 900.0, 0.05, 0.006)
    r = run(scene("components.stone.density=900", "components.stone.velocity=[0, 0, 0]", "components.stone.tilt_deg=0",
                  f"components.stone.position=[1.5, 0.5, {level + 0.005!r}]", "components.stone.lock_attitude=false",
                  "components.pond.boundary=absorbing", "components.stages.stop_after=0", "until=4.0"))
    assert_finite(r)
    assert_stone_never_gains_energy(r)
    late = r.t >= 3.0
    assert np.abs(r.velocity[late, 2]).max() < 1e-3
    assert np.abs(r.position[late, 2] - level).max() < 3e-4
