"""tools/options.py and the tools' command lines: a bad option value is one usage line and exit
status 2 before any run, never a traceback; --help describes without running."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tools import options
from tools.validate_targets import FIGURE

ROOT = Path(__file__).resolve().parents[1]


def _tool(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    return subprocess.run([sys.executable, *args], cwd=ROOT, env=env, capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize("args", [
    ("tools/bench_water.py", "--rounds", "0"),
    ("tools/bench_water.py", "--models", "nope"),
    ("tools/bench_framework.py", "--repeats", "0"),
    ("tools/contact_time_law.py", "--beta", "95"),
    ("tools/bench_skip.py", "--scene", "scenarios/no_such_scene.yaml"),
    ("tools/validate_targets.py", "--markdown", "tools"),  # a folder, refused before the ~6 min study
])
def test_a_bad_option_is_a_usage_error(args):
    done = _tool(*args)
    assert done.returncode == 2, done.stdout + done.stderr
    assert "Traceback" not in done.stderr
    assert done.stderr.startswith("usage:")
    assert "error:" in done.stderr.splitlines()[-1]


def test_contact_push_help_runs_no_study():
    done = _tool("tools/contact_push.py", "--help")
    assert done.returncode == 0, done.stderr
    # had --help run the study, its table (headed "| throw |") would follow the usage text
    assert done.stdout.startswith("usage:") and "| throw |" not in done.stdout


def test_validate_targets_figure_goes_beside_the_page(tmp_path):
    assert options.figure_beside(Path("docs/validation.md"), FIGURE) == Path("docs/figures/magic_angle.png")
    assert options.figure_beside(tmp_path / "page.md", FIGURE) == tmp_path / "figures" / "magic_angle.png"


def test_description_is_the_whole_first_paragraph():
    doc = "First line of a sentence\nthat goes on.\n\n    python tools/x.py\n"
    assert options.description(doc) == "First line of a sentence that goes on."


def test_types_refuse_bad_values():
    assert options.positive_int("3") == 3
    assert options.positive_float("0.5") == 0.5
    assert options.angle_deg(0.0, 90.0)("20") == 20.0
    for kind, text in ((options.positive_int, "0"), (options.positive_int, "x"), (options.positive_float, "-1"),
                       (options.positive_float, "nan"), (options.positive_float, "inf"),
                       (options.angle_deg(0.0, 90.0), "95")):
        with pytest.raises(argparse.ArgumentTypeError):
            kind(text)


def test_check_output(tmp_path):
    parser = argparse.ArgumentParser()
    assert options.check_output(parser, None, "--write") is None
    page = tmp_path / "new" / "page.md"
    assert options.check_output(parser, page, "--write", text=True) == page
    assert not (tmp_path / "new").exists()  # checked, not made
    (tmp_path / "bad.md").write_bytes(b"\xff\xfe not text")
    (tmp_path / "file").write_text("x")
    for path, text in ((tmp_path, False), (tmp_path / "bad.md", True), (tmp_path / "file" / "page.md", False)):
        with pytest.raises(SystemExit) as exit_:
            options.check_output(parser, path, "--write", text=text)
        assert exit_.value.code == 2


@pytest.mark.parametrize(("tool", "option", "marker"), [
    ("tools/validate_scenes.py", "--markdown", "<!-- bocquet:end -->"),
    ("tools/bench_framework.py", "--write", "<!-- framework:end -->"),
    ("tools/bench_water.py", "--markdown", "<!-- water-throughput:end -->"),
])
def test_a_page_whose_section_cannot_be_replaced_is_refused_before_the_run(tmp_path, tool, option, marker):
    """A page missing one of the markers of a section the tool rewrites was found after the whole run,
    as a traceback, and a tool writing several sections had rewritten the earlier ones (bench_water
    wrote its begin marker a second time). Now one usage line before any run, the page untouched."""
    name = marker[5:marker.index(":")]
    page = tmp_path / "p.md"
    page.write_text(f"# page\n\n<!-- {name}:begin -->\nold\n\nkept\n", encoding="utf-8")
    before = page.read_bytes()
    done = _tool(tool, option, str(page))
    assert done.returncode == 2, done.stderr
    assert done.stderr.strip().splitlines()[-1].endswith(
        f"{option} {page}: it has a '<!-- {name}:begin -->' but no '{marker}'; add the missing marker around the "
        "section (or remove the one there)")
    assert page.read_bytes() == before


def test_a_run_cut_short_by_ctrl_c_ends_a_tool_writing_nothing(tmp_path, monkeypatch):
    """A Ctrl-C ends a run as "interrupted" and run() returns: the tools then wrote the cut-short run's
    figures into the page as measured, exit 0. Under the tools (tools.options imported) the
    interruption goes on once the run's observers are told (a recording closed), and the tool ends in
    one line, exit 130, nothing more written."""
    from cosim.examples import Ping
    from cosim.scenario import loads
    from cosim.scheduler import BaseObserver, Simulation

    class Interrupts(Ping):
        def _step_impl(self, t, dt, inputs):
            if t >= 0.005:
                raise KeyboardInterrupt
            return super()._step_impl(t, dt, inputs)

    told = []

    class Told(BaseObserver):
        def on_finished(self, sim, result):
            told.append(result.status)

    scene = loads((ROOT / "scenarios" / "ping_pong.yaml").read_text(), source="ping_pong")

    def built():
        components = scene.instantiate()
        components["ping"] = Interrupts("ping", scene.components["ping"].params)
        return components

    monkeypatch.setattr(Simulation, "raise_interrupts", False)
    assert Simulation(scene, components=built(), observers=[Told()]).run().status == "interrupted"
    monkeypatch.setattr(Simulation, "raise_interrupts", True)
    with pytest.raises(KeyboardInterrupt):
        Simulation(scene, components=built(), observers=[Told()]).run()
    assert told == ["interrupted", "interrupted"]
    page = tmp_path / "p.md"
    page.write_text("kept\n")
    done = _tool("-c", f"import sys\nsys.modules['__main__'].__file__ = {str(ROOT / 'tools' / 'a_tool.py')!r}\n"
                       "sys.argv[0] = 'a_tool.py'\nimport tools.options\nraise KeyboardInterrupt")
    assert done.returncode == 130
    assert done.stderr == "a_tool.py: interrupted; what it had not yet written is not written\n"
    assert page.read_text() == "kept\n"


def test_a_pages_section_keeps_the_pages_mode_and_a_read_only_page_is_refused(tmp_path):
    """A section written into a page of mode 0600 left it 0644 (a new file moved onto it); a page made
    read-only was replaced all the same by a tool run as root, whose writes ignore the bits. The mode
    is kept, and a read-only page refused: by the tool before its run, and by the writing itself."""
    import stat

    from cosim.docsection import replace_section

    page = tmp_path / "p.md"
    page.write_text("# page\n", encoding="utf-8")
    page.chmod(0o600)
    replace_section(page, "s", "body")
    assert stat.S_IMODE(page.stat().st_mode) == 0o600 and "body" in page.read_text()
    page.chmod(0o444)
    with pytest.raises(PermissionError, match="is read-only; its section is not written"):
        replace_section(page, "s", "other")
    assert "other" not in page.read_text()
    parser = argparse.ArgumentParser()
    with pytest.raises(SystemExit):
        options.check_output(parser, page, "--write", text=True)
    page.chmod(0o644)


BAD_SCENE = "dt: x\n"


@pytest.mark.parametrize(("args", "said"), [
    (("tools/spin_regimes.py", "--figure", "{tmp}/x.txt"), "--figure {tmp}/x.txt: a figure's name ends in .png, "
                                                           ".pdf, .svg (the format it is written as)"),
    (("tools/spin_regimes.py", "--figure", "{tmp}/noext"), "--figure {tmp}/noext: a figure's name ends in"),
    (("tools/bench_skip.py", "--scene", "{tmp}/bad.yaml"), "--scene {tmp}/bad.yaml: dt: must be a number of seconds "
                                                           "(got 'x') (and 2 more: cosim validate {tmp}/bad.yaml)"),
    (("tools/bench_skip.py", "--scene", "{tmp}"), "--scene {tmp}: a folder"),
    (("tools/bench_water_paths.py", "--sizes", "1"), "--sizes: each at least 2 (got 1)"),
    (("tools/spin_precession.py", "--figure", "{tmp}/a.png", "--markdown", "{tmp}/v.md"),
     "--markdown rewrites the section of the thin slate's table, which --figure does not make"),
])
def test_what_a_tool_cannot_do_is_said_before_it_runs(tmp_path, args, said):
    """A figure named in no format matplotlib writes (a traceback after the run; a name without an
    ending was written as NAME.png while the tool said NAME), a scene that does not load (a
    traceback), a grid of one column (a traceback), --markdown beside an option whose run writes no
    section (the page was left as it was, without a word): one usage line, exit 2, nothing run."""
    (tmp_path / "bad.yaml").write_text(BAD_SCENE)
    done = _tool(*(a.format(tmp=tmp_path) for a in args))
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    assert done.stderr.splitlines()[-1].startswith(f"{Path(args[0]).name}: error: {said.format(tmp=tmp_path)}")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.yaml"]


def test_a_figure_goes_into_a_folder_made_for_it(tmp_path):
    """check_figure lets a folder that can be made pass; save_figure makes it (spin_regimes and
    glide_water wrote into it without making it: a traceback after the run)."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    path = tmp_path / "new" / "sub" / "x.png"
    parser = argparse.ArgumentParser()
    assert options.check_figure(parser, path, "--figure") == path
    options.save_figure(Figure(), path)
    assert path.read_bytes().startswith(b"\x89PNG")


def test_bench_accuracy_refuses_a_read_only_page_before_its_study(tmp_path):
    """The page's permission bits, which root's writes ignore: the study ran to its end, replaced the
    figure, and only then refused the page (a new figure beside the old table)."""
    from components.analysis.accuracy import output_folder_problem

    page = tmp_path / "accuracy.md"
    page.write_text("# page\n")
    page.chmod(0o444)
    assert output_folder_problem(tmp_path) == f"{page} is read-only; it is not replaced"
