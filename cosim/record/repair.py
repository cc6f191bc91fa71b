"""A recording left cut short, made a valid one: ``cosim repair FILE [-o OUT]``.

A run killed together with its writer process (SIGKILL of both, the machine switched off) leaves its
recording as the writer's private file, ``NAME.<random>.part``, with no footer: every record the
writer had put on disk, the last one perhaps cut off part-way. :func:`repair` copies it beside the
output and closes the copy as a finished recording would be (:func:`cosim.record.seal.seal`: up to
its last whole record, with its indexes and summary), checks that the copy reads as a cosim
recording, then moves it into place. A recording cut off before its end has no final status:
``cosim inspect`` says where it ends, and ``cosim replay`` replays it up to there; one cut off only
in its summary keeps the status the run wrote. The file given is left as it was.

A file damaged on disk as well (a chunk that fails its CRC, found by
:func:`cosim.record.seal.find_damage`) is copied without the damaged stretch, so that the chunks
after it are kept (before, reading stopped there, and the file was called cut short at the damage);
each stretch left out is said in a warning naming where it lies and what its index listed, and is
in :attr:`Repaired.damage`. When a chunk after it uses a channel the damaged chunk may have defined,
the file's summary, when it is intact, says what that channel and its schema were: their records
are written in the stretch's place, and the chunks after it kept (a closed recording damaged early
on kept only what preceded the damage, though its summary defined every channel). Without an intact
summary (a killed run's private file) the copy ends where the damage begins, and the warning says so.
A header record whose text is damaged (it carries no CRC: its profile and library not UTF-8 text)
is written anew, naming ``cosim repair`` as the file's writer, and said in a warning: the records
after it are whole (the reader had refused the file, and the repair's copy, over the header alone).

Refused (a RecordingError, bad input), with nothing written: a whole recording (nothing to repair),
a whole MCAP file that is not a cosim recording, a file that is no MCAP file at all (it does not
start with the MCAP magic: a text, random bytes; it was called cut short at its size), a file a run
is still writing, and a file whose whole records make no readable cosim recording or hold no
message (cut off before its first, or damaged there).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from cosim.errors import RecordingError
from cosim.record.output import (
    MCAP_MAGIC,
    PART_SUFFIX,
    being_written,
    beside,
    check_output,
    copy_file,
    output_folder,
    sibling_stem,
    written_whole,
)

if TYPE_CHECKING:
    from mcap.records import Channel, Header, Schema

    from cosim.record.recorder import RunStatus
    from cosim.record.seal import Damage


@dataclass(frozen=True)
class Repaired:
    """What :func:`repair` wrote, as read back from it: the recording, its messages, the latest time
    they reach [ns] and the run's final status (None when the run's end was cut off); ``cut_short``:
    the file given ended before its footer (else it was whole but damaged); ``damage``: the damaged
    stretches of the file given, left out of the copy (each also said in a warning)."""

    path: Path
    messages: int
    end_ns: int
    status: RunStatus | None
    cut_short: bool
    damage: tuple[Damage, ...] = ()


REPAIRED = "-repaired.mcap"  # the ending of a repaired recording's default name


def default_output(cut: Path) -> Path:
    """Where the repaired recording of ``cut`` goes: the recording a private file was meant to become
    (``NAME`` of ``NAME.<random>.part``) when there is none there yet, else ``STEM-repaired.mcap`` (also
    for a private file whose name was shortened, its target's being too long to keep whole)."""
    name = cut.name
    if name.endswith(PART_SUFFIX) and name.count(".") >= 2:
        meant = cut.with_name(name[:-len(PART_SUFFIX)].rsplit(".", 1)[0])
        if meant.suffix != ".mcap":  # a name too long to keep whole (output.sibling_stem): not recoverable
            return meant.with_name(sibling_stem(meant.name, len(REPAIRED)) + REPAIRED)
        if not meant.exists():
            return meant
        return beside(meant, REPAIRED)
    return beside(cut, REPAIRED)


def _reason(exc: RecordingError, path: Path) -> str:
    """The reader's error about ``path`` without the path it starts with (the file it read may be
    the repair's temporary; the line names the file given instead)."""
    text, prefix = str(exc), f"{path}: "
    return text[len(prefix):] if text.startswith(prefix) else text


def repair(cut: str | Path, output: str | Path | None = None) -> Repaired:
    """Write the valid recording of the cut-short (or damaged) recording ``cut`` to ``output``
    (default :func:`default_output`) and say what it holds, read back from it. A RecordingError (bad
    input), with nothing written, when ``cut`` is a whole recording already, is being written by a run
    now, is a whole MCAP file but no cosim recording, or its whole records make no readable cosim
    recording or hold no message."""
    from cosim.record.reader import Recording, ends_in_footer
    from cosim.record.seal import find_damage, seal

    cut = Path(cut)
    if not cut.is_file():
        raise RecordingError(f"{cut}: {'no such file' if not cut.exists() else 'not a file'}")
    if being_written(str(cut)):
        raise RecordingError(f"{cut}: a run is writing it now; it is finished when that run ends")
    try:
        Recording(cut)
    except RecordingError as exc:
        problem = _reason(exc, cut)
    else:
        raise RecordingError(f"{cut}: is a whole recording already (it was closed, and its checks pass); there "
                             "is nothing to repair")
    try:
        start = _start(cut)
    except OSError:  # what the reader said of it (permission denied) is all there is to say
        raise RecordingError(f"{cut}: {problem}") from None
    if start != MCAP_MAGIC[:len(start)]:  # (a file cut short within its magic still starts as one)
        raise RecordingError(f"{cut}: not an MCAP file (no MCAP magic at its start), so not a recording cosim repair "
                             "can mend")
    cut_short = not ends_in_footer(cut)
    if not cut_short:
        from cosim.record.reader import check_integrity

        try:
            check_integrity(cut)
        except RecordingError:
            pass  # damaged: its records are read up to the damage
        else:  # every record whole and as written: what the reader refuses, sealing it again cannot mend
            raise RecordingError(f"{cut}: {problem}; its MCAP records are whole (it was not cut short or "
                                 "damaged), so there is nothing to repair")
    was = f"cut short at {cut.stat().st_size} bytes" if cut_short else f"damaged ({problem})"
    try:
        damage = find_damage(cut)
    except ValueError:  # not even its header whole: said below, as the copy is sealed
        damage = []
    out = check_output(output if output is not None else default_output(cut), inputs=[cut])
    with output_folder(out.parent), written_whole(out) as tmp:  # no folder left if refused or failing
        _copy_leaving_out(cut, tmp, damage)
        try:
            sealed = seal(tmp)
        except ValueError as exc:
            raise RecordingError(f"{cut}: {was}; nothing in it can be kept ({exc})") from None
        if sealed.messages == 0:  # its metadata too, perhaps: said before what the reader makes of that
            if damage:
                raise RecordingError(f"{cut}: {was}, and {damage[0].what}, before its first whole message: "
                                     "nothing in it can be kept")
            raise RecordingError(f"{cut}: {was}, before its first whole message: nothing in it can be kept")
        try:
            rec = Recording(tmp)
            status = rec.status()
        except RecordingError as exc:
            also = f" ({damage_text(damage)})" if damage else ""
            raise RecordingError(f"{cut}: {was}, and what it holds whole is {_reason(exc, tmp)}: it cannot "
                                 f"be made a cosim recording{also}") from None
        messages = sum(channel.count for channel in rec.channels.values())
    with warnings.catch_warnings():  # said whatever the filters: the line written after it would mislead without it
        warnings.simplefilter("always")  # (an "error" filter would end the command after the recording is in place)
        for stretch in damage:
            warnings.warn(f"{cut}: {stretch}", UserWarning, stacklevel=2)
    return Repaired(out, messages, rec.end_ns, status, cut_short, tuple(damage))


def _start(path: Path) -> bytes:
    """The first bytes of the file ``path``, as many as an MCAP file's magic has (fewer in a shorter file)."""
    with open(path, "rb") as f:
        return f.read(len(MCAP_MAGIC))


def damage_text(damage: list[Damage], most: int = 3) -> str:
    """The damaged stretches ``damage`` in one line, the first ``most`` of them in full."""
    text = "; ".join(str(d) for d in damage[:most])
    return text + (f"; and {len(damage) - most} more damaged stretches" if len(damage) > most else "")


def _copy_leaving_out(source: Path, target: Path, damage: list[Damage]) -> None:
    """Copy ``source`` to ``target`` without its damaged stretches: each one read past is left out,
    the schema and channel records it may have held that the file's summary restores
    (:attr:`Damage.restores`) written in its place (the chunks after it use them), and the copy ends
    where one that reading stopped at begins."""
    pieces: list[tuple[int, int | None, bytes]] = []  # a span of ``source`` (end None: to its end), then bytes
    at = 0
    for stretch in damage:
        if not stretch.resumed:
            pieces.append((at, stretch.start, b""))
            break
        pieces.append((at, stretch.start, _records(stretch.restores)))
        at = stretch.end
    else:
        pieces.append((at, None, b""))
    copy_file(source, target, pieces)


def _records(records: tuple[Schema | Channel | Header, ...]) -> bytes:
    """The MCAP records ``records`` as a data section holds them."""
    from mcap.data_stream import RecordBuilder

    out = RecordBuilder()
    for record in records:
        record.write(out)
    return out.end()
