"""tools/reference_throws.py: the reference skip beside the same throw held and with a thin slate
(docs/validation.md, section 2), drawn from the runs it reports."""

from __future__ import annotations

from tools import reference_throws


def test_the_tool_draws_the_three_throws_and_the_thin_slate_skips_least(tmp_path, capsys):
    png = tmp_path / "throws.png"
    assert reference_throws.main(["--figure", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| ") and "---" not in line][1:]
    assert [row.split(" | ")[0].lstrip("| ") for row in rows] == [label for label, _ in reference_throws.THROWS]
    skips = [int(row.split(" | ")[1]) for row in rows]
    free, held, thin = skips
    assert free >= 3 and held >= free and thin < free
    assert "sink" in rows[0] and "sink" in rows[2]
