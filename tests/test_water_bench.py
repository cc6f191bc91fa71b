"""The water benchmark script runs and writes its own section of docs/performance.md."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

TOOL = Path(__file__).resolve().parent.parent / "tools" / "bench_water.py"


def load_tool():
    spec = importlib.util.spec_from_file_location("bench_water", TOOL)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


def test_benchmark_prints_and_writes_its_section(tmp_path, capsys):
    """A tiny run prints the table and writes the section with the reproducing command."""
    bench = load_tool()
    doc = tmp_path / "performance.md"
    args = ["--sizes", "16", "--models", "wave", "shallow_water", "--boundaries", "reflecting",
            "--rounds", "1", "--min-time", "0.001", "--numpy", "--markdown", str(doc)]
    assert bench.main(args) == 0
    out = capsys.readouterr().out
    assert "| 16 x 16 | wave | reflecting | numba |" in out
    text = doc.read_text()
    assert text.startswith(f"{bench.BEGIN}\n{bench.SECTION}\n")
    assert "| 16 x 16 | shallow_water | reflecting | numpy |" in text
    assert "Reproduce: `python tools/bench_water.py --sizes 16" in text


def test_section_is_replaced_in_place(tmp_path):
    """Rewriting replaces only the water section; other sections and their markers stay byte for byte."""
    bench = load_tool()
    doc = tmp_path / "performance.md"
    other = "<!-- sweeps:begin -->\n## Sweeps\n\nsweep table\n<!-- sweeps:end -->\n"
    doc.write_text(f"# Performance\n\n{bench.SECTION}\n\nold table\n\n{other}")
    bench.write_section(doc, f"{bench.SECTION}\n\nnew table\n")
    block = f"{bench.BEGIN}\n{bench.SECTION}\n\nnew table\n{bench.END}\n"
    assert doc.read_text() == f"# Performance\n\n{block}\n{other}"
    bench.write_section(doc, f"{bench.SECTION}\n\nnewer table\n")
    assert doc.read_text() == f"# Performance\n\n{block.replace('new table', 'newer table')}\n{other}"


def test_section_is_appended_to_other_sections(tmp_path):
    """A file without the water section keeps its content and gets the section at the end."""
    bench = load_tool()
    doc = tmp_path / "performance.md"
    doc.write_text("## Sweeps\n\nsweep table\n")
    bench.write_section(doc, f"{bench.SECTION}\n\nx\n")
    assert doc.read_text() == f"## Sweeps\n\nsweep table\n\n{bench.BEGIN}\n{bench.SECTION}\n\nx\n{bench.END}\n"
    bench.write_section(tmp_path / "new.md", f"{bench.SECTION}\n\nx\n")
    assert (tmp_path / "new.md").read_text() == f"{bench.BEGIN}\n{bench.SECTION}\n\nx\n{bench.END}\n"


def test_paths_benchmark_writes_every_path_beside_the_uniform_step(tmp_path, capsys):
    """A tiny run of the paths benchmark lists every path, its ratio to the uniform step and the
    copy, and writes its own marked section with the reproducing command."""
    path = Path(__file__).resolve().parent.parent / "tools" / "bench_water_paths.py"
    spec = importlib.util.spec_from_file_location("bench_water_paths", path)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    doc = tmp_path / "performance.md"
    assert bench.main(["--sizes", "16", "--rounds", "1", "--min-time", "0.0005", "--write", str(doc)]) == 0
    text = doc.read_text()
    assert text.startswith("<!-- water-paths:begin -->\n## Water paths\n")
    for name in bench.PATHS:
        assert f"| 16 x 16 | {name} |" in text
    assert "| 16 x 16 | copy h and v (`np.copyto`) |" in text
    assert "`python tools/bench_water_paths.py --sizes 16 --rounds 1" in text


def test_paths_benchmark_judges_each_wave_path_against_the_designs_share_of_the_copy(monkeypatch, tmp_path):
    """DESIGN.md section 5 asks every path for at least 50% of the copy's throughput: a path under it
    is named with its share and the target said not met; with every path over it, met."""
    path = Path(__file__).resolve().parent.parent / "tools" / "bench_water_paths.py"
    spec = importlib.util.spec_from_file_location("bench_water_paths", path)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    slow = "sloped bed (a coefficient per face)"

    def measure(n, rounds, min_time):  # the copy 1 s; every path 1.5 s, the sloped bed 2.5 s
        times = {name: [2.5 if name == slow else 1.5] for name in bench.PATHS}
        return times, [1.0]

    monkeypatch.setattr(bench, "measure", measure)
    doc = tmp_path / "performance.md"
    assert bench.main(["--sizes", "16", "--write", str(doc)]) == 0
    text = doc.read_text()
    assert "the paths below it are: sloped bed at 16 x 16 (40%). **Not met**" in text
    assert "shallow water at 16 x 16" not in text  # judged by its own measure

    def fast(n, rounds, min_time):
        return {name: [1.5] for name in bench.PATHS}, [1.0]

    monkeypatch.setattr(bench, "measure", fast)
    assert bench.main(["--sizes", "16", "--write", str(doc)]) == 0
    assert "every wave path meets it." in doc.read_text()


def test_a_grid_too_small_for_its_boundaries_is_refused_before_any_row(capsys):
    """--sizes 2 with absorbing edges (the default boundaries) measured the reflecting rows, then
    ended in a traceback (exit 1) at the first absorbing one: refused in one line, exit 2."""
    bench = load_tool()
    with pytest.raises(SystemExit) as exc:
        bench.main(["--sizes", "2", "--rounds", "1", "--min-time", "0.001"])
    assert exc.value.code == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.splitlines()[-1].endswith(
        "error: --sizes: each at least 3 with the boundaries reflecting and absorbing (got 2)")
