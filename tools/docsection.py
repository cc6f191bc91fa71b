"""Replace one generated section of a markdown file, between ``<!-- NAME:begin -->`` and
``<!-- NAME:end -->`` markers (appended at the end when the markers are not there yet)."""

from __future__ import annotations

from pathlib import Path


def replace_section(path: str | Path, name: str, body: str) -> None:
    path = Path(path)
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    block = f"{begin}\n{body.rstrip()}\n{end}"
    text = path.read_text() if path.exists() else ""
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        _, tail = rest.split(end, 1)
        text = head + block + tail
    else:
        text = (text.rstrip() + "\n\n" if text.strip() else "") + block + "\n"
    path.write_text(text)
