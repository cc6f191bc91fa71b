"""Running sweeps on the process pool: one row per point, nothing lost, resumable, deterministic."""

from __future__ import annotations

import csv
import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cosim.errors import RecordingError, ScenarioError
from cosim.record.reader import Recording
from cosim.record.writer import SinkError
from cosim.runner import collect_metrics, run_scene
from cosim.scenario import loads
from cosim.sweep.backends import ProcessBackend, Task
from cosim.sweep.plan import load_sweep
from cosim.sweep.run import run_sweep
from tests.sweep_toys import BALL_SCENE, read_table, running_pool, write_sweep

ROOT = Path(__file__).resolve().parents[1]

GRID = """
scene: ball.yaml
axes:
  components.ball.angle_deg: {linspace: [20, 70, 3]}
  components.ball.speed: [2, 3, 5]
"""


@pytest.fixture(scope="module")
def pool():
    """Two worker processes, shared by the tests of this file."""
    with running_pool(2) as backend:
        yield backend


def run_and_close(sweep, path: Path, backend):
    """Run ``sweep`` on a backend of its own, closed afterwards whatever happens."""
    try:
        return run_sweep(sweep, path, backend, progress=False, figure=False)
    finally:
        backend.close()


def rows_of(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_each_point_gets_the_row_a_direct_run_gives(tmp_path, pool):
    """The table has one row per point, sorted by index, with the status and metrics that running the
    point's scene directly gives."""
    sweep = load_sweep(write_sweep(tmp_path, GRID))
    outcome = run_sweep(sweep, tmp_path / "out.csv", pool, progress=False, figure=False)
    assert outcome.complete and outcome.ran == 9 and outcome.counts == {"stopped": 9}
    rows = rows_of(tmp_path / "out.csv")
    assert [int(r["index"]) for r in rows] == list(range(9))
    assert [r["point_id"] for r in rows] == [p.point_id for p in sweep.points]
    for point, row in zip(sweep.points, rows, strict=True):
        direct = run_scene(loads(BALL_SCENE, overrides=list(point.overrides)), None, progress=False)
        metrics = collect_metrics(direct.simulation)
        assert row["status"] == direct.result.status and row["reason"] == direct.result.reason
        assert row["ball.bounces"] == str(metrics["ball.bounces"])
        assert row["ball.distance"] == repr(metrics["ball.distance"])  # floats exactly
        assert row["components.ball.speed"] == str(point.values["components.ball.speed"])
        assert float(row["wall_s"]) > 0


def test_results_do_not_depend_on_the_worker_count(tmp_path, pool):
    """One worker or two, the same sweep gives the same table, wall time aside."""
    sweep = load_sweep(write_sweep(tmp_path, GRID))
    run_sweep(sweep, tmp_path / "two.csv", pool, progress=False, figure=False)
    run_and_close(sweep, tmp_path / "one.csv", ProcessBackend(1))
    assert read_table(tmp_path / "one.csv") == read_table(tmp_path / "two.csv")


def test_a_failing_point_does_not_stop_the_others(tmp_path, pool):
    """A run that raises, and a point whose scene is invalid (its derived value: an axis's own values
    are checked as the sweep loads), become failed rows saying why; every other point still runs."""
    body = (GRID + "  components.ball.fail_at_bounce: [0, 2]\n  restitution: [0.6, 1.5]\n"
            "derived: {components.ball.restitution: restitution}\n")
    sweep = load_sweep(write_sweep(tmp_path, body))
    outcome = run_sweep(sweep, tmp_path / "out.csv", pool, progress=False, figure=False)
    rows = rows_of(tmp_path / "out.csv")
    assert len(rows) == 36 and outcome.complete
    for row in rows:
        if row["restitution"] == "1.5":
            assert (row["status"], row["error_type"]) == ("failed", "ScenarioError")
            assert row["reason"] == "invalid scene: components.ball.restitution: must be <= 1 (got 1.5)"
            assert row["ball.bounces"] == ""
        elif row["components.ball.fail_at_bounce"] == "2" and int(row["ball.bounces"]) >= 2:
            assert (row["status"], row["error_type"]) == ("failed", "SimulationError")
            assert "component 'ball' failed at t = " in row["reason"]
            assert "RuntimeError: bounce 2 is forbidden" in row["reason"]
        else:
            assert row["status"] == "stopped" and row["error_type"] == ""
    failed = [r for r in rows if r["status"] == "failed"]
    assert outcome.counts["failed"] == len(outcome.failures) == len(failed)
    assert {r["error_type"] for r in failed} == {"ScenarioError", "SimulationError"}
    assert "failed #" in outcome.summary()


def test_a_point_that_kills_its_worker_is_the_only_one_lost(tmp_path):
    """When a worker process dies, the points in flight are retried one at a time, so only the point
    that kills its worker becomes a failed row (WorkerLost), and the sweep goes on."""
    body = ("scene: ball.yaml\naxes:\n  components.ball.speed: [2, 3, 4, 5, 6]\n"
            "  components.ball.die: [false, true]\n")
    sweep = load_sweep(write_sweep(tmp_path, body))
    outcome = run_and_close(sweep, tmp_path / "out.csv", ProcessBackend(2))
    rows = rows_of(tmp_path / "out.csv")
    assert outcome.complete and len(rows) == 10
    for row in rows:
        if row["components.ball.die"] == "true":
            assert (row["status"], row["error_type"]) == ("failed", "WorkerLost")
            assert row["reason"].startswith("the worker running this point died")
        else:
            assert row["status"] == "stopped"


def test_a_pool_found_broken_when_submitting_loses_no_point(tmp_path):
    """A worker can die before its failed run comes back, so that submitting the next point finds
    the pool broken: that point is not lost, it runs after the restart."""
    from cosim.sweep.backends import WorkerLost

    class BreaksOnThirdSubmit(ProcessBackend):
        submits = 0
        restarts = 0

        def submit(self, task):
            self.submits += 1
            if self.submits == 3:
                raise WorkerLost("a worker process died (BrokenProcessPool)", isolate=True)
            return super().submit(task)

        def restart(self):
            self.restarts += 1
            super().restart()

    sweep = load_sweep(write_sweep(tmp_path, GRID))
    backend = BreaksOnThirdSubmit(2)
    outcome = run_and_close(sweep, tmp_path / "out.csv", backend)
    assert outcome.complete and outcome.counts == {"stopped": 9} and backend.restarts == 1
    assert [int(r["index"]) for r in rows_of(tmp_path / "out.csv")] == list(range(9))


def _ends_within(action, seconds: float) -> bool:
    """Whether ``action()`` returns within ``seconds`` (run in a thread, so a hang fails the test)."""
    import threading

    thread = threading.Thread(target=action, daemon=True)
    thread.start()
    thread.join(seconds)
    return not thread.is_alive()


@pytest.mark.parametrize("broken", [False, True], ids=["healthy", "broken"])
def test_closing_a_pool_ends_a_worker_that_ignores_sigterm(monkeypatch, broken):
    """Closing the pool ends every worker, even one that ignores SIGTERM, and even after another
    worker died and broke the pool (where the executor's own shutdown waits for it forever)."""
    import cosim.sweep.backends as backends
    from tests.sweep_toys import dying_task, stubborn_task

    monkeypatch.setattr(backends, "WORKER_JOIN_TIMEOUT_S", 0.5)
    backend = ProcessBackend(2)
    backend.warm_up()
    assert backend.pool is not None
    workers = list(backend.pool._processes.values())
    stubborn = backend.pool.submit(stubborn_task, 600.0)
    if broken:
        dead = backend.pool.submit(dying_task, 0.5)
        with pytest.raises(Exception, match="terminated abruptly"):
            dead.result(timeout=60)
    else:
        time.sleep(0.5)  # the stubborn task has started and ignores SIGTERM
        assert not stubborn.done()
    assert _ends_within(backend.close, 60)
    assert backend.pool is None
    assert [w.is_alive() for w in workers] == [False, False]


def test_an_interrupted_table_resumes_to_the_same_table(tmp_path, pool):
    """Resuming a table cut short (rows in completion order, a half-written last row) runs only the
    missing points and ends with the table an uninterrupted sweep writes."""
    sweep = load_sweep(write_sweep(tmp_path, GRID))
    run_sweep(sweep, tmp_path / "full.csv", pool, progress=False, figure=False)
    full = (tmp_path / "full.csv").read_text().splitlines(keepends=True)
    (tmp_path / "cut.meta.json").write_text((tmp_path / "full.meta.json").read_text())
    (tmp_path / "cut.csv").write_text("".join([full[0], full[5], full[2], full[7][:20]]))
    outcome = run_sweep(sweep, tmp_path / "cut.csv", pool, progress=False, figure=False)
    assert (outcome.already, outcome.ran) == (2, 7)
    assert read_table(tmp_path / "cut.csv") == read_table(tmp_path / "full.csv")
    again = run_sweep(sweep, tmp_path / "cut.csv", pool, progress=False, figure=False)
    assert (again.already, again.ran) == (9, 0)


def test_the_record_keeps_the_first_start_and_adds_each_resume(tmp_path, pool):
    """The table's record (meta.json) is the sweep's first start: a resume that runs the missing points
    adds its command, its start and the rows it found under ``resumes``; running the finished sweep
    again changes neither the table nor its record, to the byte."""
    sweep = load_sweep(write_sweep(tmp_path, GRID))
    run_sweep(sweep, tmp_path / "full.csv", pool, progress=False, figure=False, command_line="cosim sweep first")
    first = json.loads((tmp_path / "full.meta.json").read_text())
    full = (tmp_path / "full.csv").read_text().splitlines(keepends=True)
    (tmp_path / "full.csv").write_text("".join(full[:4]))  # three rows kept, as by a sweep stopped there
    del first["finished"], first["counts"]  # and no summary yet: a stopped sweep writes none
    (tmp_path / "full.meta.json").write_text(json.dumps(first))
    run_sweep(sweep, tmp_path / "full.csv", pool, progress=False, figure=False, command_line="cosim sweep again")
    meta = json.loads((tmp_path / "full.meta.json").read_text())
    assert (meta["command"], meta["started"]) == ("cosim sweep first", first["started"])
    assert [(r["command"], r["rows_found"]) for r in meta["resumes"]] == [("cosim sweep again", 3)]
    assert meta["counts"] == {"stopped": 9} and "finished" in meta
    table, record = (tmp_path / "full.csv").read_bytes(), (tmp_path / "full.meta.json").read_bytes()
    again = run_sweep(sweep, tmp_path / "full.csv", pool, progress=False, figure=False,
                      command_line="cosim sweep third")
    assert (again.already, again.ran, len(again.rows)) == (9, 0, 9)
    assert (tmp_path / "full.csv").read_bytes() == table
    assert (tmp_path / "full.meta.json").read_bytes() == record


def semaphores() -> set[str]:
    """The named semaphores multiprocessing has in /dev/shm (a pool's, under the spawn start method)."""
    shm = Path("/dev/shm")
    return {p.name for p in shm.iterdir() if p.name.startswith("sem.mp-")} if shm.is_dir() else set()


def semaphores_of_group(pgid: int) -> set[str]:
    """The multiprocessing semaphores the processes of group ``pgid`` have mapped (from their
    /proc maps): those a sweep's pool made, not another program's made meanwhile."""
    names = set()
    for proc in Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            stat = (proc / "stat").read_text()
            if int(stat.rsplit(")", 1)[1].split()[2]) != pgid:  # the fields after the name: state, ppid, pgrp
                continue
            maps = (proc / "maps").read_text()
        except (OSError, ValueError, IndexError):  # gone meanwhile
            continue
        names |= {line.rsplit("/", 1)[1] for line in maps.splitlines() if "/dev/shm/sem.mp-" in line}
    return names


def test_a_sweep_killed_halfway_resumes_to_the_same_table(tmp_path, pool):
    """`cosim sweep` killed with SIGKILL (workers and all) keeps the rows it wrote; running it again
    finishes the rest, and the table equals that of a sweep never interrupted. The pool's semaphores
    do not outlive it: its resource tracker, out of the killed process group, removes them (each
    such kill left ten files in /dev/shm for good)."""
    body = GRID.replace("[2, 3, 5]", "[2, 3, 4, 5]") + "set: {components.ball.burn: 3000}\n"
    path = write_sweep(tmp_path, body)
    out = tmp_path / "killed.csv"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "sweep", str(path), "-o", str(out), "-q",
                             "--workers", "1"], cwd=tmp_path, env=env, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if out.exists() and len(out.read_text().splitlines()) >= 4:  # header + 3 rows
            break
        time.sleep(0.02)
    made = semaphores_of_group(proc.pid)  # the pool's own (another program's may come and go meanwhile)
    assert made, "the sweep's pool should hold its semaphores"
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(10)
    proc.stderr.close()
    written = len(out.read_text().splitlines()) - 1
    assert 3 <= written < 12, "the sweep should have been killed halfway"
    deadline = time.monotonic() + 30
    while semaphores() & made and time.monotonic() < deadline:  # removed once the tracker sees all gone
        time.sleep(0.05)
    assert not semaphores() & made, "the killed sweep left its semaphores in /dev/shm"
    sweep = load_sweep(path)
    outcome = run_sweep(sweep, out, pool, progress=False, figure=False)
    assert outcome.already == written and outcome.ran == 12 - written
    run_sweep(sweep, tmp_path / "whole.csv", pool, progress=False, figure=False)
    assert read_table(out) == read_table(tmp_path / "whole.csv")


def test_a_table_of_another_sweep_is_not_resumed(tmp_path, pool):
    """A table written with other settings is refused (use --fresh or another output); a longer axis
    keeps the rows already there and runs only the new points."""
    sweep = load_sweep(write_sweep(tmp_path, GRID))
    run_sweep(sweep, tmp_path / "out.csv", pool, progress=False, figure=False)
    other = load_sweep(write_sweep(tmp_path, GRID + "set: {components.ball.restitution: 0.5}\n",
                                   name="b.yaml"))
    with pytest.raises(ScenarioError, match=r"out\.csv: holds the results of a different sweep .* --fresh"):
        run_sweep(other, tmp_path / "out.csv", pool, progress=False, figure=False)
    fresh = run_sweep(other, tmp_path / "out.csv", pool, fresh=True, progress=False, figure=False)
    assert (fresh.already, fresh.ran) == (0, 9)
    run_sweep(sweep, tmp_path / "ext.csv", pool, progress=False, figure=False)
    longer = load_sweep(write_sweep(tmp_path, GRID.replace("[2, 3, 5]", "[2, 3, 4, 5]"), name="c.yaml"))
    extended = run_sweep(longer, tmp_path / "ext.csv", pool, progress=False, figure=False)
    assert (extended.already, extended.ran) == (9, 3)
    assert [r["index"] for r in rows_of(tmp_path / "ext.csv")] == [str(i) for i in range(12)]
    shorter = load_sweep(write_sweep(tmp_path, GRID.replace("[2, 3, 5]", "[2, 3]"), name="d.yaml"))
    with pytest.raises(ScenarioError, match=r"holds 6 points that are not in this sweep"):
        run_sweep(shorter, tmp_path / "ext.csv", pool, progress=False, figure=False)


def test_a_row_with_a_status_no_run_gives_is_refused_and_a_rerun_point_keeps_its_result(tmp_path, pool):
    """A hand-edited status ("weird") was taken and summed as "6 weird"; now the table is refused,
    naming the line. A point in the table twice (run again after a stop, killed before the sweep
    rewrote the table) counts once, with its result rather than its interrupted row."""
    sweep = load_sweep(write_sweep(tmp_path, GRID))
    out = tmp_path / "out.csv"
    run_sweep(sweep, out, pool, progress=False, figure=False)
    whole = out.read_text()
    lines = whole.splitlines(keepends=True)
    assert all(",stopped,ball: at rest" in line for line in lines[1:])
    out.write_text("".join([*lines[:3], lines[3].replace(",stopped,", ",weird,", 1), *lines[4:]]))
    with pytest.raises(ScenarioError, match=r"out\.csv: line 4: status 'weird' is not one a run gives "
                                            r"\(ok, stopped, failed, interrupted, unfinished\)"):
        run_sweep(sweep, out, pool, progress=False, figure=False)
    interrupted = lines[2].replace(",stopped,", ",interrupted,", 1)
    out.write_text("".join([*lines[:2], interrupted, *lines[2:]]))  # the stopped run's row, then its result
    again = run_sweep(sweep, out, pool, progress=False, figure=False)
    assert (again.already, again.ran) == (9, 0)  # the point's result kept: it is not run a second time


def test_a_row_with_a_quote_never_closed_is_refused_and_a_row_cut_short_is_dropped(tmp_path, pool):
    """A quote opened in a row's reason and never closed takes in every row after it: the table was
    resumed with that one row, and the runs appended inside the quote (exit 0 twice, the table worse
    each time). Now refused, naming the line. A last row cut short after a line break of its reason
    (the rest of one row, no whole row in it) is dropped, and the runs it held run again."""
    sweep = load_sweep(write_sweep(tmp_path, GRID))
    out = tmp_path / "out.csv"
    run_sweep(sweep, out, pool, progress=False, figure=False)
    lines = out.read_text().splitlines(keepends=True)
    broken = "".join([lines[0], lines[1].replace(",stopped,", ',stopped,"', 1), *lines[2:]])
    out.write_text(broken)
    with pytest.raises(ScenarioError, match=r"out\.csv: line 2: a row of \d+ fields where the table has \d+ "
                                            r"\(a quote opened and never closed"):
        run_sweep(sweep, out, pool, progress=False, figure=False)
    assert out.read_text() == broken
    cut = lines[-1].replace(",stopped,", ',stopped,"line one\nline', 1)
    out.write_text("".join([*lines[:-1], cut.split("\n")[0] + "\n" + "line\n"]))
    again = run_sweep(sweep, out, pool, progress=False, figure=False)
    assert (again.already, again.ran) == (8, 1)
    assert [r["index"] for r in rows_of(out)] == [str(i) for i in range(9)]


TABLE_COLUMNS = ["index", "point_id", "status", "reason", "wall_s"]


def _table_text(reasons: list[str]) -> bytes:
    """A table of failed rows with these reasons, as the sweep writes it."""
    import io

    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(TABLE_COLUMNS)
    for i, reason in enumerate(reasons):
        writer.writerow([i, f"p{i}", "failed", reason, 0.5])
    return buf.getvalue().encode()


def test_a_table_cut_anywhere_in_a_reason_with_commas_on_its_own_lines_resumes(tmp_path):
    """A failure's reason over several lines, one of them with as many commas as the table has
    columns: cut at any byte (a kill), the table resumes with its whole rows, the cut one dropped (it
    was refused as a quote never closed, its other lines taken for rows)."""
    from cosim.sweep.table import ResultTable, meta_path

    reasons = ["ok", "ValueError: in a, b, c, d, e\n  got x, y, z, w, v\nend", "two\nlines"]
    full = _table_text(reasons)
    order = {f"p{i}": i for i in range(len(reasons))}
    header = full.index(b"\n") + 1
    for cut in range(header, len(full) + 1):
        path = tmp_path / f"t{cut}.csv"
        path.write_bytes(full[:cut])
        meta_path(path).write_text(json.dumps({"fingerprint": "fp"}))
        table = ResultTable(path, TABLE_COLUMNS, {"fingerprint": "fp"})
        kept = table.open(order)
        table.close()
        # a row whole but for its line break is kept (tests/test_sweep_audit.py): its end is the byte before
        whole = [i for i in range(len(reasons)) if len(_table_text(reasons[:i + 1])) - 1 <= cut]
        assert sorted(kept) == [f"p{i}" for i in whole], cut
        assert all(kept[f"p{i}"]["reason"] == reasons[i] for i in whole)


def test_a_quote_never_closed_over_a_large_table_is_refused_in_words(tmp_path):
    """Past the csv module's 128 KiB field limit, the quote never closed was an internal error."""
    from cosim.sweep.table import ResultTable, meta_path

    reasons = [f"failure {i}" for i in range(8000)]
    lines = _table_text(reasons).decode().splitlines(keepends=True)
    path = tmp_path / "big.csv"
    path.write_text("".join([lines[0], lines[1].replace(",failure 0,", ',"failure 0,'), *lines[2:]]))
    meta_path(path).write_text(json.dumps({"fingerprint": "fp"}))
    table = ResultTable(path, TABLE_COLUMNS, {"fingerprint": "fp"})
    with pytest.raises(ScenarioError, match=r"big\.csv: line \d+: not a table this sweep wrote \(field larger than "
                                            r"field limit \(131072\)\); use --fresh"):
        table.open({f"p{i}": i for i in range(8000)})


def test_a_table_that_is_not_text_is_refused_and_left_as_it_is(tmp_path, pool):
    """A table made garbage (not UTF-8) beside its intact meta file: refused naming it, with --fresh
    offered, the file untouched (an internal UnicodeDecodeError, after its last "row" was cut off)."""
    sweep = load_sweep(write_sweep(tmp_path, GRID))
    out = tmp_path / "out.csv"
    run_sweep(sweep, out, pool, progress=False, figure=False)
    garbage = b"\xff\xfe\x00garbage\nmore\xc3"
    out.write_bytes(garbage)
    with pytest.raises(ScenarioError, match=r"out\.csv: is not UTF-8 text \(byte 0\).*--fresh"):
        run_sweep(sweep, out, pool, progress=False, figure=False)
    assert out.read_bytes() == garbage


def test_an_output_path_with_a_nul_character_is_bad_input(tmp_path, pool):
    """An output given through the API with a NUL character (no file name can hold it) is a
    ScenarioError naming it, nothing written (an internal ValueError "embedded null byte")."""
    sweep = load_sweep(write_sweep(tmp_path, GRID))
    with pytest.raises(ScenarioError, match=r"a\\x00b\.csv: cannot write the sweep's results here \(not a path "
                                            r"the system can take: embedded null byte\)"):
        run_sweep(sweep, tmp_path / "a\0b.csv", pool, progress=False, figure=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["ball.yaml", "sweep.yaml"]


def test_a_finished_table_is_sorted_again_when_the_axis_values_change_order(tmp_path, pool):
    """Listing an axis's values in another order gives the points other indices: a table finished for
    the old order is sorted again, each row with its new index, though nothing is left to run (it
    kept the old order and indices); run again as it is, it changes nothing, to the byte."""
    out = tmp_path / "t.csv"

    def run(values: str):
        body = f"scene: ball.yaml\naxes:\n  components.ball.speed: {values}\n"
        sweep = load_sweep(write_sweep(tmp_path, body))
        outcome = run_sweep(sweep, out, pool, progress=False, figure=False)
        assert outcome.complete
        return [(r["index"], r["components.ball.speed"]) for r in rows_of(out)]

    assert run("[2, 3]") == [("0", "2"), ("1", "3")]
    assert run("[4, 3, 2]") == [("0", "4"), ("1", "3"), ("2", "2")]
    assert run("[2, 3, 4]") == [("0", "2"), ("1", "3"), ("2", "4")]
    table, record = out.read_bytes(), (tmp_path / "t.meta.json").read_bytes()
    assert run("[2, 3, 4]") == [("0", "2"), ("1", "3"), ("2", "4")]
    assert out.read_bytes() == table and (tmp_path / "t.meta.json").read_bytes() == record


def test_record_writes_an_mcap_per_run_and_the_meta_names_the_scene(tmp_path, pool):
    """With record: true each point's run is recorded beside the table (its path in the row); the
    meta file holds the sweep, the base scene, the fingerprint and the versions."""
    sweep = load_sweep(write_sweep(tmp_path, GRID.replace("[2, 3, 5]", "[2]") + "record: true\n"))
    run_sweep(sweep, tmp_path / "rec.csv", pool, progress=False, figure=False, command_line="cosim sweep x")
    rows = rows_of(tmp_path / "rec.csv")
    for point, row in zip(sweep.points, rows, strict=True):
        assert row["recording"] == str(tmp_path / "rec_runs" / f"{point.point_id}.mcap")
        assert Recording(row["recording"]).scene().data["components"]["ball"]["speed"] == 2
    meta = json.loads((tmp_path / "rec.meta.json").read_text())
    assert meta["scene"] == BALL_SCENE and meta["fingerprint"] == sweep.fingerprint()
    assert meta["versions"]["cosim"] and meta["counts"] == {"stopped": 3}
    assert meta["command"] == "cosim sweep x"


def test_random_sweep_and_summary_figure(tmp_path, pool):
    """A random sweep runs its samples like a grid; the summary figure (scatter, heat map or line) is a
    PNG beside the table."""
    pytest.importorskip("matplotlib")
    body = ("scene: ball.yaml\nmode: random\nsamples: 8\nseed: 3\naxes:\n"
            "  components.ball.angle_deg: {uniform: [10, 80]}\n  components.ball.speed: {uniform: [1, 6]}\n")
    sweep = load_sweep(write_sweep(tmp_path, body))
    outcome = run_sweep(sweep, tmp_path / "r.csv", pool, progress=False)
    assert outcome.figure == tmp_path / "r.png" and (tmp_path / "r.png").read_bytes()[:4] == b"\x89PNG"
    grid = run_sweep(load_sweep(write_sweep(tmp_path, GRID, name="g.yaml")), tmp_path / "g.csv", pool,
                     progress=False)
    assert grid.figure is not None and grid.figure.stat().st_size > 10_000
    line = load_sweep(write_sweep(tmp_path, "scene: ball.yaml\naxes: {components.ball.speed: [1, 2, 3]}\n",
                                  name="l.yaml"))
    assert (line.figure.x, line.figure.y) == ("components.ball.speed", None)
    assert run_sweep(line, tmp_path / "l.csv", pool, progress=False).figure == tmp_path / "l.png"


def test_parquet_output_is_typed(tmp_path, pool):
    """A .parquet output holds the sorted table with typed columns and the sweep's record."""
    pq = pytest.importorskip("pyarrow.parquet")
    sweep = load_sweep(write_sweep(tmp_path, GRID), output=tmp_path / "out.parquet")
    run_sweep(sweep, None, pool, progress=False, figure=False)
    table = pq.read_table(tmp_path / "out.parquet")
    assert table.num_rows == 9 and str(table.schema.field("ball.bounces").type) == "int64"
    assert str(table.schema.field("ball.distance").type) == "double"
    assert b"cosim.sweep" in table.schema.metadata


def signal_state() -> tuple[bool, bool]:
    """In a pool worker: whether SIGINT is ignored, and whether it is blocked."""
    return (signal.getsignal(signal.SIGINT) == signal.SIG_IGN,
            signal.SIGINT in signal.pthread_sigmask(signal.SIG_BLOCK, []))


def test_a_ctrl_c_as_a_pool_worker_starts_waits_until_it_ignores_it():
    """A SIGINT that reaches a pool worker as it starts (a Ctrl-C to the process group in the second the
    worker takes to import, before it sets the signal ignored) is held back from its spawn and dropped
    once it ignores it: the worker runs its point (it printed a KeyboardInterrupt traceback and died,
    the pool broken). The worker then ignores SIGINT without blocking it, and the sweep's own thread
    blocks it no more."""
    backend = ProcessBackend(1)
    backend.start()
    try:
        future = backend.submit(Task(0, "p", BALL_SCENE, "<ball>", ("until=0.5",), ()))
        for process in backend.pool._processes.values():  # spawned by the submit, and starting now
            os.kill(process.pid, signal.SIGINT)
        assert backend.outcome(future)["status"] == "ok"
        assert backend.pool.submit(signal_state).result() == (True, False)
        assert signal.SIGINT not in signal.pthread_sigmask(signal.SIG_BLOCK, [])
    finally:
        backend.close()


def test_a_parquet_tables_journal_leaves_a_csv_of_the_same_name_alone(tmp_path, pool):
    """A Parquet table's rows are journalled in ``<stem>.journal.csv``: a table ``out.csv`` of the user's
    (another sweep's) beside ``out.parquet`` is neither read nor replaced (it was taken for the journal:
    refused as another sweep's, and with --fresh overwritten)."""
    pq = pytest.importorskip("pyarrow.parquet")
    theirs = tmp_path / "out.csv"
    theirs.write_text("mine,not,a,sweep\n1,2,3,4\n")
    sweep = load_sweep(write_sweep(tmp_path, GRID), output=tmp_path / "out.parquet")
    run_sweep(sweep, None, pool, progress=False, figure=False)
    run_sweep(sweep, None, pool, progress=False, figure=False, fresh=True)
    assert pq.read_table(tmp_path / "out.parquet").num_rows == 9
    assert theirs.read_text() == "mine,not,a,sweep\n1,2,3,4\n" and (tmp_path / "out.journal.csv").exists()


def test_a_full_disk_leaves_its_points_unfinished_and_stops_the_sweep(tmp_path):
    """A run whose write the disk refuses (ENOSPC) is no result of its point: it was a `failed` row,
    so that after space was freed the sweep said it held every point and only --fresh ran them. It
    now gets no row, the sweep submits no more points and says once that the disk is full, and run
    again once there is room it runs them all."""
    full = tmp_path / "disk_is_full"
    full.touch()
    body = GRID + f"set: {{components.ball.disk_full_while: {str(full)!r}}}\n"
    sweep = load_sweep(write_sweep(tmp_path, body))
    outcome = run_and_close(sweep, tmp_path / "out.csv", ProcessBackend(1))
    assert not outcome.complete and outcome.limit == os.strerror(errno.ENOSPC)
    assert (outcome.ran, rows_of(tmp_path / "out.csv")) == (0, [])
    assert 1 <= outcome.unfinished <= 2  # those in flight (two a worker) when the first came back; no more
    summary = outcome.summary()
    assert summary.count("no room") == 1
    assert ("stopped, the machine has no room for the recordings (No space left on device): 9 of 9 points left; "
            "they run when the same command is run again once there is room") in summary
    full.unlink()  # space freed
    again = run_and_close(sweep, tmp_path / "out.csv", ProcessBackend(1))
    assert again.complete and (again.already, again.ran) == (0, 9) and again.counts == {"stopped": 9}


@pytest.mark.parametrize(("error", "limit"), [
    (SinkError("r.mcap: writing the recording failed (No space left on device); the recording was closed "
               "where it stopped"), os.strerror(errno.ENOSPC)),
    (RecordingError("r.mcap: cannot write the recording (Disk quota exceeded)"), os.strerror(errno.EDQUOT)),
    (OSError(errno.ENOSPC, os.strerror(errno.ENOSPC)), os.strerror(errno.ENOSPC)),
    (SinkError("r.mcap: writing the recording failed (File too large); the recording was closed where it "
               "stopped"), os.strerror(errno.EFBIG)),
    (OSError(errno.EFBIG, os.strerror(errno.EFBIG)), os.strerror(errno.EFBIG)),
    (SinkError("r.mcap: the recording writer was killed (SIGKILL); the recording was salvaged"), None),
    (OSError(errno.EACCES, os.strerror(errno.EACCES)), None),
], ids=["sink-full", "recording-quota", "oserror-full", "sink-size-limit", "oserror-size-limit", "writer-killed",
        "no-permission"])
def test_a_recording_refused_for_want_of_room_is_unfinished_not_failed(monkeypatch, error, limit):
    """The recording's writer reports a full disk or quota by the system's words (a SinkError or
    RecordingError): the run's row is `unfinished`, naming the limit; any other failure stays `failed`."""
    import cosim.runner
    from cosim.sweep.backends import Task, run_task

    def refused(*args, **kwargs):
        raise error

    monkeypatch.setattr(cosim.runner, "run_scene", refused)
    row = run_task(Task(0, "p0", BALL_SCENE, "ball.yaml", (), (), "r.mcap"))
    assert (row["status"], row.get("limit")) == (("unfinished", limit) if limit else ("failed", None))
    assert row["reason"] == f"{type(error).__name__}: {error}"
