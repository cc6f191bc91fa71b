"""`cosim sweep`: exit codes 0/1/2, one-line errors, resuming, and Ctrl-C keeping what was done."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import cosim.sweep.backends
from cosim.cli import main
from tests.sweep_toys import interrupt_sweep, write_sweep

ROOT = Path(__file__).resolve().parents[1]

SWEEP = """
scene: ball.yaml
axes:
  components.ball.angle_deg: [30, 60]
  components.ball.speed: [2, 3, 5]
output: results/balls.csv
"""


def test_sweep_runs_reports_and_resumes(tmp_path, monkeypatch, capsys):
    """`cosim sweep` exits 0 and prints the points, statuses, table and figure; run again, it says the
    table holds every point and runs nothing; --fresh runs everything again."""
    monkeypatch.chdir(tmp_path)
    path = write_sweep(tmp_path, SWEEP)
    assert main(["sweep", str(path), "-q", "--workers", "2"]) == 0
    out = capsys.readouterr().out
    assert ("sweep: 6 points (grid of 2 components.ball.angle_deg x 3 components.ball.speed) "
            "on process pool of 2 workers") in out
    assert "ran 6, 0 already in the table; 6 stopped;" in out and "table: results/balls.csv" in out
    # the sweep's wall over its runs, and each run's own time in its worker (two run at once)
    import re

    said = re.search(r"\(([0-9.e-]+) s a run; on average ([0-9.e-]+) s in its worker\)", out)
    per_run, own = map(float, said.groups())
    assert per_run > 0 and own > 0
    assert (tmp_path / "results" / "balls.csv").exists()
    assert (tmp_path / "results" / "balls.meta.json").exists()
    assert main(["sweep", str(path), "-q", "--workers", "2"]) == 0
    captured = capsys.readouterr()
    assert "results/balls.csv holds every point of this sweep: nothing to run" in captured.err
    assert "ran 0, 6 already in the table" in captured.out
    assert "process pool" not in captured.out  # nothing ran on it
    assert main(["sweep", str(path), "-q", "--workers", "2", "--fresh", "--no-figure"]) == 0
    assert "ran 6, 0 already" in capsys.readouterr().out


def test_fresh_takes_the_old_tables_figure_and_recordings_with_it(tmp_path, monkeypatch):
    """--fresh discards the table it replaces together with the figure it drew and the recordings its
    rows name in the runs folder: a new sweep written there with --no-figure (or cut short) left the
    old sweep's figure beside its table, and its recordings with them. A file of the user's in that
    folder stays."""
    monkeypatch.chdir(tmp_path)
    path = write_sweep(tmp_path, SWEEP)
    assert main(["sweep", str(path), "-q", "--workers", "2", "--record"]) == 0
    figure, runs = tmp_path / "results" / "balls.png", tmp_path / "results" / "balls_runs"
    recorded = sorted(runs.glob("*.mcap"))
    assert figure.exists() and len(recorded) == 6
    (runs / "notes.txt").write_text("mine")
    assert main(["sweep", str(path), "-q", "--workers", "2", "--fresh", "--no-figure"]) == 0
    assert not figure.exists() and sorted(runs.glob("*.mcap")) == [] and (runs / "notes.txt").exists()


@pytest.mark.parametrize(("first", "then", "said"), [
    ([], ["--record"], "was started without --record (its rows have no recordings): resume it without --record"),
    (["--record"], [], "was started with --record (its rows name their recordings): resume it with --record"),
])
def test_resuming_with_or_without_record_the_other_way_says_so(tmp_path, capsys, first, then, said):
    """The same sweep resumed with --record when it was started without (or the other way round): the
    table's columns differ by its recording column, and the error says that (it said the table held a
    different sweep, its scene or set differing)."""
    path, out = write_sweep(tmp_path, SWEEP), tmp_path / "r.csv"
    assert main(["sweep", str(path), "-q", "--workers", "1", "--no-figure", "-o", str(out), *first]) == 0
    capsys.readouterr()
    assert main(["sweep", str(path), "-q", "--workers", "1", "--no-figure", "-o", str(out), *then]) == 2
    assert f"error: {out}: {said}, or use --fresh to start over or -o for another file" in capsys.readouterr().err


def test_a_long_dry_run_shows_its_progress_unless_quiet(tmp_path, capsys):
    """--dry-run over 120 points shows a bar while it loads their scenes (2,000 points took 19 s without a
    word, then printed everything at once); -q leaves it out."""
    path = write_sweep(tmp_path, SWEEP.replace("[2, 3, 5]", "{linspace: [2, 5, 60]}"))
    assert main(["sweep", str(path), "--dry-run", "-o", str(tmp_path / "x.csv")]) == 0
    assert "checking the points' scenes" in capsys.readouterr().err
    assert main(["sweep", str(path), "--dry-run", "-q", "-o", str(tmp_path / "x.csv")]) == 0
    assert "checking" not in capsys.readouterr().err


def test_a_dry_run_says_what_the_run_would_refuse_of_its_output(tmp_path, capsys):
    """--dry-run checks the output as the run would: a file where its folder goes, or a table of another
    sweep to resume, exit 2 with the run's words (it said ok, exit 0, and the run then exited 2);
    with --fresh the other sweep's table is no obstacle."""
    path = write_sweep(tmp_path, SWEEP)
    (tmp_path / "afile").write_text("")
    assert main(["sweep", str(path), "--dry-run", "-q", "-o", str(tmp_path / "afile" / "x.csv")]) == 2
    said = capsys.readouterr()
    assert "afile is a file, not a folder" in said.err
    assert ": its output would be refused - " in said.out.splitlines()[0]  # (its first line said "ok")
    other = write_sweep(tmp_path, SWEEP.replace("[2, 3, 5]", "[2, 3, 5]\nset: {components.ball.restitution: 0.5}"),
                        name="other.yaml")
    out = tmp_path / "t.csv"
    assert main(["sweep", str(other), "-q", "--workers", "1", "--no-figure", "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["sweep", str(path), "--dry-run", "-q", "-o", str(out)]) == 2
    assert f"error: {out}: holds the results of a different sweep" in capsys.readouterr().err
    assert main(["sweep", str(path), "--dry-run", "-q", "--fresh", "-o", str(out)]) == 0
    mine = tmp_path / "mine.csv"  # a table of the user's, no record beside it
    mine.write_text("a,b\n1,2\n")
    assert main(["sweep", str(path), "--dry-run", "-q", "-o", str(mine)]) == 2
    assert "mine.meta.json beside it is missing or unreadable, so it cannot be resumed" in capsys.readouterr().err


def test_a_dry_run_says_a_table_holding_points_no_longer_swept_is_refused(tmp_path, capsys):
    """An axis that lost values, pointed at the table the longer sweep wrote: the run refuses to resume
    it (its rows of points the sweep no longer has); the dry run said ok, exit 0. It now says what the
    run says, and leaves the table as it was."""
    path, out = write_sweep(tmp_path, SWEEP), tmp_path / "t.csv"
    assert main(["sweep", str(path), "-q", "--workers", "1", "--no-figure", "-o", str(out)]) == 0
    table = out.read_bytes()
    shorter = write_sweep(tmp_path, SWEEP.replace("[2, 3, 5]", "[2, 3]"), name="shorter.yaml")
    capsys.readouterr()
    assert main(["sweep", str(shorter), "--dry-run", "-q", "-o", str(out)]) == 2
    said = capsys.readouterr()
    assert ": its output would be refused - " in said.out.splitlines()[0]
    assert f"error: {out}: holds 2 points that are not in this sweep (e.g. " in said.err
    assert main(["sweep", str(shorter), "-q", "--workers", "1", "--no-figure", "-o", str(out)]) == 2
    assert f"error: {out}: holds 2 points that are not in this sweep (e.g. " in capsys.readouterr().err
    assert out.read_bytes() == table
    assert main(["sweep", str(shorter), "--dry-run", "-q", "--fresh", "-o", str(out)]) == 0


def test_dry_run_lists_points_and_runs_nothing(tmp_path, capsys):
    """--dry-run validates the sweep and lists each point's overrides without running or writing."""
    path = write_sweep(tmp_path, SWEEP)
    assert main(["sweep", str(path), "--dry-run", "-o", str(tmp_path / "x.csv"),
                 "--set", "components.ball.restitution=0.5"]) == 0
    out = capsys.readouterr().out
    assert f"{path}: ok - sweep: 6 points" in out
    assert "  every run: components.ball.restitution=0.5\n" in out
    assert ": components.ball.angle_deg=30 components.ball.speed=2\n" in out
    assert "metrics: ball.bounces, ball.distance, ball.outcome, ball.first_bounce_time" in out
    assert not (tmp_path / "x.csv").exists()


def test_bad_input_exits_2_with_no_traceback_and_no_table(tmp_path, capsys):
    """A bad sweep file, a bad --set key or a bad --workers exits 2 with error lines, writing nothing."""
    path = write_sweep(tmp_path, SWEEP.replace("[30, 60]", "{linspace: [30, 60]}"))
    assert main(["sweep", str(path), "-o", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {path}: axes.components.ball.angle_deg.linspace: expected a list of 3")
    assert "Traceback" not in err and not (tmp_path / "x.csv").exists()
    path = write_sweep(tmp_path, SWEEP)
    assert main(["sweep", str(path), "--set", "component.ball.speed=1", "-o", str(tmp_path / "x.csv")]) == 2
    assert "--set component.ball.speed: the scene has no key 'component'" in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        main(["sweep", str(path), "--workers", "0"])
    assert info.value.code == 2 and "--workers: must be >= 1, got 0" in capsys.readouterr().err
    # a derived expression too deep for Python's parser: RecursionError, exit 1, before
    chain = "+".join(["s"] * 1000)
    deep = SWEEP.replace("  components.ball.speed: [2, 3, 5]",
                         f"  s: [2, 3]\nderived:\n  components.ball.speed: '{chain}'")
    path = write_sweep(tmp_path, deep)
    assert main(["sweep", str(path), "-o", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert err == (f"error: {path}: derived.components.ball.speed: the expression has more than 100 operations "
                   "inside one another (a sum of 102 terms is one)\n")
    assert not (tmp_path / "x.csv").exists()
    too_many = 4 * (os.cpu_count() or 1) + 1
    assert main(["sweep", str(path), "--workers", str(too_many), "-o", str(tmp_path / "x.csv")]) == 2
    assert f"--workers {too_many}: at most {too_many - 1} on this machine" in capsys.readouterr().err
    assert not (tmp_path / "x.csv").exists()


def test_a_pool_has_no_more_workers_than_points_to_run(tmp_path, capsys):
    """--workers above the sweep's points: the pool starts one worker a point, and says so (it said
    the number asked for, and a large sweep would have started them all)."""
    path = write_sweep(tmp_path, SWEEP)
    workers = min(8, 4 * (os.cpu_count() or 1))
    assert main(["sweep", str(path), "-q", "--workers", str(workers), "-o", str(tmp_path / "x.csv"),
                 "--no-figure"]) == 0
    assert f"on process pool of {min(workers, 6)} workers" in capsys.readouterr().out


def test_failed_points_fail_the_command_only_when_strict(tmp_path, capsys):
    """Failed runs are rows of a complete sweep (exit 0); with --strict they make it exit 1."""
    failing_slow_throws = SWEEP.replace("components.ball.speed: [2, 3, 5]",
                                        "components.ball.speed: [2, 3, 5]\n  components.ball.fail_at_bounce: [0, 2]")
    path = write_sweep(tmp_path, failing_slow_throws)
    out = str(tmp_path / "f.csv")
    assert main(["sweep", str(path), "-q", "-o", out, "--workers", "2", "--no-figure"]) == 0
    text = capsys.readouterr().out
    assert "6 failed" in text and "6 stopped" in text
    assert "(components.ball.angle_deg=30, components.ball.speed=2, components.ball.fail_at_bounce=2): " \
           "component 'ball'" in text
    assert main(["sweep", str(path), "-q", "-o", out, "--strict", "--fresh", "--workers", "2",
                 "--no-figure"]) == 1
    assert "6 points failed (--strict)" in capsys.readouterr().err


def test_a_sweep_whose_every_point_failed_exits_1(tmp_path, capsys):
    """Nothing came of a sweep whose every run failed: exit 1 with one line saying so, --strict or
    not (it exited 0, and a script reading the table went on)."""
    path = write_sweep(tmp_path, SWEEP + "set: {components.ball.fail_at_bounce: 2}\n")
    out = tmp_path / "f.csv"
    assert main(["sweep", str(path), "-q", "-o", str(out), "--workers", "2", "--no-figure"]) == 1
    captured = capsys.readouterr()
    assert "6 failed" in captured.out and out.exists()
    assert captured.err == ("error: every one of the sweep's 6 points failed (the table's status and reason "
                            "columns say why)\n")
    assert main(["sweep", str(path), "-q", "-o", str(out), "--workers", "2", "--no-figure"]) == 1  # resumed


def test_table_of_another_sweep_exits_2(tmp_path, capsys):
    """Resuming a table that another sweep wrote is refused with exit 2."""
    out = str(tmp_path / "t.csv")
    assert main(["sweep", str(write_sweep(tmp_path, SWEEP)), "-q", "-o", out, "--workers", "1"]) == 0
    other = write_sweep(tmp_path, SWEEP + "until: 1.0\n", name="other.yaml")
    assert main(["sweep", str(other), "-q", "-o", out]) == 2
    err = capsys.readouterr().err
    assert "t.csv: holds the results of a different sweep" in err
    assert "resuming" not in err  # it is not resumed: said only of a table found to be this sweep's


@pytest.mark.parametrize(("first", "then"), [("res.csv", "res.parquet"), ("res.parquet", "res.csv")])
@pytest.mark.parametrize("legacy", [False, True], ids=["named", "record-of-before"])
def test_a_table_of_the_same_stem_in_the_other_format_keeps_its_side_files(tmp_path, capsys, first, then, legacy):
    """`-o res.csv` and `-o res.parquet` in one folder share their record, figure, lock and runs folder
    (named by the stem): the second sweep, with --fresh too and in a dry run, is refused in one line
    naming the other table, exit 2, and the first's files stay as they were, so that it still resumes
    (the second overwrote res.meta.json and res.png, and the first was then refused as "a different
    sweep"). A record written before it named its table is known by the other table's header; a
    table copied with its record under another stem resumes."""
    pytest.importorskip("pyarrow")
    folder = tmp_path / "col"
    mine = str(folder / first)
    assert main(["sweep", str(write_sweep(tmp_path, SWEEP)), "-q", "-o", mine, "--workers", "1"]) == 0
    record = folder / "res.meta.json"
    if legacy:
        data = json.loads(record.read_text())
        data.pop("table", None)  # (written since)
        record.write_text(json.dumps(data))
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    assert {"res.meta.json", "res.png"} <= set(before)
    other = write_sweep(tmp_path, SWEEP.replace("[2, 3, 5]", "[2, 3]"), name="other.yaml")
    capsys.readouterr()
    for options in ([], ["--fresh"], ["--dry-run"]):
        assert main(["sweep", str(other), "-q", "-o", str(folder / then), "--workers", "1", *options]) == 2
        err = capsys.readouterr().err
        assert err == (f"error: {folder / then}: res.meta.json beside it is the record of {first}, another sweep's "
                       "table of the same stem (the two would share their record, figure res.png, lock and runs "
                       "folder); give -o another name\n"), options
        assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    assert main(["sweep", str(write_sweep(tmp_path, SWEEP)), "-q", "-o", mine, "--workers", "1"]) == 0
    assert "holds every point of this sweep: nothing to run" in capsys.readouterr().err
    # a copy of the table with its record, under another stem, is its own (its record names the original)
    for name, data in before.items():
        (folder / name.replace("res.", "copy.")).write_bytes(data)
    assert main(["sweep", str(write_sweep(tmp_path, SWEEP)), "-q", "-o", str(folder / first.replace("res", "copy")),
                 "--workers", "1"]) == 0
    assert "holds every point of this sweep: nothing to run" in capsys.readouterr().err


def test_a_parquet_table_whose_journal_is_gone_is_refused_not_deleted(tmp_path, capsys):
    """A finished Parquet table whose journal (`<stem>.journal.csv`) was removed cannot be resumed: run
    again, or in a dry run, it is refused in one line saying to use --fresh, exit 2, and kept (it was
    deleted and run again as if --fresh had been given), as a CSV table without its record is;
    --fresh starts it over."""
    pq = pytest.importorskip("pyarrow.parquet")
    path, out = write_sweep(tmp_path, SWEEP), tmp_path / "t.parquet"
    assert main(["sweep", str(path), "-q", "-o", str(out), "--workers", "1", "--no-figure"]) == 0
    (tmp_path / "t.journal.csv").unlink()
    table = out.read_bytes()
    for options in ([], ["--dry-run"]):
        assert main(["sweep", str(path), "-q", "-o", str(out), "--workers", "1", "--no-figure", *options]) == 2
        assert capsys.readouterr().err == (f"error: {out}: exists but its journal t.journal.csv beside it is missing, "
                                           "so it cannot be resumed; use --fresh to start over or -o for another "
                                           "file\n")
        assert out.read_bytes() == table
    assert main(["sweep", str(path), "-q", "-o", str(out), "--workers", "1", "--no-figure", "--fresh"]) == 0
    assert pq.read_table(out).num_rows == 6 and (tmp_path / "t.journal.csv").exists()


@pytest.mark.parametrize("read_only", ["t.parquet", "t.meta.json"])
def test_a_table_or_record_made_read_only_is_refused_before_any_run(tmp_path, capsys, read_only):
    """A Parquet table (or the record beside it) made read-only, a point left to run: the sweep ran it,
    then could not write the finished table, and said to run the same command again, which did the
    same for ever (a dry run said ok). Refused before any run, in a dry run too, exit 2, nothing
    changed."""
    pytest.importorskip("pyarrow.parquet")
    import stat
    path, out = write_sweep(tmp_path, SWEEP), tmp_path / "t.parquet"
    assert main(["sweep", str(path), "-q", "-o", str(out), "--workers", "1", "--no-figure"]) == 0
    journal = tmp_path / "t.journal.csv"
    journal.write_text("".join(journal.read_text().splitlines(keepends=True)[:-1]))  # a point left to run
    (tmp_path / read_only).chmod(stat.S_IRUSR | stat.S_IRGRP | stat.S_IROTH)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    capsys.readouterr()
    for options in ([], ["--dry-run"]):
        assert main(["sweep", str(path), "-q", "-o", str(out), "--workers", "1", "--no-figure", *options]) == 2
        said = "" if read_only == "t.parquet" else "t.meta.json beside it "
        assert capsys.readouterr().err == (f"error: {out}: {said}is read-only, and a sweep rewrites it as it "
                                           "finishes; make it writable or give -o another name\n")
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()} == before

@pytest.mark.parametrize(("output", "said"), [
    ("x.txt", "error: cosim sweep: -o x.txt: must name a .csv or .parquet file"),
    ("folder.csv", "folder.csv: is a folder, not a results table: give -o a .csv or .parquet file name"),
])
def test_an_output_that_is_no_table_file_is_named_as_given(tmp_path, monkeypatch, capsys, output, said):
    """-o naming no table (another suffix, an existing folder): one line about -o, exit 2; not blamed
    on the sweep file with a PosixPath(...) in it, nor called a table whose metadata is missing."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "folder.csv").mkdir()
    assert main(["sweep", str(write_sweep(tmp_path, SWEEP)), "-q", "-o", output]) == 2
    err = capsys.readouterr().err.strip()
    assert said in err and "PosixPath" not in err and "meta.json" not in err and "resuming" not in err


def test_dask_problems_exit_2(tmp_path, monkeypatch, capsys):
    """--dask without dask installed, or with a scheduler out of reach, exits 2 saying what to do."""
    path = str(write_sweep(tmp_path, SWEEP))
    monkeypatch.setitem(sys.modules, "distributed", None)
    assert main(["sweep", path, "--dask", "local", "-o", str(tmp_path / "x.csv")]) == 2
    assert "error: --dask needs dask and distributed: pip install 'cosim[dask]'" in capsys.readouterr().err
    monkeypatch.delitem(sys.modules, "distributed")
    pytest.importorskip("distributed")
    monkeypatch.setattr(cosim.sweep.backends, "DASK_CONNECT_TIMEOUT_S", 1)
    assert main(["sweep", path, "--dask", "tcp://127.0.0.1:9", "-o", str(tmp_path / "x.csv")]) == 2
    said = capsys.readouterr().err
    # (and for how long it tried: a refused connection is tried again, as a scheduler still starting refuses)
    assert "error: cannot reach the Dask scheduler at tcp://127.0.0.1:9" in said and "(tried for 1 s)" in said
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize("dry", [[], ["--dry-run"]])
def test_workers_with_a_remote_dask_cluster_is_refused_before_anything(tmp_path, monkeypatch, capsys, dry):
    """--workers N with --dask tcp://...: the remote cluster runs on its own workers, so the count was
    ignored without a word; now one line naming both options, exit 2, before the sweep file is read,
    a scheduler reached or a table written."""
    path = str(write_sweep(tmp_path, SWEEP))

    def no_backend(*args, **kwargs):
        raise AssertionError("a backend was made (a scheduler reached) for a refused command line")

    monkeypatch.setattr(cosim.sweep.backends, "make_backend", no_backend)
    monkeypatch.setattr(cosim.sweep.backends, "DASK_CONNECT_TIMEOUT_S", 1)
    out = tmp_path / "x.csv"
    assert main(["sweep", path, "-q", "--workers", "3", "--dask", "tcp://127.0.0.1:9", "-o", str(out), *dry]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("error: cosim sweep: --workers 3 with --dask tcp://127.0.0.1:9: ")
    assert "its own workers" in lines[0] and "leave out --workers" in lines[0]
    assert captured.out == "" and not out.exists() and not (tmp_path / "results").exists()


def test_ctrl_c_keeps_finished_rows_and_exits_1(tmp_path):
    """Ctrl-C (SIGINT to the process group) ends the sweep with exit 1, keeps the rows written, and
    says how to resume."""
    path = write_sweep(tmp_path, SWEEP.replace("[2, 3, 5]", "[2, 3, 4, 5, 6, 7]") +
                       "set: {components.ball.burn: 3000}\n")
    out = tmp_path / "i.csv"
    code, stdout, stderr = interrupt_sweep(path, out, ["--workers", "1"], rows=3, timeout=60)
    assert code == 1, stderr
    assert "interrupted: " in stdout and "run the same command again to resume" in stdout
    assert "Traceback" not in stderr
    rows = len(out.read_text().splitlines()) - 1
    assert 2 <= rows < 12


def test_a_fresh_sweep_interrupted_says_to_resume_without_fresh(tmp_path):
    """A sweep started with --fresh and interrupted keeps its rows; the advice to go on leaves --fresh
    out (it said to run the same command again, which, --fresh and all, discarded them)."""
    path = write_sweep(tmp_path, SWEEP.replace("[2, 3, 5]", "[2, 3, 4, 5, 6, 7]") +
                       "set: {components.ball.burn: 3000}\n")
    out = tmp_path / "f.csv"
    code, stdout, stderr = interrupt_sweep(path, out, ["--workers", "1", "--fresh"], rows=3, timeout=60)
    assert code == 1, stderr
    assert "points left; run the command again without --fresh to resume" in stdout
    assert "run the same command again" not in stdout + stderr


@pytest.mark.parametrize("how", ["ctrl_c", "sigterm", "hangup"])
def test_a_stopped_sweep_starts_no_queued_run_and_resumes_the_rest(tmp_path, how):
    """Stopped (Ctrl-C to the process group, SIGTERM to the sweep alone, or SIGHUP to the process
    group as a closing terminal sends it: its workers died of it, and the sweep waited for good on
    the stop it had given them), a sweep starts none of
    the runs queued behind those in flight: it ran them, or one until SIGKILL, its rows discarded. The
    run in flight ends `interrupted` with its recording closed; resuming runs exactly the points with
    no row."""
    from cosim.record.reader import Recording
    from cosim.sweep.plan import load_sweep
    from cosim.sweep.run import run_sweep

    path = write_sweep(tmp_path, "scene: ball.yaml\naxes:\n  components.ball.speed: [2, 3, 4, 5, 6, 7]\n"
                                 "set: {components.ball.burn: 20000}\nrecord: true\n")
    out, runs = tmp_path / "s.csv", tmp_path / "s_runs"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "sweep", str(path), "-q", "-o", str(out),
                             "--workers", "1"], cwd=tmp_path, env=env, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:  # a row written, the next run recording
        if out.exists() and len(out.read_text().splitlines()) >= 2 and list(runs.glob("*.part")):
            break
        time.sleep(0.02)
    if how in ("ctrl_c", "hangup"):
        os.killpg(proc.pid, signal.SIGINT if how == "ctrl_c" else signal.SIGHUP)
    else:
        proc.send_signal(signal.SIGTERM)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 1, stderr
    assert "interrupted: " in stdout and "Traceback" not in stderr
    # and standard error says so in its one line, as for any other failure
    assert stderr.strip().splitlines()[-1].startswith("error: cosim sweep: interrupted: "), stderr
    rows = {line.split(",")[1] for line in out.read_text().splitlines()[1:]}
    recorded = {p.name.removesuffix(".mcap") for p in runs.glob("*.mcap")}
    assert 1 <= len(rows) < 6 and rows <= recorded
    # one worker: the run in flight, and no other, was recorded without a row
    (cut,) = recorded - rows
    status = Recording(runs / f"{cut}.mcap").status()
    assert status is not None and status.status == "interrupted"
    assert not list(runs.glob("*.part"))
    outcome = run_sweep(load_sweep(path), out, progress=False, figure=False)
    assert (outcome.already, outcome.ran, outcome.complete) == (len(rows), 6 - len(rows), True)


def test_a_nul_character_in_the_sweeps_name_is_one_line_even_in_a_dry_run(tmp_path, capsys):
    """A NUL in `name:` exits 2 with one line naming the key, nothing written (an internal ValueError
    "embedded null byte" when run; --dry-run said ok)."""
    path = write_sweep(tmp_path, 'scene: ball.yaml\naxes: {components.ball.speed: [1, 2]}\nname: "run\\0s"\n')
    for dry in (["--dry-run"], []):
        assert main(["sweep", str(path), "-q", *dry]) == 2
        err = capsys.readouterr().err
        assert err == f"error: {path}: name: must not hold a NUL character (got 'run\\x00s')\n"
    assert not (tmp_path / "runs").exists()


def test_a_huge_sweep_is_refused_at_once_even_in_a_dry_run(tmp_path, capsys):
    """A typo that makes an axis huge exits 2 with one line naming the axis, its count and the limit,
    before any value is built (a range of 10**18 values could never be built)."""
    path = write_sweep(tmp_path, "scene: ball.yaml\naxes:\n  dt: {range: [0, 1000000000000000000, 1]}\n")
    assert main(["sweep", str(path), "--dry-run", "-q"]) == 2
    assert capsys.readouterr().err == (
        f"error: {path}: axes.dt.range: 1000000000000000000 values is more than the 1000000 points a sweep "
        "may have (got [0, 1000000000000000000, 1]); check the start, stop and step\n")


def leftovers(folder: Path) -> set[str]:
    """The files and folders in ``folder`` besides the sweep and scene files ``write_sweep`` writes."""
    return {str(p.relative_to(folder)) for p in folder.rglob("*")} - {"sweep.yaml", "ball.yaml"}


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux's /proc, where no file can be made")
def test_an_unwritable_output_is_named_as_the_user_gave_it(tmp_path, capsys):
    """An output where nothing can be written exits 2 with one line naming the path given with -o and
    what could not be written there, not a temporary file of its own."""
    path = write_sweep(tmp_path, SWEEP)
    assert main(["sweep", str(path), "-o", "/proc/x.csv", "--workers", "1", "--no-figure", "-q"]) == 2
    assert capsys.readouterr().err == ("error: /proc/x.csv: cannot write the sweep's results here "
                                       "(x.meta.json beside it: No such file or directory)\n")


@pytest.mark.parametrize(("blocker", "output", "reason"), [
    ("afile", "afile/x.csv", "Not a directory"),  # a file where a folder should be
    ("x.meta.json/", "x.csv", "x.meta.json beside it: Is a directory"),  # the record's place is taken
])
def test_an_output_that_cannot_be_written_says_why_and_leaves_nothing(tmp_path, capsys, blocker, output,
                                                                      reason):
    """A results table that cannot be made exits 2 naming the output and the reason, and writes nothing."""
    path = write_sweep(tmp_path, SWEEP)
    if blocker.endswith("/"):
        (tmp_path / blocker).mkdir()
    else:
        (tmp_path / blocker).touch()
    before = leftovers(tmp_path)
    out = tmp_path / output
    assert main(["sweep", str(path), "-o", str(out), "--workers", "1", "--no-figure", "-q"]) == 2
    assert capsys.readouterr().err == f"error: {out}: cannot write the sweep's results here ({reason})\n"
    assert leftovers(tmp_path) == before


def test_a_table_that_fails_halfway_is_removed_with_its_folders(tmp_path, monkeypatch, capsys):
    """If the table cannot be created once its record and folders are (the disk fills, a permission),
    they are removed again: no sweep is left half-started."""
    import cosim.sweep.table

    def refuse(file, *args, **kwargs):
        raise PermissionError(13, "Permission denied", str(file))

    monkeypatch.setattr(cosim.sweep.table, "open", refuse, raising=False)
    path = write_sweep(tmp_path, SWEEP)
    out = tmp_path / "new" / "deeper" / "x.csv"
    assert main(["sweep", str(path), "-o", str(out), "--workers", "1", "--no-figure", "-q"]) == 2
    assert capsys.readouterr().err == f"error: {out}: cannot write the sweep's results here (Permission denied)\n"
    assert leftovers(tmp_path) == set()


def test_an_unwritable_recording_folder_is_said_once_before_any_run(tmp_path, capsys):
    """With --record, a place for the runs' recordings that is taken exits 2 naming the output and that
    folder, before any run, and leaves no table behind (not a table of runs that all failed)."""
    path = write_sweep(tmp_path, SWEEP)
    (tmp_path / "x_runs").touch()
    out = tmp_path / "x.csv"
    assert main(["sweep", str(path), "-o", str(out), "--workers", "1", "--no-figure", "-q", "--record"]) == 2
    assert capsys.readouterr().err == (f"error: {out}: cannot write the sweep's recordings here "
                                       "(x_runs beside it: File exists)\n")
    assert leftovers(tmp_path) == {"x_runs"}


def test_a_figure_that_cannot_be_written_says_the_table_is_complete(tmp_path, capsys):
    """A summary figure whose place is taken exits 2 naming the output and the figure, says the table
    is complete, and leaves no temporary picture behind."""
    pytest.importorskip("matplotlib")
    path = write_sweep(tmp_path, SWEEP)
    (tmp_path / "x.png").mkdir()
    out = tmp_path / "x.csv"
    assert main(["sweep", str(path), "-o", str(out), "--workers", "1", "-q"]) == 2
    assert capsys.readouterr().err == (f"error: {out}: cannot draw the sweep's figure here (x.png beside it: "
                                       "Is a directory); the table is complete (--no-figure leaves the "
                                       "figure out)\n")
    assert leftovers(tmp_path) == {"x.png", "x.csv", "x.meta.json"}
    assert len(out.read_text().splitlines()) == 7


def test_a_later_points_notice_is_said_once_after_the_sweep(tmp_path, capsys):
    """Only the first point's scene is loaded before the sweep: a notice of a later point's scene
    (here its column displacement) is said once the sweep has run, naming a point that has it (it
    was never said)."""
    scene = Path(__file__).resolve().parents[1] / "scenarios" / "float_sphere.yaml"
    path = tmp_path / "modes.yaml"
    path.write_text(f"scene: {scene}\naxes:\n  components.pine_water.displacement_mode: [ring, column]\n"
                    "set: {until: 0.01}\noutput: modes.csv\n")
    assert main(["sweep", str(path), "-q", "--workers", "2", "--no-figure", "-o", str(tmp_path / "m.csv")]) == 0
    err = capsys.readouterr().err
    assert err.count("warning: components.pine_water: displacement_mode: column reads the surface") == 1
    assert err.rstrip().endswith("(point components.pine_water.displacement_mode=column, and any other like it)")


@pytest.mark.parametrize(("radii", "invalid"), [("0.05, 0.04, -0.01", 2), ("-0.01, 0.05, 0.04", 0)])
def test_a_dry_run_loads_every_points_scene_and_names_the_invalid_ones(tmp_path, capsys, radii, invalid):
    """--dry-run said 'ok' for a sweep whose third point makes no scene, found only as a failed row
    when it ran; it now loads each point's scene and names the ones that are invalid (here a derived
    value's: an override axis's own values are checked as the sweep loads). The first point too: it
    was the sweep's refusal, naming that point alone."""
    scene = Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml"
    path = tmp_path / "radii.yaml"
    path.write_text(f"scene: {scene}\naxes:\n  r: [{radii}]\nderived: {{components.stone.radius: r}}\n"
                    "output: r.csv\n")
    assert main(["sweep", str(path), "--dry-run"]) == 2
    out = capsys.readouterr().out
    assert "  2 of 3 points checked make valid scenes" in out
    assert f"invalid #{invalid} " in out and "invalid scene: components.stone.radius: must be > 0 m (got -0.01)" in out


@pytest.mark.parametrize("dry_run", [[], ["--dry-run"]], ids=["run", "dry-run"])
def test_an_invalid_value_of_an_override_axis_is_bad_input_and_nothing_is_written(tmp_path, capsys, dry_run):
    """A value of an override axis that makes no scene, whichever point holds it: exit 2 naming the axis
    and the value, nothing written (`[0.05, -1]` ran, wrote a table and a figure with a failed row, and
    exited 0)."""
    scene = Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml"
    path = tmp_path / "radii.yaml"
    path.write_text(f"scene: {scene}\naxes:\n  components.stone.radius: [0.05, -1]\nuntil: 0.01\n")
    assert main(["sweep", str(path), "-q", "--workers", "1", "-o", str(tmp_path / "out" / "r.csv"), *dry_run]) == 2
    captured = capsys.readouterr()
    assert captured.err == (f"error: {path}: axes.components.stone.radius: -1 makes an invalid scene: "
                            "components.stone.radius: must be > 0 m (got -1)\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["radii.yaml"]


@pytest.mark.parametrize("strict", [[], ["--strict"]], ids=["plain", "strict"])
def test_a_dry_run_that_finds_invalid_points_says_so_and_exits_2(tmp_path, capsys, strict):
    """A dry run whose points include invalid ones said `ok` and exited 0, with or without --strict:
    its header now counts them, one error line follows, and it exits 2 (bad input); a sweep whose
    every point is valid still says `ok` and exits 0."""
    body = "scene: ball.yaml\naxes:\n  u: [1.0, -1.0]\nderived: {until: 'u * 20'}\noutput: d.csv\n"
    path = write_sweep(tmp_path, body)
    assert main(["sweep", str(path), "--dry-run", *strict]) == 2
    captured = capsys.readouterr()
    assert captured.out.startswith(f"{path}: 1 of 2 points checked are invalid - sweep: 2 points")
    assert "invalid #1 " in captured.out and "until: must be > 0 s (got -20)" in captured.out
    assert captured.err == (f"error: {path}: 1 of 2 points checked make no valid scene (listed above); each "
                            "would be a failed row\n")
    assert not (tmp_path / "d.csv").exists()
    path.write_text(body.replace("-1.0", "2.0"))
    assert main(["sweep", str(path), "--dry-run", *strict]) == 0
    assert capsys.readouterr().out.startswith(f"{path}: ok - sweep: 2 points")


def test_a_sweep_into_a_log_says_its_progress_in_a_few_plain_lines(tmp_path, monkeypatch, capsys):
    """Standard error not a terminal (a log, a pipe): the sweep's progress is a line at each tenth of
    its runs, not a bar redrawn with carriage returns (one log line of every redraw); on a terminal,
    the bar."""
    monkeypatch.chdir(tmp_path)
    path = write_sweep(tmp_path, SWEEP)
    assert main(["sweep", str(path), "--workers", "1", "--no-figure"]) == 0
    err = capsys.readouterr().err
    assert "\r" not in err
    lines = [line for line in err.splitlines() if line.startswith("sweep: ")]  # the sweep file's name
    assert [line.split(",")[0] for line in lines] == [f"sweep: {n}/6 runs ({100 * n / 6:.0f}%)"
                                                       for n in range(1, 7)]


def test_log_lines_say_each_tenth_once_with_what_failed():
    """The plain-line progress: a line as each tenth of the work is passed (10 of 1000 pieces done one
    by one: 10 lines), what set_postfix gave in it, and none for work already done before it began."""
    import io

    from cosim.progress import LogLines

    out = io.StringIO()
    shown = LogLines(1000, initial=300, desc="s", unit="run", file=out)
    for n in range(700):
        if n == 650:
            shown.set_postfix(failed=2, refresh=False)
        shown.update(1)
    lines = out.getvalue().splitlines()
    assert [line.split(" (")[0] for line in lines] == [f"s: {n}/1000 runs" for n in range(400, 1001, 100)]
    assert "failed 2" in lines[-1] and "failed" not in lines[-2]


def test_a_run_past_its_timeout_is_stopped_and_its_row_says_failed_timed_out(tmp_path, monkeypatch, capsys):
    """--run-timeout (or the file's run_timeout): a run still going after that much wall time is stopped
    at the end of its step, its recording closed as an interrupted run's, and its row says failed,
    timed out, with the simulated time it reached; the other points run as before, and a resumed sweep
    takes the timed-out row as a result (a sweep had no bound: one slow point held it for ever)."""
    import csv

    from cosim.record.reader import Recording

    monkeypatch.chdir(tmp_path)
    path = write_sweep(tmp_path, SWEEP.replace("components.ball.speed: [2, 3, 5]",
                                               "components.ball.burn: [0, 300000]")
                       .replace("[30, 60]", "[30]") + "run_timeout: 1000\n")
    out = tmp_path / "t.csv"
    assert main(["sweep", str(path), "-q", "--workers", "1", "--no-figure", "--record", "--run-timeout", "0.5",
                 "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert "ran 2, 0 already in the table; 1 failed, 1 stopped" in said
    with open(out, newline="") as table:
        rows = {row["components.ball.burn"]: row for row in csv.DictReader(table)}
    slow = rows["300000"]
    assert slow["status"] == "failed" and slow["error_type"] == "Timeout"
    assert slow["reason"].startswith("timed out: still running after 0.5 s of wall time (run_timeout); "
                                     "stopped at t = ")
    assert 0 < float(slow["sim_time_s"]) < 3.0 and float(slow["wall_s"]) < 30
    status = Recording(slow["recording"]).status()
    assert status is not None and status.status == "interrupted" and status.reason.startswith("timed out")
    assert rows["0"]["status"] == "stopped"
    assert main(["sweep", str(path), "-q", "--workers", "1", "--no-figure", "--record", "-o", str(out)]) == 0
    assert "ran 0, 2 already in the table" in capsys.readouterr().out


def test_a_run_timeout_that_is_no_number_of_seconds_is_refused(tmp_path, capsys):
    path = write_sweep(tmp_path, SWEEP + "run_timeout: -1\n")
    assert main(["sweep", str(path), "-q", "--dry-run", "-o", str(tmp_path / "x.csv")]) == 2
    assert "run_timeout: must be a finite number of wall seconds > 0 (got -1)" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exited:
        main(["sweep", str(path), "-q", "--dry-run", "--run-timeout", "0", "-o", str(tmp_path / "x.csv")])
    assert exited.value.code == 2 and "argument --run-timeout: must be > 0 s, got 0" in capsys.readouterr().err


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_as_the_finished_sweep_writes_its_table_lets_it_finish(tmp_path, monkeypatch, capsys, signum):
    """Every point run, a SIGTERM (or Ctrl-C) while the sweep writes its table and figure: it said
    "interrupted", exit 1, and nothing of the table, which was whole, and the same command again had
    nothing to run. The sweep now finishes its table and figure, says the signal came then, exit 0."""
    pytest.importorskip("matplotlib")
    import cosim.sweep.figure

    drawn = cosim.sweep.figure.draw

    def draw_signalled(*args, **kwargs):
        os.kill(os.getpid(), signum)
        return drawn(*args, **kwargs)

    monkeypatch.setattr(cosim.sweep.figure, "draw", draw_signalled)
    path, out = write_sweep(tmp_path, SWEEP), tmp_path / "x.csv"
    assert main(["sweep", str(path), "-o", str(out), "--workers", "1", "-q"]) == 0
    said = capsys.readouterr()
    name = "SIGTERM" if signum == signal.SIGTERM else "Ctrl-C"
    assert f"  {name} came as the sweep finished: it was let finish (its table and figure whole)" in said.out
    assert said.err == ""
    assert (tmp_path / "x.png").exists() and "finished" in json.loads((tmp_path / "x.meta.json").read_text())
    assert len(out.read_text().splitlines()) == 1 + 6


def test_a_second_ctrl_c_as_a_finished_sweep_closes_interrupts_it():
    """Held off while a complete sweep finishes, the first Ctrl-C is noted and a second one interrupts,
    also when the first came while the table was written and the second as the workers close."""
    from cosim.sweep.run import LateSignals

    with LateSignals() as late:
        os.kill(os.getpid(), signal.SIGINT)
        assert late.seen == "Ctrl-C"
        with pytest.raises(KeyboardInterrupt):
            os.kill(os.getpid(), signal.SIGINT)
    with pytest.raises(KeyboardInterrupt), LateSignals("Ctrl-C"):
        os.kill(os.getpid(), signal.SIGINT)
