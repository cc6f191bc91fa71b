"""A scene too large for the machine is refused when it loads, with the figure, before any of its
arrays is allocated: each component class estimates its memory (Component.estimate_bytes)."""

from __future__ import annotations

import pytest

import cosim.scenario
from cosim.component import Component
from cosim.errors import ScenarioError
from cosim.scenario import loads

POND = """
dt: 0.001
until: 0.01
components:
  pond: {{type: WaterSurface, nx: {nx}, ny: {ny}, cell: 0.01}}
"""


@pytest.fixture
def sixteen_gb(monkeypatch):
    """A machine of 16 GB, whatever this one has."""
    monkeypatch.setattr(cosim.scenario, "machine_memory", lambda: 16_000_000_000)


def test_a_40000_by_40000_lake_is_refused_with_the_figure(sixteen_gb):
    """40000 x 40000 cells (about 102 GB) is one ScenarioError naming the need and the machine."""
    with pytest.raises(ScenarioError) as err:
        loads(POND.format(nx=40000, ny=40000))
    (problem,) = err.value.problems
    assert problem == ("components: the scene needs about 102 GB of memory (pond 102 GB), more than this "
                       "machine's 16 GB allows (90%); use a smaller grid")


def test_the_estimate_follows_the_grid_and_the_machine(monkeypatch):
    """A grid that fits is built; the same grid on a smaller machine is refused."""
    scene = loads(POND.format(nx=300, ny=200))
    cfg = scene.components["pond"]
    assert cfg.cls.estimate_bytes(cfg.params) == 300 * 200 * 8 * 8  # a flat bed: 8 arrays of the grid
    monkeypatch.setattr(cosim.scenario, "machine_memory", lambda: 3_000_000)
    figure = r"needs about 3\.84 MB of memory \(pond 3\.84 MB\), more than this machine's 3 MB"
    with pytest.raises(ScenarioError, match=figure):
        loads(POND.format(nx=300, ny=200))


def test_components_without_an_estimate_count_nothing(monkeypatch):
    """The hook is optional: the base class says 0, so toy components load on any machine."""
    assert Component.estimate_bytes(None) == 0
    monkeypatch.setattr(cosim.scenario, "machine_memory", lambda: 1)
    assert loads("dt: 0.001\nuntil: 0.01\ncomponents:\n  s: {type: \"tests.toys:Source\"}\n").components


def test_a_pond_of_many_bodies_is_told_that_its_bodies_take_the_memory(sixteen_gb):
    """Each body sharing a pond keeps its occupied height over the whole grid: a pond of 2000 x 2000
    cells with 500 bodies needs 16 GB for those alone, and the refusal says so, not "use a smaller
    grid" (the grid itself is 0.26 GB)."""
    names = ", ".join(f"b{k}" for k in range(500))
    with pytest.raises(ScenarioError) as err:
        loads(POND.format(nx=2000, ny=2000).replace("cell: 0.01}", f"cell: 0.01, bodies: [{names}]}}"))
    (problem,) = err.value.problems
    assert problem.endswith("allows (90%); most of it is the 500 bodies' occupied heights, each over the whole "
                            "grid (32 MB each): fewer bodies on one pond, or a smaller grid")
