"""`cosim sweep`: exit codes 0/1/2, one-line errors, resuming, and Ctrl-C keeping what was done."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import cosim.sweep.backends
from cosim.cli import main
from tests.sweep_toys import write_sweep

ROOT = Path(__file__).resolve().parents[1]

SWEEP = """
scene: ball.yaml
axes:
  components.ball.angle_deg: [30, 60]
  components.ball.speed: [2, 3, 5]
output: results/balls.csv
"""


def test_sweep_runs_reports_and_resumes(tmp_path, monkeypatch, capsys):
    """`cosim sweep` exits 0 and prints the points, statuses, table and figure; run again, it says it
    resumes and runs nothing; --fresh runs everything again."""
    monkeypatch.chdir(tmp_path)
    path = write_sweep(tmp_path, SWEEP)
    assert main(["sweep", str(path), "-q", "--workers", "2"]) == 0
    out = capsys.readouterr().out
    assert ("sweep: 6 points (grid of 2 components.ball.angle_deg x 3 components.ball.speed) "
            "on process pool of 2 workers") in out
    assert "ran 6, 0 already in the table; 6 stopped;" in out and "table: results/balls.csv" in out
    assert (tmp_path / "results" / "balls.csv").exists()
    assert (tmp_path / "results" / "balls.meta.json").exists()
    assert main(["sweep", str(path), "-q", "--workers", "2"]) == 0
    captured = capsys.readouterr()
    assert "resuming results/balls.csv: points already there are skipped" in captured.err
    assert "ran 0, 6 already in the table" in captured.out
    assert main(["sweep", str(path), "-q", "--workers", "2", "--fresh", "--no-figure"]) == 0
    assert "ran 6, 0 already" in capsys.readouterr().out


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


def test_failed_points_fail_the_command_only_when_strict(tmp_path, capsys):
    """Failed runs are rows of a complete sweep (exit 0); with --strict they make it exit 1."""
    path = write_sweep(tmp_path, SWEEP + "set: {components.ball.fail_at_bounce: 2}\n")
    out = str(tmp_path / "f.csv")
    assert main(["sweep", str(path), "-q", "-o", out, "--workers", "2", "--no-figure"]) == 0
    text = capsys.readouterr().out
    assert "failed #0 (components.ball.angle_deg=30, components.ball.speed=2): component 'ball'" in text
    assert main(["sweep", str(path), "-q", "-o", out, "--strict", "--fresh", "--workers", "2",
                 "--no-figure"]) == 1
    assert "points failed (--strict)" in capsys.readouterr().err


def test_table_of_another_sweep_exits_2(tmp_path, capsys):
    """Resuming a table that another sweep wrote is refused with exit 2."""
    out = str(tmp_path / "t.csv")
    assert main(["sweep", str(write_sweep(tmp_path, SWEEP)), "-q", "-o", out, "--workers", "1"]) == 0
    other = write_sweep(tmp_path, SWEEP + "until: 1.0\n", name="other.yaml")
    assert main(["sweep", str(other), "-q", "-o", out]) == 2
    assert "t.csv: holds the results of a different sweep" in capsys.readouterr().err


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
    assert "error: cannot reach the Dask scheduler at tcp://127.0.0.1:9" in capsys.readouterr().err
    assert not (tmp_path / "x.csv").exists()


def test_ctrl_c_keeps_finished_rows_and_exits_1(tmp_path):
    """Ctrl-C (SIGINT to the process group) ends the sweep with exit 1, keeps the rows written, and
    says how to resume."""
    path = write_sweep(tmp_path, SWEEP.replace("[2, 3, 5]", "[2, 3, 4, 5, 6, 7]") +
                       "set: {components.ball.burn: 3000}\n")
    out = tmp_path / "i.csv"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "sweep", str(path), "-q", "-o", str(out),
                             "--workers", "1"], cwd=tmp_path, env=env, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        if out.exists() and len(out.read_text().splitlines()) >= 3:
            break
        time.sleep(0.02)
    os.killpg(proc.pid, signal.SIGINT)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 1, stderr
    assert "interrupted: " in stdout and "run the same command again to resume" in stdout
    assert "Traceback" not in stderr
    rows = len(out.read_text().splitlines()) - 1
    assert 2 <= rows < 12
