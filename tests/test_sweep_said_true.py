"""What a sweep's table and figure say is true: a recording cell names a file that was written, and a
figure's reference point outside an axis's range is not drawn inside it."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from cosim.sweep.backends import Task, run_task
from cosim.sweep.figure import _placed, draw
from cosim.sweep.plan import load_sweep
from cosim.sweep.run import run_sweep
from tests.sweep_toys import BALL_SCENE, running_pool, write_sweep

# an axis laid out one cell a value (its gaps 1, 3 and 15 differ by more than figure.UNEVEN)
UNEVEN_SPEEDS = ["1", "2", "5", "20"]
CELLS = [0.0, 1.0, 2.0, 3.0]  # their positions; the last cell spans 2.5 .. 3.5


# -- defect 1: a recording cell for a run that never ran -------------------------------------------

@pytest.mark.parametrize(("overrides", "problem"), [
    ((), "derived.components.ball.speed: cannot evaluate 'sqrt(v - 1)': ValueError: math domain error"),
    (("components.ball.speed=-1",), None),
], ids=["derived-failed", "scene-refused"])
def test_a_point_that_never_ran_names_no_recording(tmp_path, overrides, problem):
    """A point whose derived values failed, or whose scene was refused at load, never ran: its row's
    recording cell is empty, even where an earlier run of the point left a file at that path."""
    recording = tmp_path / "p0.mcap"
    task = Task(0, "p0", BALL_SCENE, "ball.yaml", overrides, (), str(recording), "", problem)
    row = run_task(task)
    assert (row["status"], row["error_type"]) == ("failed", "ScenarioError")
    assert not row.get("recording") and not recording.exists()

    recording.write_bytes(b"left by an earlier run")
    assert not run_task(task).get("recording")


def test_every_recording_a_recorded_sweep_names_exists(tmp_path):
    """With --record, the rows of points that ran name their recording, which exists; the rows of
    points that never ran (a derived value that cannot be evaluated) name none."""
    body = ("scene: ball.yaml\naxes:\n  components.ball.fail_at_bounce: [0, 1]\n  v: [2.0, 0.1]\n"
            "derived:\n  components.ball.speed: \"sqrt(v - 1)\"\nuntil: 0.5\nrecord: true\n")
    sweep = load_sweep(write_sweep(tmp_path, body))
    out = tmp_path / "rec.csv"
    with running_pool(2) as pool:
        run_sweep(sweep, out, pool, progress=False, figure=False)
    with open(out, newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    never_ran = [r for r in rows if r["v"] == "0.1"]
    ran = [r for r in rows if r["v"] == "2.0"]
    assert len(never_ran) == len(ran) == 2
    assert [r["recording"] for r in never_ran] == ["", ""]
    assert all(r["recording"] and Path(r["recording"]).is_file() for r in ran)


def test_whether_a_sweep_runs_does_not_hang_on_the_order_of_its_axis_values(tmp_path):
    """A derived value that fails at the first point (sqrt(v - 1) at v = 0.5) refused the whole sweep,
    where the same failure at a later point was a failed row: [0.5, 2, 5] was refused, [2, 5, 0.5]
    ran. The sweep's scene is now checked at the first point whose derived values can be worked out;
    only when none can is the sweep refused."""
    from cosim.scenario import ScenarioError

    body = ("scene: ball.yaml\naxes:\n  v: [0.5, 2.0, 5.0]\n"
            "derived:\n  components.ball.speed: \"sqrt(v - 1)\"\nuntil: 0.2\n")
    sweep = load_sweep(write_sweep(tmp_path, body))
    assert [bool(p.problem) for p in sweep.points] == [True, False, False]
    assert "ball.bounces" in sweep.metrics
    with pytest.raises(ScenarioError, match=r"the first point \(v=0\.5\): derived\.components\.ball\.speed"):
        load_sweep(write_sweep(tmp_path, body.replace("[0.5, 2.0, 5.0]", "[0.5, 0.7]"), name="none.yaml"))


# -- defect 2: a reference point outside an unevenly spaced axis ----------------------------------

def test_a_value_beyond_an_uneven_axis_is_placed_beyond_its_end_cell():
    """On an axis laid out one cell a value, a value above its range lies beyond its last cell (on the
    line through the last two cells), one below it before its first cell; values inside the range lie
    between the cells about them, as before."""
    assert _placed(100.0, UNEVEN_SPEEDS, CELLS) > 3.5
    assert _placed(100.0, UNEVEN_SPEEDS, CELLS) == pytest.approx(3.0 + 80.0 / 15.0)
    assert _placed(0.0, UNEVEN_SPEEDS, CELLS) < -0.5
    assert _placed(10.0, UNEVEN_SPEEDS, CELLS) == pytest.approx(2.0 + 5.0 / 15.0)
    assert _placed(20.0, UNEVEN_SPEEDS, CELLS) == 3.0
    assert math.isnan(_placed(1.0, ["a", "b"], [0.0, 1.0]))


def test_the_figure_keeps_a_reference_point_beyond_the_axis_off_its_cells(tmp_path, monkeypatch):
    """Drawn on the heat map, a reference point at speed 100 (the axis ends at 20) is not in the cell
    of 20: it lies beyond the map's drawn area, and the legend says a point is not on the map; a point
    inside the range is drawn among the cells."""
    matplotlib = pytest.importorskip("matplotlib")
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    body = ("scene: ball.yaml\naxes:\n  components.ball.speed: [1, 2, 5, 20]\n"
            "  components.ball.angle_deg: [30, 60]\nmetrics: [\"ball.bounces\"]\n"
            "figure: {metric: ball.bounces, x: components.ball.speed, y: components.ball.angle_deg,\n"
            "         reference: {label: \"thrown\", points: [[100, 45], [10, 45]]}}\n")
    sweep = load_sweep(write_sweep(tmp_path, body))
    rows = [{"status": "ok", "components.ball.speed": speed, "components.ball.angle_deg": angle,
             "ball.bounces": "1"} for speed in UNEVEN_SPEEDS for angle in ("30", "60")]
    drawn = []
    subplots = plt.subplots
    monkeypatch.setattr(plt, "subplots", lambda *a, **k: drawn.append(subplots(*a, **k)) or drawn[-1])
    assert draw(sweep, rows, tmp_path / "f.png") is not None

    ax = drawn[0][1]
    stars = next(line for line in ax.get_lines() if line.get_marker() == "*")
    (far, near), left, right = stars.get_xdata(), *ax.get_xlim()
    assert (left, right) == (-0.5, 3.5) and far > right
    assert near == pytest.approx(2.0 + 5.0 / 15.0)
    assert stars.get_label() == "thrown (1 point outside the swept range: not on the map)"
