"""scenarios/lake.yaml: a strong throw over a 50 m x 6 m lake, stepped by tiles, its viewer surface
a window that follows the stone."""

from pathlib import Path

import pytest

from cosim.runner import run_scene
from cosim.scenario import load

LAKE = Path(__file__).resolve().parents[1] / "scenarios" / "lake.yaml"


def test_the_lake_loads_within_its_memory_estimate_and_is_stepped_by_tiles():
    """3 million columns on a flat bed: 8 arrays per column at most (192 MB), the water tiled."""
    scene = load(LAKE)
    cfg = scene.components["lake"]
    assert cfg.cls.estimate_bytes(cfg.params) == 5000 * 600 * 8 * 8
    outcome = run_scene(load(LAKE, overrides=["until=0.06"]), None, progress=False)
    lake = outcome.simulation.components["lake"]
    assert lake.tiles is not None and lake.grid.compact
    assert 0.0 < lake.tiles.peak_fraction() < 0.05  # one touchdown: a few tiles of 2983
    i0, i1, j0, j1 = lake.field_window()
    assert (i1 - i0, j1 - j0) == (800, 300)  # the viewer's surface: 8 m x 3 m, not the lake
    assert i0 <= 600 <= i1  # around the stone's first touchdown at x = 1 m (column 600)


@pytest.mark.slow
def test_the_strong_throw_skips_ten_times_over_25_m():
    """The whole throw: at least 10 skips over at least 25 m, sinking on open water."""
    outcome = run_scene(load(LAKE), None, progress=False)
    metrics = outcome.simulation.components["stages"].metrics()
    assert metrics["skips"] >= 10
    assert metrics["distance"] >= 25.0
    assert metrics["outcome"] == "sink" and metrics["reached_edge"] == 0


WIDE = ["components.lake.ny=2400", "components.lake.origin_y=-12.0"]  # 24 m: no curving throw leaves it


def _skips(overrides: list[str], until: float) -> tuple[int, list[float]]:
    """(skips, take-off angles [deg]) of the lake's throw with ``overrides``, run to ``until`` [s]."""
    outcome = run_scene(load(LAKE, overrides=[*WIDE, f"until={until}", *overrides]), None, progress=False)
    stages = outcome.simulation.components["stages"]
    return stages.metrics()["skips"], [s.takeoff_angle_deg for s in stages.records]


@pytest.mark.slow
def test_at_65_rev_s_the_free_slate_skips_twice_where_the_held_one_skips_ten_times():
    """docs/validation.md, section 2: the lake's throw spun at the experiments' 65 rev/s. Held, its
    spin costs it one skip of eleven; free, its first contact already turns it off the held path
    (a flatter take-off) and it skips twice."""
    spin = "components.stone.spin=408"
    held, held_angles = _skips([spin], 3.0)  # ten skips by t = 2.4 s
    free, free_angles = _skips([spin, "components.stone.lock_attitude=false"], 3.0)
    assert held == 10
    assert free == 2
    assert free_angles[0] < held_angles[0] - 1.5  # 6.0 against 8.0 deg
