"""The sweep audit's findings: a table written by one sweep at a time, finished for the points it
holds, typed as the sweep declares, resumed without losing or inventing results; sweep files refused
where they would write outside runs/ or repeat a value."""

from __future__ import annotations

import csv
import errno
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.errors import ScenarioError
from cosim.sweep.plan import load_sweep, point_id
from cosim.sweep.run import run_sweep
from tests.sweep_toys import read_table, running_pool, write_sweep

THREE = """
scene: ball.yaml
axes:
  components.ball.speed: [2, 3, 5]
"""


@pytest.fixture(scope="module")
def pool():
    """One worker process, shared by the tests of this file."""
    with running_pool(1) as backend:
        yield backend


def run(sweep, out: Path, pool, **options):
    return run_sweep(sweep, out, pool, progress=False, figure=False, **options)


def rows_of(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


# --- 1: one sweep at a time writes a table ---------------------------------------------------------

def _hold_lock(path: Path) -> subprocess.Popen:
    """A process that holds an exclusive flock on ``path`` (as a sweep running holds its table's) until
    killed; returned once it holds it."""
    code = ("import fcntl, os, sys, time\n"
            f"fd = os.open({str(path)!r}, os.O_RDWR | os.O_CREAT)\n"
            "fcntl.flock(fd, fcntl.LOCK_EX)\n"
            "print('held', flush=True)\n"
            "time.sleep(600)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline() == "held\n"
    return proc


def test_a_sweep_on_a_table_another_sweep_is_writing_is_refused_and_a_dead_ones_lock_does_not_block(
        tmp_path, capsys):
    """Two sweeps writing one table lost rows and both said they were done: the second is refused (exit
    2, one line, nothing written) while the first holds the table's lock; once the process holding it
    is gone (killed: its lock file left behind), the sweep runs, and leaves no lock file."""
    path = write_sweep(tmp_path, THREE)
    out = tmp_path / "t.csv"
    holder = _hold_lock(tmp_path / "t.lock")
    try:
        assert main(["sweep", str(path), "-q", "--workers", "1", "--no-figure", "-o", str(out)]) == 2
        err = capsys.readouterr().err
        assert err == (f"error: {out}: another sweep is writing it now (it holds t.lock beside it); wait for it "
                       "to end, or give -o another file\n")
        assert not out.exists() and not (tmp_path / "t.meta.json").exists()
    finally:
        holder.kill()
        holder.wait()
        holder.stdout.close()
    assert (tmp_path / "t.lock").exists()  # left by the killed holder
    assert main(["sweep", str(path), "-q", "--workers", "1", "--no-figure", "-o", str(out)]) == 0
    assert len(rows_of(out)) == 3 and not (tmp_path / "t.lock").exists()


def test_rows_of_points_not_in_the_sweep_are_not_dropped_unsaid_when_it_finishes(tmp_path):
    """A row appended by a sweep of other points (one that took no lock) was dropped without a word
    when the table was finished; now the finish is refused, the journal left with every row."""
    from cosim.sweep.table import ResultTable, meta_path

    columns = ["index", "point_id", "status", "reason", "wall_s"]
    out = tmp_path / "t.csv"
    meta_path(out).write_text(json.dumps({"fingerprint": "fp"}))
    table = ResultTable(out, columns, {"fingerprint": "fp"})
    order = {"p0": 0, "p1": 1}
    table.open(order)
    for i, point in enumerate(["p0", "p1", "p9"]):  # p9: another sweep's point
        table.append({"index": i, "point_id": point, "status": "ok", "reason": "done", "wall_s": 0.5})
    with pytest.raises(ScenarioError, match=r"t\.csv: holds 1 row of points that are not in this sweep \(e\.g\. "
                                            r"p9\), written by another command meanwhile; the table is left as it is"):
        table.finish(order, {})
    table.release()
    assert [r["point_id"] for r in rows_of(out)] == ["p0", "p1", "p9"]


# --- 2: an extended table is finished for its points --------------------------------------------------

@pytest.mark.parametrize("cut", ["disk-full-at-finish", "interrupted-writing-parquet"])
def test_an_extended_sweep_whose_finish_was_cut_short_is_finished_by_the_same_command_again(
        tmp_path, pool, monkeypatch, cut):
    """A finished sweep extended with more points, whose finish failed (the disk full) or was cut short
    (Ctrl-C while the Parquet file was written), kept the earlier finish's Parquet file and counts for
    good: the next command took the table for finished. Now it finishes it: every point in the Parquet
    file and the counts."""
    pq = pytest.importorskip("pyarrow.parquet")
    import cosim.sweep.table as table

    out = tmp_path / "t.parquet"
    run(load_sweep(write_sweep(tmp_path, THREE), output=out), out, pool)
    longer = load_sweep(write_sweep(tmp_path, THREE.replace("[2, 3, 5]", "[2, 3, 5, 7]"), name="b.yaml"), output=out)
    with monkeypatch.context() as patch:
        if cut == "disk-full-at-finish":
            def full(self, *args):
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.path))

            patch.setattr(table.ResultTable, "_finish", full)
            with pytest.raises(Exception, match="No space left on device"):
                run(longer, out, pool)
        else:
            def interrupted(*args):
                raise KeyboardInterrupt

            patch.setattr(table, "write_parquet", interrupted)
            with pytest.raises(KeyboardInterrupt):
                run(longer, out, pool)
    again = run(longer, out, pool)
    assert again.complete and (again.already, again.ran) == (4, 0)
    assert pq.read_table(out).num_rows == 4
    assert json.loads((tmp_path / "t.meta.json").read_text())["counts"] == {"stopped": 4}


# --- 3: Parquet columns typed as the sweep declares them ------------------------------------------

def _speed_whose_id_reads_as_a_number(other: dict[str, str]) -> float:
    """A ball speed whose point id (with the ``other`` axis values) Python reads as a number (such as
    974675670973 or 87885e489738)."""
    for k in range(1, 100_000):
        speed = 2 + k / 1000
        try:
            float(point_id({"components.ball.speed": speed, **other}))
        except ValueError:
            continue
        return speed
    raise AssertionError("no such speed")


def test_parquet_columns_are_typed_as_the_sweep_declares_not_guessed_from_the_values(tmp_path, pool):
    """A point id of hex digits that read as a number became a double (11e755065873 was inf), an axis
    of texts of digits became int64: a column's type is what the sweep declares (ids, statuses and text
    metrics strings; axes by their values; number metrics numbers)."""
    pq = pytest.importorskip("pyarrow.parquet")
    other = {"components.ball.disk_full_while": "00"}  # a text of digits (no such file: no disk is full)
    speed = _speed_whose_id_reads_as_a_number(other)
    body = f"scene: ball.yaml\naxes:\n  components.ball.speed: [{speed!r}]\n  components.ball.disk_full_while: ['00']\n"
    out = tmp_path / "t.parquet"
    run(load_sweep(write_sweep(tmp_path, body), output=out), out, pool)
    table = pq.read_table(out)
    types = {field.name: str(field.type) for field in table.schema}
    assert types["point_id"] == "string" and table.column("point_id").to_pylist() == [
        point_id({"components.ball.speed": speed, **other})]
    assert types["components.ball.disk_full_while"] == "string"
    assert table.column("components.ball.disk_full_while").to_pylist() == ["00"]
    assert types["components.ball.speed"] == "double"
    for name in ("status", "reason", "error_type", "ball.outcome"):
        assert types[name] == "string", name
    assert (types["index"], types["ticks"], types["ball.bounces"]) == ("int64", "int64", "int64")
    assert (types["sim_time_s"], types["ball.distance"], types["wall_s"]) == ("double", "double", "double")


# --- 4, 5, 6: resuming keeps whole rows, runs interrupted ones again, refuses edited ones ----------

def test_a_whole_last_row_without_its_line_break_is_kept(tmp_path, pool):
    """A table whose last row is whole but has no line break after it (an editor took it away): the
    row was deleted and its point run again; now it is kept, and the table ends with a line break."""
    sweep = load_sweep(write_sweep(tmp_path, THREE))
    out = tmp_path / "t.csv"
    run(sweep, out, pool)
    whole = out.read_text()
    out.write_text(whole.removesuffix("\n"))
    again = run(sweep, out, pool)
    assert (again.already, again.ran) == (3, 0)
    assert out.read_text() == whole


def test_an_interrupted_row_is_no_result_its_point_runs_again(tmp_path, pool):
    """README: interrupted runs are not kept, they run again on resume. A row with status interrupted
    was taken as the point's result (never run again, counted "1 interrupted"); now its point runs
    again, the summary says so, and the table ends as a sweep never interrupted writes it."""
    sweep = load_sweep(write_sweep(tmp_path, THREE))
    out = tmp_path / "t.csv"
    run(sweep, out, pool)
    expected = read_table(out)
    lines = out.read_text().splitlines(keepends=True)
    lines[2] = lines[2].replace(",stopped,", ",interrupted,", 1)
    out.write_text("".join(lines))
    again = run(sweep, out, pool)
    assert (again.already, again.ran) == (2, 1)
    assert again.dropped == 1
    assert again.counts == {"stopped": 3}
    assert "ran 1, 2 already in the table (1 interrupted run found in it, no result: run again)" in again.summary()
    assert read_table(out) == expected


def test_an_edited_axis_value_is_refused_naming_the_line_the_column_and_both_values(tmp_path, pool):
    """A row whose axis value was edited by hand was kept and plotted at the edited value, as the
    result of a point that never ran there; now the table is refused, and left as it is."""
    sweep = load_sweep(write_sweep(tmp_path, THREE))
    out = tmp_path / "t.csv"
    run(sweep, out, pool)
    lines = out.read_text().splitlines(keepends=True)
    row = next(csv.reader([lines[2]]))
    row[2] = "9"  # the speed, 3 at this point
    lines[2] = ",".join(row) + "\n"
    edited = "".join(lines)
    out.write_text(edited)
    with pytest.raises(ScenarioError, match=rf"t\.csv: line 3: column components\.ball\.speed holds '9' where point "
                                            rf"{row[1]} has '3' \(the table was edited\?\).*--fresh"):
        run(sweep, out, pool)
    assert out.read_text() == edited


# --- 7: a full disk is the machine's limit, named, with the way on ---------------------------------

class _DiskFillsUp:
    """The table's journal on a disk that fills after ``rows`` writes: the next write gets to the file
    whole, and then the disk refuses it (an OSError naming no file, as a full disk gives)."""

    def __init__(self, file, rows: int):
        self.file, self.left = file, rows

    def write(self, text):
        return self.file.write(text)

    def flush(self):
        self.file.flush()
        if self.left == 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.left -= 1

    def fileno(self):
        return self.file.fileno()

    def close(self):
        self.file.close()


def test_a_disk_that_fills_while_rows_are_written_names_the_table_and_says_how_to_resume(
        tmp_path, monkeypatch, capsys):
    """A full disk while rows were appended said "cosim sweep: its output: cannot be written", naming no
    file and no way on. Now the sweep stops as for a full disk under the recordings: it names the
    table, exits 1, says the same command resumes; the row the disk refused is not left in part."""
    import builtins

    import cosim.sweep.table as table

    def filling(file, mode="r", *args, **kwargs):
        opened = builtins.open(file, mode, *args, **kwargs)
        return _DiskFillsUp(opened, rows=3) if mode == "a" else opened  # the header and two rows

    path = write_sweep(tmp_path, THREE)
    out = tmp_path / "t.csv"
    command = ["sweep", str(path), "-q", "--workers", "1", "--no-figure", "-o", str(out)]
    with monkeypatch.context() as patch:
        patch.setattr(table, "open", filling, raising=False)
        assert main(command) == 1
    captured = capsys.readouterr()
    assert captured.err.endswith(
        f"error: cosim sweep: stopped, the machine has no room for the table {out} (No space left on device): 1 of "
        "3 points left; they run when the same command is run again once there is room\n")
    assert len(rows_of(out)) == 2 and out.read_text().endswith("\n")
    assert main(command) == 0
    assert len(rows_of(out)) == 3


@pytest.mark.parametrize("when", ["open", "finish"])
def test_a_full_disk_when_the_table_is_started_or_finished_exits_1_naming_it(tmp_path, monkeypatch, capsys, when):
    """A full disk when the table's record was written or the table finished was bad input (exit 2);
    it is the machine's limit: exit 1, naming the table, saying the same command goes on."""
    import cosim.sweep.table as table

    def full(self, *args):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self.meta_path if when == "open" else self.path))

    path = write_sweep(tmp_path, THREE)
    out = tmp_path / "t.csv"
    command = ["sweep", str(path), "-q", "--workers", "1", "--no-figure", "-o", str(out)]
    with monkeypatch.context() as patch:
        patch.setattr(table.ResultTable, "_write_meta" if when == "open" else "_finish", full)
        assert main(command) == 1
    said = {"open": "cannot write the sweep's results (t.meta.json beside it: No space left on device); run the same "
                    "command again once there is room to resume the sweep",
            "finish": "cannot write the sweep's finished table (No space left on device); its rows are kept: run "
                      "the same command again to finish it"}[when]
    assert capsys.readouterr().err == f"error: {out}: {said}\n"
    assert main(command) == 0
    assert len(rows_of(out)) == 3


# --- 8-11: sweep files refused -----------------------------------------------------------------

@pytest.mark.parametrize("name", ["../../escaped", "a/b", "..", ".hidden"])
def test_a_sweep_name_that_is_no_safe_file_name_is_refused(tmp_path, name):
    """The name makes the default table runs/NAME.csv: "../../escaped" wrote outside runs/. It is
    refused as a scene's name is."""
    with pytest.raises(ScenarioError, match=r"name: must be letters, digits, _, - and \. \(not first\), at most "
                                            rf"100 characters, no '\.\.': it names the table's file \(got '{name}'\)"):
        load_sweep(write_sweep(tmp_path, THREE + f"name: {name!r}\n"))


def test_dask_local_workers_have_the_process_pools_bound(tmp_path, monkeypatch, capsys):
    """--dask local --workers N started a cluster of any N (the bound was skipped with --dask): refused
    as the process pool refuses it, before any cluster starts."""
    import cosim.sweep.backends as backends
    from cosim.sweep.command import CORES, MAX_WORKERS_PER_CORE

    def no_cluster(*args, **kwargs):
        raise AssertionError("a backend was made")

    monkeypatch.setattr(backends, "make_backend", no_cluster)
    path = write_sweep(tmp_path, THREE)
    too_many = MAX_WORKERS_PER_CORE * CORES + 1
    assert main(["sweep", str(path), "--dask", "local", "--workers", str(too_many), "-q"]) == 2
    assert capsys.readouterr().err.startswith(f"error: cosim sweep: --workers {too_many}: at most "
                                              f"{MAX_WORKERS_PER_CORE * CORES} on this machine's {CORES} cores")


@pytest.mark.parametrize("values", ["[2, 2.0]", "[[1, 2], [1.0, 2]]", "[.nan, .nan]"])
def test_an_axis_that_repeats_a_value_written_otherwise_is_refused(tmp_path, values):
    """[10, 10.0] passed the check of repeated values (it compared their YAML text): two points of one
    value, with two ids. Numbers are compared by value."""
    with pytest.raises(ScenarioError, match=r"axes\.components\.ball\.speed: repeats a value"):
        load_sweep(write_sweep(tmp_path, f"scene: ball.yaml\naxes:\n  components.ball.speed: {values}\n"))


def test_an_unknown_key_of_the_figures_reference_is_refused(tmp_path):
    """lable: and colour: under figure.reference were taken without a word (the label fell back to
    "reference"): each is named, with the keys it knows."""
    body = THREE + "figure: {reference: {lable: Clanet, points: [[3, 1]], colour: red}}\n"
    with pytest.raises(ScenarioError) as info:
        load_sweep(write_sweep(tmp_path, body))
    assert info.value.problems == ["figure.reference.lable: unknown key (known: label, points)",
                                   "figure.reference.colour: unknown key (known: label, points)"]


def test_the_lock_is_held_for_the_whole_sweep_and_let_go_after(tmp_path, pool):
    """The lock is held from the table's opening to its finish (another sweep started meanwhile is
    refused), and let go when the sweep returns, finished or stopped."""
    sweep = load_sweep(write_sweep(tmp_path, THREE))
    out = tmp_path / "t.csv"
    seen = []

    def try_another(rows: int) -> None:
        try:
            run(sweep, out, pool)
        except ScenarioError as exc:
            seen.append(str(exc))

    run(sweep, out, pool)
    run(sweep, out, pool, on_resume=try_another)
    assert len(seen) == 1 and "another sweep is writing it now" in seen[0]
    assert not (tmp_path / "t.lock").exists()
    assert run(sweep, out, pool).complete


def test_a_figure_drawing_several_runs_a_cell_says_it_draws_their_mean(tmp_path, monkeypatch):
    """A heat map of attack x speed over a sweep with a third axis holds two runs a cell: its colour bar
    says it draws their mean (it was labelled with the metric alone, every cell 0.5 looking like a
    run's value); a cell of one run each keeps the metric's name."""
    plt = pytest.importorskip("matplotlib.pyplot")
    from types import SimpleNamespace

    from cosim.sweep.figure import draw

    labels = []
    colorbar = plt.Figure.colorbar
    monkeypatch.setattr(plt.Figure, "colorbar", lambda self, *a, **kw: (labels.append(kw.get("label")),
                                                                        colorbar(self, *a, **kw))[1])
    spec = SimpleNamespace(x="attack", y="speed", metric="stages.skips", threshold=None, reference_points=None,
                           reference_label=None)
    sweep = SimpleNamespace(figure=spec, mode="grid", name="three")
    rows = [{"status": "stopped", "attack": a, "speed": s, "until": u, "stages.skips": str(int(u == "1"))}
            for a in ("10", "20") for s in ("4", "8") for u in ("0.5", "1")]
    draw(sweep, rows, tmp_path / "three.png")
    draw(sweep, [r for r in rows if r["until"] == "1"], tmp_path / "two.png")
    assert labels == ["mean of stages.skips over up to 2 runs a cell (the other axes)", "stages.skips"]
