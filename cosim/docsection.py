"""Replace one generated section of a markdown file, between ``<!-- NAME:begin -->`` and
``<!-- NAME:end -->`` markers (appended, with the markers, when they are not there yet; the rest of
the file is kept). Benchmarks and studies write their tables into the docs this way."""

from __future__ import annotations

import os
import secrets
import stat
from pathlib import Path


def section_problem(text: str, name: str) -> str | None:
    """Why the section ``name`` of a page's ``text`` cannot be replaced, or None: its end marker
    before its begin marker, one of the two without the other, or either twice. (A begin marker
    alone had a whole section added after it, and the next write replaced the page's own text from
    that marker to the added section's end.)"""
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    begins, ends = text.count(begin), text.count(end)
    if begins > 1 or ends > 1:
        twice = begin if begins > 1 else end
        return f"its '{twice}' is there {max(begins, ends)} times; keep one section (one begin, one end)"
    if begins != ends:
        there, missing = (begin, end) if begins else (end, begin)
        return (f"it has a '{there}' but no '{missing}'; add the missing marker around the section "
                f"(or remove the one there)")
    if begins and end not in text.split(begin, 1)[1]:
        return f"its '{end}' comes before its '{begin}'; put the section's end after its begin (or remove both)"
    return None


def replace_section(path: str | Path, name: str, body: str) -> None:
    """Put ``body`` between the markers of section ``name`` in the markdown file ``path``.

    The page is written whole, to a temporary name beside it moved onto it once complete: a write
    that fails (a full disk) leaves it as it was, never cut short, and is an OSError naming it; a page
    that is not UTF-8 text is a ValueError naming it, before anything is written."""
    path = Path(path)
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    block = f"{begin}\n{body.rstrip()}\n{end}"
    try:
        text = path.read_text(encoding="utf-8") if path.exists() else ""
    except UnicodeDecodeError as exc:
        raise ValueError(f"{path}: not UTF-8 text (byte {exc.start}); its '{name}' section is not written") from None
    misplaced = section_problem(text, name)
    if misplaced:
        raise ValueError(f"{path}: {misplaced}")
    if begin in text and end in text:
        head, rest = text.split(begin, 1)
        _, tail = rest.split(end, 1)
        text = head + block + tail
    else:
        text = (text.rstrip() + "\n\n" if text.strip() else "") + block + "\n"
    try:
        mode = stat.S_IMODE(os.stat(path).st_mode)
    except FileNotFoundError:
        mode = None
    if mode is not None and not mode & (stat.S_IWUSR | stat.S_IWGRP | stat.S_IWOTH):
        # made read-only: not replaced, whoever runs the tool (root's writes ignore the bits)
        raise PermissionError(13, "is read-only; its section is not written", str(path))
    path.parent.mkdir(parents=True, exist_ok=True)
    # (as cosim.record.output.written_whole does, which this contract-layer module may not import): a
    # new file of a unique name, never one that was there (a fixed PAGE.tmp was overwritten, then removed)
    # (made as any new file is, 0666 less the umask: mkstemp's 0600 would have become the page's)
    tmp = path.with_name(f"{path.name}.{secrets.token_hex(4)}.tmp")
    made = False
    try:
        os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o666))
        made = True
        tmp.write_text(text, encoding="utf-8")
        if mode is not None:  # the page keeps its mode (a page of 0600 became 0644)
            os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException as exc:
        if made:  # (never a file of that name that was there)
            tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise OSError(exc.errno, exc.strerror or str(exc), str(path)) from None
        raise
