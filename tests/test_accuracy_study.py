"""``cosim bench accuracy``: the work-precision study (components/analysis/accuracy.py), on its --quick
setting against the reference skip, plus the plan's overrides and the table's bookkeeping."""

from __future__ import annotations

import re
from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest

from components.analysis.accuracy import (
    FIGURE,
    SECTION,
    Trace,
    compare,
    plan,
)
from cosim.cli import main
from cosim.docsection import replace_section
from cosim.scenario import load

ROOT = Path(__file__).resolve().parent.parent
SKIP = ROOT / "scenarios" / "held_skip.yaml"
COLUMNS = ["group", "variant", "wall (x fastest)", "trajectory error, skips [mm]",
           "trajectory error, whole run [mm]", "skips (ref", "skip distance error [mm]",
           "energy error [% of E0]", "end", "settings"]


def rows_of(page: str) -> tuple[list[str], list[list[str]]]:
    """The header and the rows of the generated markdown table."""
    section = page.split(f"<!-- {SECTION}:begin -->", 1)[1].split(f"<!-- {SECTION}:end -->", 1)[0]
    lines = [line for line in section.splitlines() if line.startswith("|")]
    cells = [[c.strip() for c in line.strip("|").split(" | ")] for line in lines]
    return cells[0], cells[2:]


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """One quick study of the reference skip through the command line: (exit code, output folder)."""
    out = tmp_path_factory.mktemp("accuracy")
    (out / "accuracy.md").write_text("# Accuracy\n\nHand-written text stays.\n", encoding="utf-8")
    code = main(["bench", "accuracy", str(SKIP), "--quick", "-o", str(out), "-q"])
    return code, out


def test_the_command_writes_the_table_section_and_a_small_figure(quick):
    """Exit 0; the table goes between its markers in accuracy.md (the page's own text kept) and the
    figure is a PNG under 2 MB in figures/."""
    code, out = quick
    assert code == 0
    page = (out / "accuracy.md").read_text(encoding="utf-8")
    assert page.startswith("# Accuracy\n\nHand-written text stays.\n")
    assert f"<!-- {SECTION}:begin -->" in page and f"<!-- {SECTION}:end -->" in page
    png = out / "figures" / "accuracy.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert png.stat().st_size < 2_000_000
    assert "![Error against wall time](figures/accuracy.png)" in page


def test_the_table_has_one_row_per_run_with_the_reference_first_at_zero_error(quick):
    """Columns as documented; the reference row first with every error 0 and wall ratio >= 1; every
    group of the study present; one row has the fastest wall time (ratio 1.00)."""
    _, out = quick
    header, rows = rows_of((out / "accuracy.md").read_text(encoding="utf-8"))
    assert header[:5] + header[6:] == COLUMNS[:5] + COLUMNS[6:] and header[5].startswith("skips (ref ")
    assert all(len(r) == len(COLUMNS) for r in rows)
    ref = rows[0]
    assert ref[0] == "reference"
    assert ref[3] == ref[4] == ref[6] == ref[7] == "0"
    assert float(ref[2]) >= 1.0
    assert {r[0] for r in rows} == {"reference", "base step", "integrator", "water", "coupling", "effects"}
    assert min(float(r[2]) for r in rows) == 1.0


def test_errors_shrink_as_the_base_step_shrinks(quick):
    """Along the base-step series (0.25 .. 1 ms), the trajectory and energy errors grow with dt, and
    the run gets cheaper. A skip's distance runs between the steps its touchdowns fall on, so each
    run resolves it to one step of travel and its error is no trend but at most a step of the run's
    and one of the reference's at the throw's speed (under 12 m/s), beyond the trajectory's own error."""
    _, out = quick
    page = (out / "accuracy.md").read_text(encoding="utf-8")
    _, rows = rows_of(page)
    series = [r for r in rows if r[0] == "base step"]
    dts = [float(r[1].split("dt = ")[1].split(" ms")[0]) for r in series]
    assert dts == sorted(dts) and len(dts) >= 3
    for column in (3, 7):
        errors = [float(r[column]) for r in series]
        assert all(a < b for a, b in pairwise(errors)), (column, errors)
    assert float(series[0][2]) > float(series[-1][2])
    reference_dt_ms = float(page.split("Reference: `dt=")[1].split(" ")[0]) * 1e3
    for dt, row in zip(dts, series, strict=True):
        assert float(row[6]) <= 12.0 * (dt + reference_dt_ms) + float(row[3]), (dt, row[6])


def test_the_plan_holds_the_water_step_and_the_domain():
    """Every base-step variant keeps the water stepping every 2 ms; the coarse-water variant covers the
    same 8 m x 1 m; the Jacobi variant makes the body and water edges into the coupler delayed; the
    reference takes a sixteenth of the step with cells and water step halved (full) or a quarter of
    the step with the scene's water (quick)."""
    scene = load(SKIP)
    reference, variants = plan(scene, quick=False)
    fine = load(SKIP, overrides=list(reference.overrides))
    assert fine.dt_ns * 16 == scene.dt_ns and fine.components["pond"].params.cell == 0.005
    assert fine.dt_ns * fine.components["pond"].every == 1_000_000  # half the water step
    for v in variants:
        if v.group == "base step" and v.overrides:
            s = load(SKIP, overrides=list(v.overrides))
            assert s.dt_ns * s.components["pond"].every == 2_000_000
    coarse = next(v for v in variants if v.name == "wave, 2 cm cells")
    p = load(SKIP, overrides=list(coarse.overrides)).components["pond"].params
    assert p.origin_x - p.cell / 2 == pytest.approx(-0.005) and p.nx * p.cell == pytest.approx(8.0)
    airy = next(v for v in variants if v.name == "airy (dispersive), 1 cm cells")
    assert load(SKIP, overrides=list(airy.overrides)).components["pond"].params.model == "airy"
    jacobi = next(v for v in variants if v.group == "coupling")
    edges = load(SKIP, overrides=list(jacobi.overrides)).connections
    delayed = {(e.source, e.target, e.target_port) for e in edges if e.delay}
    assert {("stone", "coupler", "body"), ("pond", "coupler", "water")} <= delayed
    quick_ref, _ = plan(scene, quick=True)
    coarse_ref = load(SKIP, overrides=list(quick_ref.overrides))
    assert coarse_ref.dt_ns * 4 == scene.dt_ns
    assert coarse_ref.components["pond"].params == scene.components["pond"].params


def trace(x: np.ndarray, distances: list[float]) -> Trace:
    t = np.linspace(0.0, 1.0, len(x))
    position = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    takeoffs = [0.1 * (k + 1) for k in range(len(distances))]
    return Trace(t, position, 10.0 - x, len(distances), distances, "sink", "stopped", "", 1.0, takeoffs, [1.0])


def test_compare_measures_positions_at_equal_times_and_skips_both_runs_made():
    """Identical runs differ by 0; a run 1 cm ahead everywhere is 1 cm off, its energy by 0.1% of 10 J;
    skip distances compare over the skips both made, the count separately."""
    base = trace(np.linspace(0.0, 5.0, 11), [1.0, 0.5])
    same = compare(base, base)
    assert same["trajectory"] == same["trajectory_skips"] == same["distance"] == same["energy"] == 0.0
    ahead = compare(trace(np.linspace(0.0, 5.0, 11) + 0.01, [1.02, 0.5, 0.2]), base)
    assert ahead["trajectory"] == pytest.approx(0.01) and ahead["energy"] == pytest.approx(0.1)
    assert ahead["distance"] == pytest.approx(0.02) and ahead["skip_diff"] == 1


def test_replace_section_keeps_the_rest_of_the_page(tmp_path):
    """The generated block replaces the old one between its markers; text before and after stays."""
    page = tmp_path / "a.md"
    page.write_text(f"intro\n<!-- {SECTION}:begin -->\nold\n<!-- {SECTION}:end -->\noutro\n", encoding="utf-8")
    replace_section(page, SECTION, "new table")
    assert page.read_text(encoding="utf-8") == (f"intro\n<!-- {SECTION}:begin -->\nnew table\n"
                                                f"<!-- {SECTION}:end -->\noutro\n")


def test_replace_section_that_cannot_be_written_leaves_the_page_as_it_was(tmp_path, monkeypatch):
    """A write that fails part-way (a full disk, a file-size limit) leaves the page whole, as it was,
    and names it; it once cut the page short, losing the text around the section."""
    import errno

    page = tmp_path / "a.md"
    before = "intro\n" + "hand-written text\n" * 1000
    page.write_text(before, encoding="utf-8")
    real = Path.write_text

    def cut_short(self, text, *args, **kwargs):
        real(self, text[:100], *args, **kwargs)
        raise OSError(errno.EFBIG, "File too large")

    monkeypatch.setattr(Path, "write_text", cut_short)
    with pytest.raises(OSError) as caught:
        replace_section(page, SECTION, "new table")
    monkeypatch.undo()
    assert caught.value.filename == str(page)
    assert page.read_text(encoding="utf-8") == before
    assert [p.name for p in tmp_path.iterdir()] == ["a.md"]


@pytest.mark.parametrize("problem", ["not_utf8", "figure_is_a_folder", "read_only_page", "markers_swapped",
                                     "begin_alone", "end_alone", "begin_twice"])
def test_a_page_or_figure_the_study_cannot_write_is_bad_input_before_any_run(tmp_path, capsys, monkeypatch,
                                                                            problem):
    """A page that is not UTF-8 text, a folder where the figure goes, a read-only page: exit 2 and one
    line naming it, before the study's runs (they were found only after every run)."""
    import os

    import components.analysis.accuracy as accuracy

    page, figure = tmp_path / "accuracy.md", tmp_path / FIGURE
    if problem == "not_utf8":
        page.write_bytes(b"# Accuracy \xff\xfe\n")
    elif problem == "figure_is_a_folder":
        figure.mkdir(parents=True)
    elif problem == "markers_swapped":  # (an internal error after the whole study, its figure already replaced)
        page.write_text(f"x\n<!-- {SECTION}:end -->\ny\n<!-- {SECTION}:begin -->\n", encoding="utf-8")
    elif problem == "begin_alone":  # (a section was added after it, and the next study's page lost "b")
        page.write_text(f"a\n<!-- {SECTION}:begin -->\nb\n", encoding="utf-8")
    elif problem == "end_alone":
        page.write_text(f"a\n<!-- {SECTION}:end -->\nb\n", encoding="utf-8")
    elif problem == "begin_twice":
        page.write_text(f"<!-- {SECTION}:begin -->\n<!-- {SECTION}:begin -->\nb\n<!-- {SECTION}:end -->\n",
                        encoding="utf-8")
    else:
        page.write_text("# Accuracy\n", encoding="utf-8")
        page.chmod(0o444)
        if os.access(page, os.W_OK):  # root may write read-only files: it is told what another user is
            access = os.access
            monkeypatch.setattr(accuracy.os, "access", lambda path, mode: (
                not (mode & os.W_OK) and access(path, mode) if Path(path) == page else access(path, mode)))
    monkeypatch.setattr(accuracy, "run_study", lambda *a, **k: pytest.fail("the study ran"))
    assert main(["bench", "accuracy", str(SKIP), "--quick", "-o", str(tmp_path), "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {tmp_path}: ") and len(err.splitlines()) == 1
    assert str(figure if problem == "figure_is_a_folder" else page) in err


def test_a_scene_without_a_stone_is_bad_input(tmp_path, capsys):
    """The study follows a stone: a water-only scene exits 2 saying so, writing nothing."""
    code = main(["bench", "accuracy", str(ROOT / "scenarios" / "wave_pulse.yaml"), "-o", str(tmp_path), "-q"])
    assert code == 2
    assert "no RigidBody" in capsys.readouterr().err
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("where", ["a_file", "a_file/inside"])
def test_an_output_that_cannot_be_a_folder_is_bad_input_before_any_run(tmp_path, capsys, monkeypatch, where):
    """-o naming a file, or a folder under one: exit 2 and one line at once, no run made (it ran
    every variant and then failed writing the figure)."""
    import components.analysis.accuracy as accuracy

    (tmp_path / "a_file").write_text("x")
    monkeypatch.setattr(accuracy, "run_study", lambda *a, **k: pytest.fail("the study ran"))
    scene = str(Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml")
    assert main(["bench", "accuracy", scene, "--quick", "-o", str(tmp_path / where)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"error: {tmp_path / where}: ") and ("not a folder" in err or "is a file" in err)


def test_ctrl_c_during_a_run_stops_the_study(tmp_path, capsys, monkeypatch):
    """A run that Ctrl-C cuts short is no result: the study stops (exit 1, one line, nothing written).
    It went on with the next runs, wrote its page with the cut-short run as a row, and exited 0."""
    import components.analysis.accuracy as accuracy
    import cosim.runner

    real = cosim.runner.run_scene

    def interrupted(scene, *args, **kwargs):
        outcome = real(scene, *args, **kwargs)
        outcome.result.status = "interrupted"
        return outcome

    monkeypatch.setattr(cosim.runner, "run_scene", interrupted)
    monkeypatch.setattr(accuracy, "QUICK_UNTIL", 0.01)
    assert main(["bench", "accuracy", str(SKIP), "--quick", "-o", str(tmp_path / "b"), "-q"]) == 1
    assert "interrupted" in capsys.readouterr().err
    assert not (tmp_path / "b" / "accuracy.md").exists()


@pytest.mark.parametrize("until, said", [("1e300", "must be at most"), ("0", "must be later than 0 s")])
def test_an_until_out_of_range_is_bad_input_before_any_run(tmp_path, capsys, monkeypatch, until, said):
    """--until is bounded as `cosim run --until` is, at once: it was refused only after the warm-up
    runs, and named as the scene file's own `until`."""
    import components.analysis.accuracy as accuracy

    monkeypatch.setattr(accuracy, "run_study", lambda *a, **k: pytest.fail("the study ran"))
    with pytest.raises(SystemExit) as exc:
        main(["bench", "accuracy", str(SKIP), "--quick", "--until", until, "-o", str(tmp_path / "o")])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--until" in err[0] and said in err[0]
    assert not (tmp_path / "o").exists()


def test_an_until_shorter_than_a_variants_step_is_said_of_until_before_any_run(tmp_path, capsys, monkeypatch):
    """--until 0.7 ms against the quick study's 1 ms variants: refused as the scene file's own `until`
    ("until: must be at least one base step, dt = 0.001 s"), which the user never set, at a dt not the
    scene's, after warm-up runs; now said of --until and the variant, before any run."""
    import components.analysis.accuracy as accuracy

    monkeypatch.setattr(accuracy, "run_variant", lambda *a, **k: pytest.fail("a variant ran"))
    assert main(["bench", "accuracy", str(SKIP), "--quick", "--until", "0.0007", "-o", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["error: --until 0.0007 s is shorter than one base step of the variant 'semi_implicit_euler, "
                   "dt = 1 ms' (dt = 0.001 s): give --until of at least 0.001 s"]
    assert not (tmp_path / "o").exists()


def test_a_pages_section_is_written_through_a_new_file_and_leaves_a_same_named_one_alone(tmp_path):
    """A page's section is written to a new temporary beside it, never to a file that was there: a
    fixed PAGE.tmp was written over, then removed, whatever it held."""
    page, theirs = tmp_path / "page.md", tmp_path / "page.md.tmp"
    theirs.write_text("a file of the user's\n")
    replace_section(page, "table", "new table")
    assert "new table" in page.read_text() and theirs.read_text() == "a file of the user's\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["page.md", "page.md.tmp"]


def test_a_runs_wall_time_leaves_out_the_kernels_it_compiled(monkeypatch):
    """The warm-up runs 0.02 s, before the stone's first contact, so the first timed run compiled the
    contact's kernels when their cache was cold: the reference's 0.7 s read 57 s, every wall ratio
    180x off. A run's wall time is its loop's, without the compiling (as the run summary's rate)."""
    import components.analysis.accuracy as accuracy
    import cosim.runner

    real = cosim.runner.run_scene
    seen = {}

    def compiling(scene, *args, **kwargs):
        outcome = real(scene, *args, **kwargs)
        outcome.result.compile_s = 0.75 * outcome.result.wall_s  # as if three quarters of it compiled
        seen["wall"] = outcome.result.wall_s
        return outcome

    monkeypatch.setattr(cosim.runner, "run_scene", compiling)
    reference, _ = accuracy.plan(load(SKIP), True)
    trace = accuracy.run_variant(SKIP, reference, 0.01)
    assert trace.walls == [pytest.approx(0.25 * seen["wall"], rel=1e-12)]


def test_a_study_whose_writing_is_interrupted_leaves_no_empty_folder(tmp_path, monkeypatch):
    """Ctrl-C while the figure is drawn: the output folder and its figures folder, made for them, go
    again (both were left empty), as a plot's are."""
    from components.analysis import accuracy

    def interrupted(study, path, dpi=100):
        Path(path).parent.mkdir(parents=True, exist_ok=True)  # as the figure makes its folder
        raise KeyboardInterrupt

    monkeypatch.setattr(accuracy, "figure", interrupted)
    out = tmp_path / "new" / "study"
    with pytest.raises(KeyboardInterrupt):
        accuracy.write(object(), out)
    assert not (tmp_path / "new").exists()


def test_a_scenes_own_until_shorter_than_a_variants_step_is_said_of_it_before_any_run(tmp_path, capsys,
                                                                                      monkeypatch):
    """The full study of a scene whose own `until` (1.5 ms) is shorter than its coarse variant's step
    (2 ms): it was refused as "until: must be at least one base step, dt = 0.002 s", the variant's dt
    said as the scene file's (0.5 ms); now said of the scene's until and the variant, before any run."""
    import components.analysis.accuracy as accuracy

    text = (ROOT / "scenarios" / "held_skip.yaml").read_text()
    scene = tmp_path / "tiny.yaml"
    scene.write_text(re.sub(r"(?m)^until: [0-9.]+", "until: 0.0015", text, count=1))
    monkeypatch.setattr(accuracy, "run_variant", lambda *a, **k: pytest.fail("a variant ran"))
    assert main(["bench", "accuracy", str(scene), "-o", str(tmp_path / "o")]) == 2
    (err,) = capsys.readouterr().err.strip().splitlines()
    assert re.fullmatch(r"error: the scene's until, 0\.0015 s, is shorter than one base step of the variant "
                        r"'.*' \(dt = 0\.002 s\): give --until of at least 0\.002 s", err), err
    assert not (tmp_path / "o").exists()
