"""Runs cut short by the edge of their water are told apart in sweeps: the stage monitor's
``reached_edge`` column, and a red ring on the sweep figure with a count in its title."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from cosim.sweep.figure import _cut_short, _mark_cut_short, draw


def rows(cut: set[tuple[str, str]]) -> list[dict[str, str]]:
    return [{"status": "stopped", "attack": a, "speed": s, "stages.skips": "3",
             "stages.reached_edge": "1" if (a, s) in cut else "0"}
            for a in ("10", "20") for s in ("4", "8")]


def test_a_run_is_cut_short_only_when_a_component_says_so():
    assert _cut_short({"stages.reached_edge": "1"}) and _cut_short({"x.reached_edge": "true"})
    assert not _cut_short({"stages.reached_edge": "0"}) and not _cut_short({"stages.skips": "1"})


def test_the_figure_rings_the_runs_that_reached_the_edge():
    plt = pytest.importorskip("matplotlib.pyplot")
    fig, ax = plt.subplots()
    spec = SimpleNamespace(x="attack", y="speed", metric="stages.skips")
    _mark_cut_short(ax, rows({("20", "8"), ("10", "8")}), spec, scattered=False)
    (ring,) = [line for line in ax.get_lines() if "edge" in line.get_label()]
    assert sorted(zip(ring.get_xdata(), ring.get_ydata(), strict=True)) == [(10.0, 8.0), (20.0, 8.0)]
    plt.close(fig)


def test_the_figure_title_counts_them(tmp_path, monkeypatch):
    plt = pytest.importorskip("matplotlib.pyplot")
    titles = []
    monkeypatch.setattr(plt.Axes, "set_title", lambda self, text, **kw: titles.append(text))
    spec = SimpleNamespace(x="attack", y="speed", metric="stages.skips", threshold=None, reference_points=None,
                           reference_label=None)
    sweep = SimpleNamespace(figure=spec, mode="grid", name="grid")
    assert draw(sweep, rows({("20", "8")}), tmp_path / "f.png") == tmp_path / "f.png"
    assert titles == ["grid: stages.skips (4 runs; 1 reached the edge of the domain (marked))"]


def test_the_skip_grid_keeps_its_longest_throw_on_the_water():
    """The skip-grid sweep's longest throw (10 m/s at 10 deg of attack, about 22 m) sinks on its pond
    instead of reaching the far edge."""
    from pathlib import Path

    from cosim.scenario import loads
    from cosim.scheduler import Simulation
    from cosim.sweep.plan import load_sweep

    sweep = load_sweep(Path(__file__).resolve().parent.parent / "scenarios" / "sweeps" / "skip_grid.yaml")
    (point,) = [p for p in sweep.points if p.values == {"attack": 10, "speed": 10}]
    sim = Simulation(loads(sweep.scene_text, sweep.scene_source, list(point.overrides)))
    sim.run()
    metrics = sim.components["stages"].metrics()
    assert metrics["reached_edge"] == 0 and metrics["outcome"] == "sink"
    assert metrics["distance"] > 20.0


def test_a_heat_map_lays_out_an_unevenly_spaced_axis_one_cell_a_value(tmp_path):
    """A logspace axis (1e-4 .. 1) makes a heat map of equal cells, labelled with their values, and a
    reference point given in the axis's values lands between the cells of the values about it; at
    their values three of five cells were a sliver at 0, their labels over each other. An evenly
    spaced axis stays at its values."""
    plt = pytest.importorskip("matplotlib.pyplot")
    c_f = ["0.0001", "0.001", "0.01", "0.1", "1.0"]
    grid = [{"status": "stopped", "c_f": c, "speed": s, "stages.skips": "2"} for c in c_f for s in ("4", "6", "8")]
    spec = SimpleNamespace(x="c_f", y="speed", metric="stages.skips", threshold=None,
                           reference_points=[(0.0055, 6.0)], reference_label="published")
    plots, xticks = {}, []
    real_plot = plt.Axes.plot

    def watch(self, *args, **kw):
        plots[kw.get("label")] = args
        return real_plot(self, *args, **kw)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(plt.Axes, "plot", watch)
        patch.setattr(plt.Axes, "set_xticks", lambda self, ticks, labels=None, **kw: xticks.append((ticks, labels)))
        draw(SimpleNamespace(figure=spec, mode="grid", name="grid"), grid, tmp_path / "f.png")
    ((ticks, labels),) = xticks
    assert list(ticks) == [0.0, 1.0, 2.0, 3.0, 4.0] and list(labels) == c_f
    xs, ys = plots["published"][:2]
    assert xs[0] == pytest.approx(1.0 + (0.0055 - 0.001) / (0.01 - 0.001)) and ys == [6.0]  # between 0.001 and 0.01
    from cosim.sweep.figure import _positions

    assert _positions(["2", "4", "6"], even_only=True) == (["2", "4", "6"], [2.0, 4.0, 6.0], True)
    assert _positions(["0.03", "-1", "0.05"], even_only=True)[1:] == ([0.0, 1.0, 2.0], False)
