"""A stone smaller than one water cell: R = 4 mm on 1 cm columns.

The coupler samples each column with sub-cells (automatically about 12 per body radius across a
cell, at most 16 x 16 per column: here the most), so buoyancy, displacement and the wetted area
still resolve the stone.
"""

from __future__ import annotations

import numpy as np
import pytest

from tests.stability.scenes import (
    assert_finite,
    assert_stone_never_gains_energy,
    assert_volume_kept,
    run,
    scene,
)
from tests.stability.test_densities import float_height
from tests.stability.test_throws import terminal_speed

SMALL = 0.004  # [m], less than half a cell


def test_a_small_disk_skips_and_its_columns_are_subsampled():
    """A 4 mm slate disk (1 mm thick) thrown like the reference stone skims, skips at least once,
    leaves the 3 m pond, and the coupler resolved it with 16 x 16 sub-cells per column."""
    r = run(scene(f"components.stone.radius={SMALL}", "components.stone.thickness=0.001",
                  "components.stone.position=[0.3, 0.5, 0.05]", "until=1.0"))
    assert_finite(r)
    assert_volume_kept(r)
    assert_stone_never_gains_energy(r)
    assert r.metrics["skips"] >= 1 and r.metrics["outcome"] == "left-pond"
    from components.coupler.fixtures import body

    assert r.coupler._subsamples(body(radius=SMALL, thickness=0.001), 0.01) == 16


def test_a_small_sphere_sinks_at_its_terminal_speed():
    """A 4 mm slate sphere dropped at 2 m/s sinks straight down (drift under 0.5 mm) and settles at
    the closed-form terminal speed of the coupler's submerged drag and friction (its pressure drag
    0.457 and C_f = 0.005 over the sphere: the measured 0.47) within 1.5%: 0.6061 m/s (measured
    0.6082 at 0.4 s), which
    the 16 x 16 sub-columns' buoyancy and the elements' drag of this sub-cell sphere must resolve."""
    r = run(scene("components.stone.shape=sphere", f"components.stone.radius={SMALL}",
                  "components.stone.velocity=[0, 0, -2]", "components.stone.position=[1.0, 0.5, 0.05]",
                  "components.stages.stop_after=0", "until=0.4"))
    assert_finite(r)
    assert_volume_kept(r)
    assert_stone_never_gains_energy(r)
    assert np.abs(r.position[:, :2] - r.position[0, :2]).max() < 5e-4
    assert -r.velocity[-1, 2] == pytest.approx(terminal_speed(r), rel=0.015)
    assert abs(r.velocity[-1, 2] - r.velocity[-11, 2]) < 0.02


def test_a_small_cork_sphere_floats_at_its_archimedes_height():
    """A 4 mm cork sphere let go 1 cm above the water floats, its centre over the last 0.5 s within
    0.3 mm of the Archimedes height (1.6 mm above the surface)."""
    level = float_height("sphere", 240.0, SMALL, 0.0)
    r = run(scene("components.stone.shape=sphere", f"components.stone.radius={SMALL}",
                  "components.stone.density=240", "components.stone.velocity=[0, 0, 0]",
                  "components.stone.position=[1.0, 0.5, 0.01]", "components.stages.stop_after=0",
                  "until=1.5"))
    assert_finite(r)
    assert_volume_kept(r)
    assert_stone_never_gains_energy(r)
    last = r.t >= r.t[-1] - 0.5
    assert r.position[last, 2].mean() == pytest.approx(level, abs=3e-4)
