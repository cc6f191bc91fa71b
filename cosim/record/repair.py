"""A recording left cut short, made a valid one: ``cosim repair FILE [-o OUT]``.

A run killed together with its writer process (SIGKILL of both, the machine switched off) leaves its
recording as the writer's private file, ``NAME.<random>.part``, with no footer: every record the
writer had put on disk, the last one perhaps cut off part-way. :func:`repair` copies it beside the
output and closes the copy as a finished recording would be (:func:`cosim.record.seal.seal`: up to
its last whole record, with its indexes and summary), then moves it into place. The recording has
no final status: ``cosim inspect`` says where it ends, and ``cosim replay`` replays it up to there.
The file given is left as it was.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

from cosim.errors import RecordingError
from cosim.record.output import PART_SUFFIX, being_written, check_output, written_whole


@dataclass(frozen=True)
class Repaired:
    """What :func:`repair` wrote: the recording, its messages and the latest time they reach [ns]."""

    path: Path
    messages: int
    end_ns: int


def default_output(cut: Path) -> Path:
    """Where the repaired recording of ``cut`` goes: the recording a private file was meant to become
    (``NAME`` of ``NAME.<random>.part``) when there is none there yet, else ``STEM-repaired.mcap`` (also
    for a private file whose name was shortened, its target's being too long to keep whole)."""
    name = cut.name
    if name.endswith(PART_SUFFIX) and name.count(".") >= 2:
        meant = cut.with_name(name[:-len(PART_SUFFIX)].rsplit(".", 1)[0])
        if meant.suffix != ".mcap":  # a name too long to keep whole (output.sibling_stem): not recoverable
            return meant.with_name(f"{meant.name}-repaired.mcap")
        if not meant.exists():
            return meant
        return meant.with_name(f"{meant.stem}-repaired.mcap")
    return cut.with_name(f"{cut.stem}-repaired.mcap")


def repair(cut: str | Path, output: str | Path | None = None) -> Repaired:
    """Write the valid recording of the cut-short recording ``cut`` to ``output`` (default
    :func:`default_output`). A RecordingError (bad input) when ``cut`` is a whole recording already,
    is being written by a run now, or holds not even its header whole."""
    from cosim.record.reader import Recording
    from cosim.record.seal import seal

    cut = Path(cut)
    if not cut.is_file():
        raise RecordingError(f"{cut}: {'no such file' if not cut.exists() else 'not a file'}")
    if being_written(str(cut)):
        raise RecordingError(f"{cut}: a run is writing it now; it is finished when that run ends")
    try:
        Recording(cut)
    except RecordingError:
        pass  # cut short, as expected
    else:
        raise RecordingError(f"{cut}: is a whole recording already; there is nothing to repair")
    out = check_output(output if output is not None else default_output(cut), inputs=[cut])
    out.parent.mkdir(parents=True, exist_ok=True)
    with written_whole(out) as tmp:
        shutil.copyfile(cut, tmp)
        try:
            sealed = seal(tmp)
        except ValueError as exc:
            raise RecordingError(f"{cut}: nothing in it can be kept ({exc})") from None
    return Repaired(out, sealed.messages, sealed.end_ns)
