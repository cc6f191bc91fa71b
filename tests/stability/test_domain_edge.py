"""A stone crossing the edge of the water's grid: the run ends with a clear outcome, 'left the pond'.

Where the grid has no columns the coupler exerts nothing (outside is no water) and reports the depth
of the stone's lowest point below the rest level; a stone that stays dry while below the water level
has left the pond, and the stage monitor stops the run saying so (``StageMonitor.outside_after``),
instead of the stone falling forever as a 'hit'.
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
    throw,
)

REACH = float(0.05 * np.sin(np.radians(20.0)) + 0.003 * np.cos(np.radians(20.0)))  # centre above lowest point
PLANING = [throw(8.0, 1.0), f"components.stone.position=[0.3, 0.5, {REACH + 0.001!r}]",
           "components.pond.nx=150", "until=1.0"]  # skims along the surface off a 1.5 m pond


def test_a_stone_planing_off_the_end_of_the_pond_stops_the_run():
    """Skimming at the surface across the far edge, the stone is dry once past it and falls; 50 ms
    after its lowest point sinks below the water level with no water around it the run stops:
    status 'stopped', reason and outcome 'left the pond', the stone just beyond the edge (x 1.5-2.1 m)
    instead of falling forever. The water keeps its volume to 1e-9 with reflecting walls."""
    r = run(scene(*PLANING))
    assert_finite(r)
    assert_volume_kept(r)
    assert_stone_never_gains_energy(r)
    assert r.result.status == "stopped" and "left the pond" in r.result.reason
    assert r.metrics["outcome"] == "left-pond"
    assert 1.5 < r.position[-1, 0] < 2.1 and -0.1 < r.position[-1, 2] < 0.0
    assert "left-pond" in r.sim.components["stages"].summary()[0]


def test_across_absorbing_edges_only_the_water_that_leaves_is_lost():
    """With absorbing (open) edges the volume is not an invariant: it is kept to round-off (1e-12)
    until the stone's waves reach an edge, then changes only by the water leaving through the
    one-way edges (under 1e-6 of the pond here); the outcome is the same as with walls."""
    r = run(scene(*PLANING, "components.pond.boundary=absorbing"))
    assert_finite(r)
    early = r.t < 0.1  # the bow wave reaches the far edge at about 0.12 s
    assert np.abs(r.volume[early] - r.volume[0]).max() <= 1e-12 * r.volume[0]
    assert np.abs(r.volume - r.volume[0]).max() <= 1e-6 * r.volume[0]
    assert r.metrics["outcome"] == "left-pond"


@pytest.mark.parametrize(("side", "velocity"), [("far end", "[7.88, 0.0, -1.39]"),
                                                ("side", "[7.47, 2.5, -1.39]")])
def test_a_stone_skipping_over_an_edge_lands_outside_and_stops_the_run(side, velocity):
    """A stone that skips once and flies over the far end (1.5 m pond) or the side (0.5 m away, thrown
    18 degrees aside) lands outside the grid: one skip counted, then 'left the pond' with the stone
    outside the pond's rectangle."""
    r = run(scene(f"components.stone.velocity={velocity}", "components.pond.nx=150", "until=1.0"))
    assert_finite(r)
    assert_volume_kept(r)
    assert r.metrics["skips"] == 1 and r.metrics["outcome"] == "left-pond"
    x, y = r.position[-1, :2]
    assert x > 1.5 or not 0.0 < y < 1.0


@pytest.mark.parametrize(("where", "position"), [("beyond the far end", "[3.5, 0.5, 0.15]"),
                                                 ("far off the pond", "[100.0, 100.0, 0.15]")])
def test_a_stone_that_first_comes_down_off_the_grid_finds_no_water_there(where, position):
    """A throw whose first touchdown lies wholly outside the water's grid (3 m pond): the water
    answers that it has no columns there (``HeightPatch.off_grid``), the coupler assumes no still
    water in their place, and the stone falls through: no skip, no force, 'left the pond'. Before,
    having never received a column, the coupler stood in still water for the water it had not yet
    heard from, and the stone skipped four times on a pond that was not there."""
    r = run(scene(f"components.stone.position={position}", "until=1.0"))
    assert_finite(r)
    assert r.metrics["skips"] == 0 and r.metrics["outcome"] == "left-pond"
    assert r.sim.components["coupler"].dissipated == 0.0  # the water never pushed on the stone
    assert r.volume[-1] == r.volume[0]  # the water never moved


def test_a_stone_thrown_from_the_shore_skips_on_the_pond():
    """Let go in the air off the grid (1 m before the pond's near edge) and coming down on it, the
    stone skips as from inside: the water that answers 'off the grid' while it flies there stands
    for nothing once it is over the columns."""
    r = run(scene("components.stone.position=[-1.0, 0.5, 0.3]", "components.stone.velocity=[8.0, 0.0, 0.5]",
                  "until=1.0"))
    assert_finite(r)
    assert r.metrics["skips"] >= 1
    first = r.sim.components["stages"].records[0]
    assert 0.0 < first.touchdown_x < 3.0
