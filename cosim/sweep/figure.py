"""The summary figure of a sweep (PNG beside the table): one metric over one or two axes.

- two axes of a grid: a heat map (mean over any further axes), each cell labelled with its value;
  with a ``threshold``, the lowest y whose metric reaches it, for each x (e.g. the least speed that
  gives a skip at each attack angle: the magic-angle curve);
- one axis: the metric against it;
- random samples: the points, coloured by the metric.

Failed runs have no value: their cells are grey. matplotlib (the ``viz`` extra) is imported here only;
without it there is no figure, and the sweep says so.
"""

from __future__ import annotations

import itertools
import math
from collections import defaultdict
from pathlib import Path
from typing import Any

from cosim.errors import counted
from cosim.record.output import written_whole
from cosim.sweep.plan import Sweep

MAX_LABELLED_CELLS = 400  # above this many cells, the heat map's values are not written in them
UNEVEN = 3.0  # a numeric axis whose gaps differ by more than this factor is laid out one cell a value


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        return math.nan


def _positions(values: list[str], even_only: bool = False) -> tuple[list[str], list[float], bool]:
    """Distinct axis values in order, their plot positions, and whether those positions are the values
    themselves (a numeric axis). ``even_only``: a numeric axis whose values are unevenly spaced (gaps
    more than UNEVEN apart: a logspace) is laid out one position a value instead, as a heat map needs
    (at their values, 1e-4 .. 1 put three of five cells in a sliver at 0, their labels over each other)."""
    distinct = list(dict.fromkeys(values))
    numbers = [_number(v) for v in distinct]
    if all(math.isfinite(n) for n in numbers):
        pairs = sorted(zip(numbers, distinct, strict=True))
        ordered, at = [d for _, d in pairs], [n for n, _ in pairs]
        gaps = [b - a for a, b in itertools.pairwise(at)]
        if not (even_only and gaps and max(gaps) > UNEVEN * min(gaps)):
            return ordered, at, True
        return ordered, [float(i) for i in range(len(ordered))], False
    return distinct, [float(i) for i in range(len(distinct))], False


def _placed(value: float, labels: list[str], positions: list[float]) -> float:
    """Where a value [the axis's unit] falls on an axis laid out one position a value (``labels`` in
    ascending order): between the positions of the values about it, in proportion; outside the axis's
    range, on the line through its two end positions, so beyond its end cell (np.interp alone would
    clamp it onto the end cell, drawing 100 in the cell of 20). nan off a non-numeric axis, and for a
    value other than the only one of a one-value axis (no scale to place it by)."""
    import numpy as np

    numbers = [_number(v) for v in labels]
    if not all(math.isfinite(n) for n in numbers):
        return math.nan
    if numbers[0] <= value <= numbers[-1]:
        return float(np.interp(value, numbers, positions))
    if len(numbers) < 2:
        return math.nan
    end, inner = (0, 1) if value < numbers[0] else (-1, -2)
    per_unit = (positions[end] - positions[inner]) / (numbers[end] - numbers[inner])
    return positions[end] + (value - numbers[end]) * per_unit


def _within(position: float, edges: list[float]) -> bool:
    """Whether a position lies on the drawn cells of an axis whose cell edges are ``edges`` (False for nan)."""
    return edges[0] <= position <= edges[-1]


def _edges(centres: list[float]) -> list[float]:
    if len(centres) == 1:
        return [centres[0] - 0.5, centres[0] + 0.5]
    mids = [(a + b) / 2 for a, b in itertools.pairwise(centres)]
    return [2 * centres[0] - mids[0], *mids, 2 * centres[-1] - mids[-1]]


def draw(sweep: Sweep, rows: list[dict[str, str]], path: Path) -> Path | None:
    """Draw the figure of ``sweep.figure`` from the table's rows into ``path``; None without matplotlib."""
    spec = sweep.figure
    if spec is None or not rows:
        return None
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return None
    fig, ax = plt.subplots(figsize=(7.5, 5.5), dpi=110)
    try:
        if sweep.mode == "random":
            _scatter(ax, fig, rows, spec)
        elif spec.y is None:
            _line(ax, rows, spec)
        else:
            place = _heat_map(ax, fig, rows, spec)
        if spec.reference_points:
            _reference(ax, spec, place if sweep.mode != "random" and spec.y is not None else None)
        if ax.get_legend_handles_labels()[0]:  # below the axes, so no cell is hidden
            ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, fontsize=8, frameon=False)
        _mark_cut_short(ax, rows, spec, sweep.mode == "random")
        failed = sum(r["status"] == "failed" for r in rows)
        note = f"; {failed} failed{' (grey)' if spec.y is not None else ''}" if failed else ""
        cut = sum(_cut_short(r) for r in rows)
        note += f"; {cut} reached the edge of the domain (marked)" if cut else ""
        ax.set_title(f"{sweep.name}: {spec.metric} ({len(rows)} runs{note})", fontsize=10)
        fig.tight_layout()
        path.parent.mkdir(parents=True, exist_ok=True)
        with written_whole(path) as tmp:  # a failed write leaves no half a picture behind
            fig.savefig(tmp, format=path.suffix.removeprefix(".") or plt.rcParams["savefig.format"])
    finally:
        plt.close(fig)
    return path


EDGE_METRIC = ".reached_edge"  # a component's metric: 1 when the run was cut short by its domain's edge


def _cut_short(row: dict[str, str]) -> bool:
    """Whether a run ended at the edge of its domain (its figures are then lower bounds)."""
    return any(k.endswith(EDGE_METRIC) and v.strip() in ("1", "true") for k, v in row.items())


def _mark_cut_short(ax: Any, rows: list[dict[str, str]], spec: Any, scattered: bool) -> None:
    """Mark the runs that reached the edge of their domain with a red ring where they are drawn."""
    cut = [r for r in rows if _cut_short(r)]
    if not cut:
        return
    if spec.y is None:
        xs, xpos, _ = _positions([r[spec.x] for r in rows])
        points = [(xpos[xs.index(r[spec.x])] if not scattered else _number(r[spec.x]), _value(r, spec.metric))
                  for r in cut]
    elif scattered:
        points = [(_number(r[spec.x]), _number(r[spec.y])) for r in cut]
    else:
        xs, xpos, _ = _positions([r[spec.x] for r in rows], even_only=True)
        ys, ypos, _ = _positions([r[spec.y] for r in rows], even_only=True)
        points = [(xpos[xs.index(r[spec.x])], ypos[ys.index(r[spec.y])]) for r in cut]
    ax.plot(*zip(*points, strict=True), "o", markersize=15, markerfacecolor="none", markeredgecolor="tab:red",
            markeredgewidth=1.6, label="reached the edge of the water: a lower bound", zorder=4)


def _value(row: dict[str, str], metric: str) -> float:
    return _number(row[metric]) if row["status"] != "failed" else math.nan


def _reference(ax: Any, spec: Any, place: Any) -> None:
    """Overlay the reference points as stars: onto the heat map's cells by ``place`` (from
    :func:`_heat_map`), or as given when None. Points outside the swept range are not on the map: the
    legend says how many, as a star missing from the picture would otherwise go unnoticed."""
    xs, ys = zip(*spec.reference_points, strict=True)
    label = spec.reference_label
    if place is not None:
        xs, ys, outside = place(xs, ys)
        if outside:
            label += f" ({counted(outside, 'point')} outside the swept range: not on the map)"
    ax.plot(xs, ys, "*", color="tab:red", markersize=13, markeredgecolor="k", label=label, zorder=5)


def _heat_map(ax: Any, fig: Any, rows: list[dict[str, str]], spec: Any) -> Any:
    """Draw the heat map; returns how to place points given in the axes' values onto it: their
    positions and how many lie off its cells. An axis laid out one cell a value keeps to its cells (a
    point beyond them is not drawn: past the last cell that axis has no scale to show it on); a
    numeric axis grows to show such a point at its value."""
    import numpy as np

    xs, xpos, xnum = _positions([r[spec.x] for r in rows], even_only=True)
    ys, ypos, ynum = _positions([r[spec.y] for r in rows], even_only=True)
    cells: dict[tuple[str, str], list[float]] = defaultdict(list)
    for r in rows:
        value = _value(r, spec.metric)
        if math.isfinite(value):
            cells[(r[spec.x], r[spec.y])].append(value)
    grid = np.full((len(ys), len(xs)), np.nan)
    for (x, y), values in cells.items():
        grid[ys.index(y), xs.index(x)] = sum(values) / len(values)
    cmap = __import__("matplotlib").colormaps["viridis"].with_extremes(bad="0.85")
    x_edges, y_edges = _edges(xpos), _edges(ypos)
    mesh = ax.pcolormesh(x_edges, y_edges, np.ma.masked_invalid(grid), cmap=cmap, shading="flat")
    fig.colorbar(mesh, ax=ax, label=_averaged(spec.metric, cells.values()))
    if grid.size <= MAX_LABELLED_CELLS:
        finite = grid[np.isfinite(grid)]
        middle = (finite.min() + finite.max()) / 2 if finite.size else 0.0
        for i, y in enumerate(ypos):
            for j, x in enumerate(xpos):
                v = grid[i, j]
                if math.isfinite(v):
                    ax.text(x, y, f"{v:.3g}", ha="center", va="center", fontsize=7,
                            color="white" if v < middle else "black")
    if spec.threshold is not None:
        line_x, line_y = [], []
        for j, x in enumerate(xpos):
            reached = [ypos[i] for i in range(len(ypos))
                       if math.isfinite(grid[i, j]) and grid[i, j] >= spec.threshold]
            if reached:
                line_x.append(x)
                line_y.append(min(reached))
        ax.plot(line_x, line_y, "o-", color="tab:orange", markeredgecolor="k",
                label=f"lowest {spec.y} with {spec.metric} >= {spec.threshold:g}")
    ax.set_xlabel(spec.x)
    ax.set_ylabel(spec.y)
    if not xnum:
        ax.set_xticks(xpos, xs, rotation=30)
        ax.set_xlim(x_edges[0], x_edges[-1])
    if not ynum:
        ax.set_yticks(ypos, ys)
        ax.set_ylim(y_edges[0], y_edges[-1])

    def place(x_values: Any, y_values: Any) -> tuple[list[float], list[float], int]:
        px = [float(v) if xnum else _placed(float(v), xs, xpos) for v in x_values]
        py = [float(v) if ynum else _placed(float(v), ys, ypos) for v in y_values]
        # (a numeric axis grows to show a point beyond its cells: only the one-cell-a-value axes leave it off)
        outside = sum(not ((xnum or _within(x, x_edges)) and (ynum or _within(y, y_edges)))
                      for x, y in zip(px, py, strict=True))
        return px, py, outside
    return place


def _averaged(metric: str, groups: Any) -> str:
    """The label of ``metric`` drawn one value a cell (or a point of a line), ``groups`` each cell's
    values: "mean of METRIC over N runs a cell" where a cell holds several runs (the sweep's other
    axes), which the figure otherwise drew as if one run's, the metric's name alone."""
    most = max((len(values) for values in groups), default=1)
    return f"mean of {metric} over up to {most} runs a cell (the other axes)" if most > 1 else metric


def _line(ax: Any, rows: list[dict[str, str]], spec: Any) -> None:
    xs, xpos, xnum = _positions([r[spec.x] for r in rows])
    sums: dict[str, list[float]] = defaultdict(list)
    for r in rows:
        value = _value(r, spec.metric)
        if math.isfinite(value):
            sums[r[spec.x]].append(value)
    points = [(p, sum(sums[x]) / len(sums[x])) for x, p in zip(xs, xpos, strict=True) if sums[x]]
    if points:
        ax.plot(*zip(*points, strict=True), "o-")
    failed = sorted({xpos[xs.index(r[spec.x])] for r in rows if r["status"] == "failed"})
    if failed:  # along the bottom edge: they have no value to plot
        from matplotlib.transforms import blended_transform_factory

        ax.plot(failed, [0.03] * len(failed), "x", color="tab:red", markersize=9, label="failed",
                transform=blended_transform_factory(ax.transData, ax.transAxes))
    ax.set_xlabel(spec.x)
    ax.set_ylabel(_averaged(spec.metric, sums.values()))
    if not xnum:
        ax.set_xticks(xpos, xs, rotation=30)
    ax.grid(alpha=0.3)


def _scatter(ax: Any, fig: Any, rows: list[dict[str, str]], spec: Any) -> None:
    x = [_number(r[spec.x]) for r in rows]
    values = [_value(r, spec.metric) for r in rows]
    if spec.y is None:
        ax.plot(x, values, "o", alpha=0.7)
        ax.set_ylabel(spec.metric)
    else:
        y = [_number(r[spec.y]) for r in rows]
        ok = [i for i, v in enumerate(values) if math.isfinite(v)]
        bad = [i for i, v in enumerate(values) if not math.isfinite(v)]
        if bad:
            ax.plot([x[i] for i in bad], [y[i] for i in bad], "x", color="0.6", label="failed / no value")
        sc = ax.scatter([x[i] for i in ok], [y[i] for i in ok], c=[values[i] for i in ok],
                        cmap="viridis", s=22)
        fig.colorbar(sc, ax=ax, label=spec.metric)
        ax.set_ylabel(spec.y)
    ax.set_xlabel(spec.x)
    ax.grid(alpha=0.3)
