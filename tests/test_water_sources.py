"""DropSource: a scripted body entering the water, seen through the occupied-height port."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from components.messages import OccupiedHeight
from components.water.sources import DropParams, DropSource
from cosim.errors import ScenarioError
from cosim.scenario import load

MS = 1_000_000


def drop(**kw) -> DropSource:
    defaults = dict(x=0.0, y=0.0, radius=0.03, height=0.01, start=0.01, rise=0.02,
                    cell=0.01, origin_x=-0.1, origin_y=-0.1, nx=21, ny=21)
    return DropSource("drop", DropParams(**{**defaults, **kw}))


def test_publishes_occupied_height_over_the_disk():
    """The window covers the disk; b is a smooth cap peaking at ``height`` in the centre column."""
    d = drop(start=0.0)
    msg = d.step(0, 30 * MS, {})["occupied"]
    assert isinstance(msg, OccupiedHeight)
    assert (msg.i0, msg.j0) == (7, 7)
    assert msg.b.shape == (7, 7)
    assert msg.b.max() == pytest.approx(0.01) and msg.b[3, 3] == msg.b.max()
    assert np.all(msg.b[0, :] == 0.0)  # the corners of the window lie outside the disk


def test_level_rises_smoothly_and_holds():
    """The displacement is 0 before start, rises over ``rise`` and stays when no hold is given."""
    d = drop()
    assert [d.level(t) for t in (0.0, 0.01, 0.02, 0.03, 1.0)] == pytest.approx([0, 0, 0.5, 1, 1])


def test_body_leaves_after_holding():
    """With ``hold`` the body leaves again over another ``rise``: the displacement returns to 0."""
    d = drop(hold=0.05)
    assert d.level(0.06) == 1.0
    assert d.level(0.09) == pytest.approx(0.5)
    assert d.level(0.2) == 0.0


def test_initial_output_is_the_state_at_t0():
    """At t = 0 (before start) the source publishes an all-zero occupied height."""
    msg = drop().initial_outputs()["occupied"]
    assert not msg.b.any()


def test_window_is_clipped_to_the_grid():
    """A drop near the edge publishes only the columns on the grid."""
    msg = drop(x=-0.1, y=0.1, start=0.0).step(0, 30 * MS, {})["occupied"]
    assert (msg.i0, msg.j0) == (0, 17)
    assert msg.b.shape == (4, 4)


@pytest.mark.parametrize("place", [dict(x=0.5), dict(y=-0.2), dict(origin_x=1e20)])
def test_a_drop_that_misses_the_grid_is_refused_with_the_grid(place):
    """A disk wholly off the water would displace nothing (and a grid 1e20 m away made an empty window
    of object dtype that the recording refused): the parameters say where the grid is."""
    with pytest.raises(ValueError, match=r"x: the drop at \(.*\) m, radius 0\.03 m, misses the water grid, "
                                         r"x .* to .* m and y .* to .* m"):
        drop(**place)
    drop(x=0.12)  # its disk reaches the last column's outer half: accepted


def test_a_drop_smaller_than_a_micrometre_is_refused():
    """A radius of 1e-320 m made every column's distance over it overflow (numpy warnings): refused."""
    from cosim.params import build

    problems: list[str] = []
    build(DropParams, {"radius": 1e-320}, "drop", problems)
    assert problems == ["drop.radius: must be >= 1e-06 m (got 9.99989e-321)"]


def test_a_height_beyond_a_kilometre_is_refused_naming_it():
    """A drop 1e308 m high passed `cosim validate`; the run then failed with overflow warnings and a
    non-finite water blamed on the pond."""
    with pytest.raises(ScenarioError) as err:
        load(Path(__file__).resolve().parents[1] / "scenarios" / "drop_ripple.yaml", ["components.drop.height=1e308"])
    assert err.value.problems == ["components.drop.height: must be <= 1000 m (got 1e+308)"]


@pytest.mark.parametrize(("override", "said"), [
    ("components.pond.cell=0.02", "cell 0.01 (the water's 0.02)"),
    ("components.pond.origin_x=-1.0", "origin_x -1.275 (the water's -1)"),
    ("components.pond.ny=200", "ny 256 (the water's 200)"),
])
def test_a_drop_on_another_grid_than_its_waters_is_refused(override, said):
    """The drop's window is in the indices of the grid it assumes: with the pond's cell doubled, a
    drop meant at (0, 0) landed at (1.27, 1.27) m with four times its volume, the run "ok"."""
    with pytest.raises(ScenarioError) as err:
        load(Path(__file__).resolve().parents[1] / "scenarios" / "drop_ripple.yaml", [override])
    assert err.value.problems == [f"components.pond: occupied: its source drop places its window on another "
                                  f"grid: {said}; set them as the water's"]
