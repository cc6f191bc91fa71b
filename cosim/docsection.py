"""Replace one generated section of a markdown file, between ``<!-- NAME:begin -->`` and
``<!-- NAME:end -->`` markers (appended, with the markers, when they are not there yet; the rest of
the file is kept). Benchmarks and studies write their tables into the docs this way."""

from __future__ import annotations

from pathlib import Path


def replace_section(path: str | Path, name: str, body: str) -> None:
    """Put ``body`` between the markers of section ``name`` in the markdown file ``path``."""
    path = Path(path)
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    block = f"{begin}\n{body.rstrip()}\n{end}"
    text = path.read_text(encoding="utf-8") if path.exists() else ""
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        _, tail = rest.split(end, 1)
        text = head + block + tail
    else:
        text = (text.rstrip() + "\n\n" if text.strip() else "") + block + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
