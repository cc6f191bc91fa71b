"""A recording cut short where its disk filled up, closed in place as a valid recording.

When the file system refuses the writer's writes (the disk full, a file-size limit), the private
file holds the run's records up to the failure, the last of them cut off part-way. Rebuilding it
elsewhere (:mod:`cosim.record.salvage`) would need as much free space again. :func:`seal` instead
keeps the file where it is: it reads the data section up to the last record that is whole (each
chunk checked against its CRC), cuts the file there, which frees the space the cut-off record took,
writes the last chunk's message index again from its content (it follows the chunk, and may be
what was cut off), and then what a finished MCAP file ends with: a last small chunk holding the
``ending`` message (the run's ``failed`` status), the data-end record with the data section's CRC,
the summary (the schemas, channels, statistics, chunk, attachment and metadata indexes, as a writer
closing the file would write them) and the footer. If even that does not fit, it drops the last
chunks one at a time until it does.

This module reads the MCAP layout itself (the specification's records, built with the ``mcap``
package's record classes), because the writer that wrote the file is gone.

A file damaged on disk (a chunk failing its CRC, a record that cannot be read) is another matter:
:func:`find_damage` reads it past the damage, resuming at the next chunk that is whole and passes its
CRC (a chunk record gives its own length; when that length is what was damaged, the next chunk is
searched for), and says where each damaged stretch lies and what its message index lists. ``cosim
repair`` leaves those stretches out of the copy it seals (:mod:`cosim.record.repair`), and ``cosim
inspect`` names them (:func:`cosim.record.reader.check_integrity`). A chunk after a damaged stretch
may use a channel that was not defined before it (the damaged chunk may have defined it): when the
file's summary is intact (its CRC given and matching), its schema and channel records say what
they were, and the stretch carries them (:attr:`Damage.restores`) to be written in its place;
without one, reading stops at that stretch. A damaged header record is such a stretch too, carrying
a header written anew (:attr:`Damage.mended`). :func:`seal`, closing a file in place, keeps only what
precedes the first damage.
"""

from __future__ import annotations

import mmap
import os
import struct
import zlib
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from io import BytesIO
from pathlib import Path
from typing import Any

from mcap.data_stream import ReadDataStream, RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    AttachmentIndex,
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Message,
    MessageIndex,
    MetadataIndex,
    Schema,
    Statistics,
)
from mcap.stream_reader import CRCValidationError

from cosim.errors import shortened
from cosim.record.output import MCAP_MAGIC
from cosim.record.salvage import chunk_records, message_head

_PREFIX = struct.Struct("<BQ")  # a record's opcode and length
_CHUNK_HEAD = struct.Struct("<QQQII")  # a chunk's start and end times, uncompressed size and CRC, compression length
FOOTER = struct.Struct("<BQQQI")  # opcode, record length, summary start, summary offset start, summary CRC
FOOTER_TAIL = FOOTER.size + len(MCAP_MAGIC)  # a closed MCAP file's last bytes: its footer record, then the magic
_COMPRESSIONS = ("", "zstd", "lz4")
# the records a data section holds (the header before it; the summary's after the data end)
_DATA_OPS = (Opcode.SCHEMA, Opcode.CHANNEL, Opcode.MESSAGE, Opcode.CHUNK, Opcode.MESSAGE_INDEX, Opcode.ATTACHMENT,
             Opcode.METADATA, Opcode.DATA_END)
_FIXED_LENGTH = {Opcode.DATA_END: 4, Opcode.FOOTER: 20}


Ending = Callable[[int], "tuple[int, Any] | None"]
_Definitions = tuple[dict[int, Schema], dict[int, Channel]]  # schemas and channels by id


@dataclass
class _ChunkEntry:
    """A whole chunk of the file: where it is, what it holds, and the file's state after it."""

    index: ChunkIndex
    counts: dict[int, int]  # messages per channel id
    schemas: list[Schema]  # defined in it
    channels: list[Channel]
    chunk_end: int  # offset just past the chunk record
    chunk_crc: int  # CRC-32 of the file up to ``chunk_end``
    end: int  # offset just past it and the message indexes that follow it
    crc: int  # CRC-32 of the file up to ``end``


@dataclass
class Sealed:
    """What a sealed recording holds."""

    messages: int = 0  # messages kept (the ending not counted)
    end_ns: int = 0  # the latest log time among them [ns]
    chunks_dropped: int = 0  # whole chunks given up to make room for the summary
    size: int = 0  # bytes of the sealed file


@dataclass(frozen=True)
class Damage:
    """A damaged stretch of an MCAP file, bytes ``start`` to ``end``: a record that cannot be read
    (``what``: "the chunk at byte N fails its CRC", ...), with whatever follows it up to the next
    chunk read whole. ``resumed``: reading went on at ``end`` (else nothing from ``start`` on is
    kept, ``why_stopped`` saying why, and ``kept_before`` counting the messages of the whole chunks
    before it); ``listed``: the messages its message index lists, and ``first_ns`` .. ``last_ns``
    their log times (None when it has no readable index); ``restores``: records written in its place;
    ``mended``: what was written in place of a record that is not left out (the header)."""

    start: int
    end: int
    what: str
    resumed: bool
    listed: int | None = None
    first_ns: int = 0
    last_ns: int = 0
    why_stopped: str = ""
    kept_before: int = 0
    restores: tuple[Schema | Channel | Header, ...] = ()
    mended: str = ""

    def lost(self) -> str:
        """What leaving it out loses: "the 20 messages its index lists (t = 0.123 .. 0.132 s)"."""
        if not self.listed:
            return "the messages it held"
        times = (f"{self.first_ns / 1e9:g} s" if self.first_ns == self.last_ns
                 else f"{self.first_ns / 1e9:g} .. {self.last_ns / 1e9:g} s")
        return f"the {self.listed} message{'s' if self.listed != 1 else ''} its index lists (t = {times})"

    def __str__(self) -> str:
        if self.mended:
            return f"{self.what}: {self.mended}"
        if self.resumed:
            return f"{self.what}: left out, with {self.lost()}"
        return f"{self.what}: nothing from there on is kept ({self.why_stopped})"


@dataclass
class _Scan:
    """The whole records of a cut-short file, in order."""

    start: int = 0  # offset of the first record after the header
    start_crc: int = 0
    chunks: list[_ChunkEntry] = field(default_factory=list)
    attachments: list[tuple[AttachmentIndex, int, int]] = field(default_factory=list)  # index, end, crc
    metadata: list[tuple[MetadataIndex, int, int]] = field(default_factory=list)
    schemas: list[Schema] = field(default_factory=list)  # outside chunks
    channels: list[Channel] = field(default_factory=list)
    data_complete: bool = False  # the data section's end was reached (only the summary was cut off)
    last_indexes: list[MessageIndex] = field(default_factory=list)  # the last chunk's, from its content
    damage: list[Damage] = field(default_factory=list)  # stretches read past (only when asked to) or stopped at


def _read_chunk(body: bytes) -> tuple[Chunk, dict[int, list[tuple[int, int]]], list[Schema], list[Channel], int, int]:
    """(the chunk, per channel id the (log time [ns], offset) of each of its messages (its message
    index), its schemas, its channels, its earliest and latest log time [ns]) of a chunk record's
    body; raises on anything damaged (its CRC is checked)."""
    chunk = Chunk.read(ReadDataStream(BytesIO(body)))
    messages: dict[int, list[tuple[int, int]]] = {}
    schemas: list[Schema] = []
    channels: list[Channel] = []
    first, last = None, None
    for op, record_at, at, length, data in chunk_records(chunk):
        if op == Opcode.MESSAGE:
            channel, log_time = message_head(data, at)
            messages.setdefault(channel, []).append((log_time, record_at))
            first = log_time if first is None else min(first, log_time)
            last = log_time if last is None else max(last, log_time)
        elif op == Opcode.SCHEMA:
            schemas.append(Schema.read(ReadDataStream(BytesIO(data[at:at + length]))))
        elif op == Opcode.CHANNEL:
            channels.append(Channel.read(ReadDataStream(BytesIO(data[at:at + length]))))
    return chunk, messages, schemas, channels, first or 0, last or 0


def _scan(data: Any, skip: bool = False) -> _Scan:
    """The whole records of the MCAP bytes ``data``, up to the first record cut short or damaged (or
    the data section's end); with ``skip``, read past each damaged stretch to the next whole chunk
    (:class:`Damage`, in ``damage``). A damaged record reading stops at is in ``damage`` too, not
    resumed; a record cut short by the file's end is no damage. Raises ValueError when not even the
    magic and header are whole."""
    size = len(data)
    if size < len(MCAP_MAGIC) or bytes(data[:len(MCAP_MAGIC)]) != MCAP_MAGIC:
        raise ValueError("no MCAP magic at its start")
    if size < len(MCAP_MAGIC) + _PREFIX.size:  # the magic, and the header's record cut short
        raise ValueError("its header is cut short")
    op, length = _PREFIX.unpack_from(data, len(MCAP_MAGIC))
    at = len(MCAP_MAGIC) + _PREFIX.size + length
    if op != Opcode.HEADER or at > size:
        raise ValueError("its header is cut short")
    found = _Scan(start=at, start_crc=zlib.crc32(data[:at]))
    crc = found.start_crc
    if skip and (problem := _header_problem(data, at)) is not None:
        found.damage.append(Damage(len(MCAP_MAGIC), at, f"its header record (byte {len(MCAP_MAGIC)}) is damaged "
                                   f"({problem})", True, restores=(Header(profile="", library=REPAIRED_BY),),
                                   mended=f"written anew, naming {REPAIRED_BY!r} as its writer"))
    while at + _PREFIX.size <= size:
        op, length = _PREFIX.unpack_from(data, at)
        end = at + _PREFIX.size + length
        if end > size:
            if skip and (resume := _next_chunk(data, at + 1)) is not None:  # its length is what was damaged
                found.damage.append(Damage(at, resume, f"the record at byte {at} runs past the file's end (its "
                                                       "length is damaged)", True))
                at = resume
                continue
            break  # cut short: the end of what was written
        problem = _record(found, data, op, at, end, skip)
        if problem is not None:
            if not skip:
                found.damage.append(Damage(at, size, problem, False, why_stopped="a damaged record"))
                break
            damage = _skip(data, op, at, end, problem)
            found.damage.append(damage)
            if not damage.resumed:
                break
            at = damage.end
            continue
        if op in (Opcode.DATA_END, Opcode.FOOTER):
            found.data_complete = True
            break
        crc = zlib.crc32(data[at:end], crc)
        # the file's CRC up to here, kept with the record it follows (a message index: with its chunk)
        if op == Opcode.CHUNK:
            found.chunks[-1].chunk_crc = found.chunks[-1].crc = crc
        elif op == Opcode.MESSAGE_INDEX:
            found.chunks[-1].crc = crc
        elif op == Opcode.ATTACHMENT:
            found.attachments[-1] = (*found.attachments[-1][:2], crc)
        elif op == Opcode.METADATA:
            found.metadata[-1] = (*found.metadata[-1][:2], crc)
        at = end
    if skip:
        _stop_where_channels_are_missing(found, size, _summary_definitions(data))
        if found.damage and not found.damage[-1].resumed:
            before = sum(sum(c.counts.values()) for c in found.chunks
                         if c.index.chunk_start_offset < found.damage[-1].start)
            found.damage[-1] = replace(found.damage[-1], kept_before=before)
    return found


def _record(found: _Scan, data: Any, op: int, at: int, end: int, strict: bool) -> str | None:
    """Read the record ``op`` at ``at`` (ending at ``end``) into ``found``; what is wrong with it when
    it cannot be read (then ``found`` is unchanged). ``strict``: an opcode no data section holds, or a
    data end or footer of another length, is damage too (else it is passed over, or ends the data)."""
    if op in _FIXED_LENGTH:
        if strict and end - at - _PREFIX.size != _FIXED_LENGTH[op]:
            return (f"the {_name(op)} record at byte {at} is {end - at - _PREFIX.size} bytes long, not "
                    f"{_FIXED_LENGTH[op]}")
        return None
    if strict and op not in _DATA_OPS:
        return f"the record at byte {at} has opcode 0x{op:02x}, which no data section holds"
    body = data[at + _PREFIX.size:end]
    try:
        if op == Opcode.CHUNK:
            chunk, messages, schemas, channels, first, last = _read_chunk(body)
            index = ChunkIndex(chunk_length=end - at, chunk_start_offset=at, compression=chunk.compression,
                               compressed_size=len(chunk.data), message_end_time=last,
                               message_index_length=0, message_index_offsets={}, message_start_time=first,
                               uncompressed_size=chunk.uncompressed_size)
            counts = {channel: len(records) for channel, records in messages.items()}
            found.chunks.append(_ChunkEntry(index, counts, schemas, channels, end, 0, end, 0))
            # the last chunk's message index may be cut off behind it: kept to be written anew
            found.last_indexes = [MessageIndex(channel_id=c, records=r) for c, r in sorted(messages.items())]
        elif op == Opcode.MESSAGE_INDEX:
            if not found.chunks or found.chunks[-1].end != at:
                return f"the message index at byte {at} follows no chunk"  # it belongs right after its chunk
            entry = found.chunks[-1]
            channel = MessageIndex.read(ReadDataStream(BytesIO(body))).channel_id
            entry.index.message_index_offsets[channel] = at
            entry.index.message_index_length += end - at
            entry.end = end
        elif op == Opcode.ATTACHMENT:
            stream = ReadDataStream(BytesIO(body))
            log_time, create_time = stream.read8(), stream.read8()
            name, media_type = stream.read_prefixed_string(), stream.read_prefixed_string()
            data_size = stream.read8()
            found.attachments.append((AttachmentIndex(offset=at, length=end - at, log_time=log_time,
                                                      create_time=create_time, data_size=data_size,
                                                      name=name, media_type=media_type), end, 0))
        elif op == Opcode.METADATA:
            name = ReadDataStream(BytesIO(body)).read_prefixed_string()
            found.metadata.append((MetadataIndex(offset=at, length=end - at, name=name), end, 0))
        elif op == Opcode.SCHEMA:
            found.schemas.append(Schema.read(ReadDataStream(BytesIO(body))))
        elif op == Opcode.CHANNEL:
            found.channels.append(Channel.read(ReadDataStream(BytesIO(body))))
    except Exception as exc:  # damaged
        if op == Opcode.CHUNK and isinstance(exc, CRCValidationError):
            return f"the chunk at byte {at} fails its CRC"
        what = "chunk" if op == Opcode.CHUNK else f"{_name(op)} record"
        return f"the {what} at byte {at} cannot be read ({type(exc).__name__}: {_short(exc)})"
    return None


def _skip(data: Any, op: int, at: int, end: int, problem: str) -> Damage:
    """The damaged stretch that begins with the record ``op`` at ``at`` (which should end at ``end``),
    said by ``problem``: a chunk whose own lengths agree with its record's, with the message index
    records that follow it (their count and times kept); otherwise up to the next whole chunk."""
    if op == Opcode.CHUNK and _framed(data, at, end):
        listed, first, last = 0, None, None
        resume = end
        while resume + _PREFIX.size <= len(data):
            next_op, length = _PREFIX.unpack_from(data, resume)
            next_end = resume + _PREFIX.size + length
            if next_op != Opcode.MESSAGE_INDEX or next_end > len(data):
                break
            try:
                times = [t for t, _ in MessageIndex.read(ReadDataStream(BytesIO(data[resume + _PREFIX.size:next_end])))
                         .records]
            except Exception:  # no index of it (reading goes on there, and finds what it is)
                break
            listed += len(times)
            first = min([*times, first] if first is not None else times, default=None)
            last = max([*times, last] if last is not None else times, default=None)
            resume = next_end
        return Damage(at, resume, problem, True, listed if first is not None else None, first or 0, last or 0)
    resume = _next_chunk(data, at + 1)
    if resume is None:
        return Damage(at, len(data), problem, False, why_stopped="no whole chunk follows it")
    return Damage(at, resume, problem, True)


def _framed(data: Any, at: int, end: int) -> bool:
    """Whether the chunk record at ``at`` ends at ``end`` by its own lengths too (its compression's
    name and its records' length add up to the record's), a known compression: its length whole."""
    head = at + _PREFIX.size
    if head + _CHUNK_HEAD.size > len(data):
        return False
    compression_length = _CHUNK_HEAD.unpack_from(data, head)[4]
    records_at = head + _CHUNK_HEAD.size + compression_length
    if compression_length > 8 or records_at + 8 > len(data):
        return False
    try:
        compression = bytes(data[head + _CHUNK_HEAD.size:records_at]).decode()
    except UnicodeDecodeError:
        return False
    (records_length,) = struct.unpack_from("<Q", data, records_at)
    return compression in _COMPRESSIONS and records_at + 8 + records_length == end


RESYNC_BUDGET = 4  # candidate chunks read back while resynchronising, at most this many times the file's bytes


def _next_chunk(data: Any, start: int) -> int | None:
    """The offset of the first chunk record at or after ``start`` that is whole, framed by its own
    lengths, and read back passing its CRC; None if there is none, or none found within
    :data:`RESYNC_BUDGET` times the file's bytes read back (a crafted file of nested candidates, each
    running to its end, made the search quadratic: 54 s for 4 MB). A candidate must carry a CRC (the
    format lets a chunk leave it 0, unchecked, which junk bytes could pass as)."""
    at = start
    budget = RESYNC_BUDGET * len(data)
    while (at := data.find(bytes([Opcode.CHUNK]), at)) >= 0:
        if at + _PREFIX.size <= len(data):
            length = _PREFIX.unpack_from(data, at)[1]
            end = at + _PREFIX.size + length
            if end <= len(data) and _framed(data, at, end) and _has_crc(data, at):
                budget -= end - at
                if budget < 0:
                    return None
                try:
                    _read_chunk(data[at + _PREFIX.size:end])
                except Exception:  # not a chunk after all: searched on
                    pass
                else:
                    return at
        at += 1
    return None


def _has_crc(data: Any, at: int) -> bool:
    """Whether the chunk record at ``at`` carries a CRC of its records (not 0, "unchecked")."""
    return _CHUNK_HEAD.unpack_from(data, at + _PREFIX.size)[3] != 0


REPAIRED_BY = "cosim repair"  # the library a header written anew names (its own was damaged)


def _header_problem(data: Any, end: int) -> str | None:
    """What is wrong with the header record ending at ``end`` (its two strings, profile and library,
    must fill it and be UTF-8 text; the header has no CRC of its own), or None."""
    at = len(MCAP_MAGIC) + _PREFIX.size
    for name in ("profile", "library"):
        if at + 4 > end:
            return f"its {name} is cut off"
        (length,) = struct.unpack_from("<I", data, at)
        if at + 4 + length > end:
            return f"its {name}'s length runs past the record"
        try:
            bytes(data[at + 4:at + 4 + length]).decode("utf-8")
        except UnicodeDecodeError:
            return f"its {name} is not UTF-8 text"
        at += 4 + length
    return None if at == end else "it holds more than its profile and library"


def _stop_where_channels_are_missing(found: _Scan, size: int, summary: _Definitions) -> None:
    """A chunk after a damaged stretch whose messages use a channel not defined before it (or one
    whose schema is not): the damaged chunk may have defined it. When the file's intact ``summary``
    defines it (and its schema), the last stretch before the chunk restores those records
    (:attr:`Damage.restores`); otherwise reading stops at that stretch instead (``found`` then holds
    the chunks before it, for what is said of it; a scan that skips is not sealed)."""
    known = {c.id for c in found.channels}
    schemas = {s.id for s in found.schemas} | {0}
    for entry in found.chunks:
        schemas |= {s.id for s in entry.schemas}
        known |= {c.id for c in entry.channels if c.schema_id in schemas}
        at = entry.index.chunk_start_offset
        before = [d for d in found.damage if d.start < at and not d.mended]
        missing = sorted(channel for channel in entry.counts if channel not in known)
        if not before or not missing:
            continue  # (a channel missing before any damage is the file's own: the reader says what it makes of it)
        stretch = before[-1]
        restored = _restored(missing, schemas, summary)
        if restored is not None:
            found.damage[found.damage.index(stretch)] = replace(stretch, restores=stretch.restores + restored)
            schemas |= {r.id for r in restored if isinstance(r, Schema)}
            known |= set(missing)
            continue
        why = f"the chunk at byte {at} after it uses a channel not defined before it, which it may have defined"
        found.damage[found.damage.index(stretch):] = [replace(stretch, end=size, resumed=False, why_stopped=why)]
        found.chunks = [c for c in found.chunks if c.index.chunk_start_offset < stretch.start]
        found.data_complete = False
        return


def _restored(channels: list[int], schemas: set[int], summary: _Definitions) -> tuple[Schema | Channel, ...] | None:
    """The records defining the channels of ids ``channels`` (and their schemas not among the ids
    ``schemas``, defined already), as the file's ``summary`` gives them; None when it lacks one."""
    summary_schemas, summary_channels = summary
    if not all(c in summary_channels for c in channels):
        return None
    wanted = [summary_channels[c] for c in channels]
    needed = sorted({c.schema_id for c in wanted} - schemas)
    if not all(s in summary_schemas for s in needed):
        return None
    return (*(summary_schemas[s] for s in needed), *wanted)


def footer_fields(tail: bytes) -> tuple[int, int, int] | None:
    """(summary start, summary offset start, summary CRC) from ``tail``, the last :data:`FOOTER_TAIL`
    bytes of an MCAP file, when they are a footer record and then the magic, as a closed file ends;
    None when they are not."""
    if len(tail) != FOOTER_TAIL or tail[FOOTER.size:] != MCAP_MAGIC:
        return None
    op, length, summary_start, summary_offsets, summary_crc = FOOTER.unpack(tail[:FOOTER.size])
    if op != Opcode.FOOTER or length != _FIXED_LENGTH[Opcode.FOOTER]:
        return None
    return summary_start, summary_offsets, summary_crc


def _summary_definitions(data: Any) -> _Definitions:
    """The schemas and channels the summary of the MCAP bytes ``data`` defines, when the file ends in
    a footer whose summary CRC is given and matches (the summary is as its writer wrote it, whatever
    happened to the data before it); none when it does not, or a record of it cannot be read."""
    none: _Definitions = ({}, {})
    footer_at = len(data) - FOOTER_TAIL
    footer = footer_fields(bytes(data[footer_at:])) if footer_at >= len(MCAP_MAGIC) else None
    if footer is None:
        return none
    summary_start, _, summary_crc = footer
    if not len(MCAP_MAGIC) < summary_start <= footer_at:
        return none
    if not summary_crc or zlib.crc32(data[summary_start:footer_at + FOOTER.size - 4]) != summary_crc:
        return none  # (a summary without a CRC cannot be told intact)
    schemas: dict[int, Schema] = {}
    channels: dict[int, Channel] = {}
    at = summary_start
    try:
        while at < footer_at:
            op, length = _PREFIX.unpack_from(data, at)
            end = at + _PREFIX.size + length
            if end > footer_at:
                return none
            stream = ReadDataStream(BytesIO(data[at + _PREFIX.size:end]))
            if op == Opcode.SCHEMA:
                schema = Schema.read(stream)
                schemas[schema.id] = schema
            elif op == Opcode.CHANNEL:
                channel = Channel.read(stream)
                channels[channel.id] = channel
            at = end
    except Exception:  # a record that cannot be read, though its CRC matched: no definition is taken from it
        return none
    return schemas, channels


def find_damage(path: str | Path) -> list[Damage]:
    """The damaged stretches of the MCAP file ``path``, read past each to the next whole chunk (the
    last not resumed when reading stops there); empty when what it holds is whole, up to a cut at its
    end. Raises ValueError when not even its magic and header are whole, OSError when it cannot be read."""
    return find_damage_and_names(path)[0]


def find_damage_and_names(path: str | Path) -> tuple[list[Damage], set[str], set[str]]:
    """(:func:`find_damage`'s stretches, the names of the metadata records and of the attachments read
    whole around them): whether what a repair keeps still holds what makes the file a recording of
    its kind (a cosim recording's metadata and scene)."""
    with open(path, "rb") as f:
        if os.fstat(f.fileno()).st_size == 0:
            raise ValueError("the file is empty")
        with mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as data:
            found = _scan(data, skip=True)
            return (found.damage, {index.name for index, _, _ in found.metadata},
                    {index.name for index, _, _ in found.attachments})


def _name(op: int) -> str:
    """An opcode's record name as the specification gives it ("message index")."""
    try:
        return Opcode(op).name.lower().replace("_", " ")
    except ValueError:
        return f"0x{op:02x}"


def _short(exc: BaseException) -> str:
    """An exception's message on one line, at most 100 characters."""
    return shortened(str(exc), 100)


def _cut(scan: _Scan, chunks: int) -> tuple[int, int, bool]:
    """(offset, CRC of the file up to it, whether the last chunk's message index is to be written
    anew) just past the last whole record kept when only the first ``chunks`` chunks are
    (attachments and metadata after the last kept chunk stay when they come before the first dropped
    one). A chunk's message index follows it; when the file ends there, its last records may be cut
    off, so the last chunk scanned is cut behind the chunk itself and its index written again from
    its content (readers find a chunk's messages through it)."""
    limit = scan.chunks[chunks].index.chunk_start_offset if chunks < len(scan.chunks) else None
    best = (scan.start, scan.start_crc)
    ends = [(c.end, c.crc) for c in scan.chunks[:chunks]]
    ends += [(end, crc) for _, end, crc in scan.attachments + scan.metadata]
    for end, crc in ends:
        if (limit is None or end <= limit) and end > best[0]:
            best = (end, crc)
    last = scan.chunks[-1] if scan.chunks and chunks == len(scan.chunks) else None
    if last is not None and best[0] == last.end:
        return last.chunk_end, last.chunk_crc, True
    return best[0], best[1], False


def _tail(scan: _Scan, chunks: int, start: int, crc: int, reindex: bool, ending: Ending | None
          ) -> tuple[bytes, Sealed]:
    """The bytes a file cut at ``start`` (keeping its first ``chunks`` chunks; ``crc``: the CRC-32 of
    the file up to there) ends with: the last chunk's message index when ``reindex``, the ending's
    chunk, the data end, the summary and the footer; and what the file then holds."""
    kept = scan.chunks[:chunks]
    schemas = {s.id: s for s in scan.schemas}
    channels = {c.id: c for c in scan.channels}
    counts: dict[int, int] = {}
    for entry in kept:
        schemas.update((s.id, s) for s in entry.schemas)
        channels.update((c.id, c) for c in entry.channels)
        for channel, n in entry.counts.items():
            counts[channel] = counts.get(channel, 0) + n
    with_messages = [e.index for e in kept if e.counts]
    sealed = Sealed(messages=sum(counts.values()),
                    end_ns=max((i.message_end_time for i in with_messages), default=0))
    indexes = [e.index for e in kept]
    out = RecordBuilder()
    if reindex:
        offsets = {}
        for record in scan.last_indexes:
            offsets[record.channel_id] = start + out.count
            record.write(out)
        indexes[-1] = replace(indexes[-1], message_index_offsets=offsets, message_index_length=out.count)
    whole = scan.data_complete and chunks == len(scan.chunks)  # the run's own ending is there
    last = ending(sealed.end_ns) if ending is not None and not whole else None
    if last is not None:
        index, channel_id = _ending_chunk(out, start, last, schemas, channels, counts)
        indexes.append(index)
        with_messages.append(index)
        counts[channel_id] = counts.get(channel_id, 0) + 1
    data_end_at = out.count
    DataEnd(data_section_crc=0).write(out)
    summary_at = out.count
    for schema in sorted(schemas.values(), key=lambda s: s.id):
        schema.write(out)
    for channel in sorted(channels.values(), key=lambda c: c.id):
        channel.write(out)
    attachments = [a for a, end, _ in scan.attachments if end <= start]
    metadata = [m for m, end, _ in scan.metadata if end <= start]
    Statistics(attachment_count=len(attachments), channel_count=len(channels), channel_message_counts=counts,
               chunk_count=len(indexes), message_count=sum(counts.values()),
               message_end_time=max((i.message_end_time for i in with_messages), default=0),
               message_start_time=min((i.message_start_time for i in with_messages), default=0),
               metadata_count=len(metadata), schema_count=len(schemas)).write(out)
    for record in (*indexes, *attachments, *metadata):
        record.write(out)
    Footer(summary_start=start + summary_at, summary_offset_start=0, summary_crc=0).write(out)
    tail = bytearray(out.end())
    # the data end's CRC covers the whole data section; the summary's, the summary up to the footer's
    # own CRC field
    struct.pack_into("<I", tail, data_end_at + _PREFIX.size, zlib.crc32(tail[:data_end_at], crc))
    struct.pack_into("<I", tail, len(tail) - 4, zlib.crc32(tail[summary_at:len(tail) - 4]))
    tail += MCAP_MAGIC
    sealed.size = start + len(tail)
    return bytes(tail), sealed


def _ending_chunk(out: RecordBuilder, start: int, ending: tuple[int, Any], schemas: dict[int, Schema],
                  channels: dict[int, Channel], counts: dict[int, int]) -> tuple[ChunkIndex, int]:
    """Write into ``out`` (which begins at file offset ``start``) an uncompressed chunk holding the
    ending message (with its schema and channel when the file has none for its topic) and its message
    index; (the chunk's index, the message's channel id)."""
    time_ns, msg = ending
    inner = RecordBuilder()
    channel = next((c for c in channels.values() if c.topic == msg.topic), None)
    if channel is None:
        schema = next((s for s in schemas.values() if s.name == msg.schema_name
                       and s.encoding == msg.schema_encoding and s.data == msg.schema_data), None)
        if schema is None:
            schema = Schema(id=max(schemas, default=0) + 1, data=msg.schema_data, encoding=msg.schema_encoding,
                            name=msg.schema_name)
            schemas[schema.id] = schema
            schema.write(inner)
        channel = Channel(id=max(channels, default=0) + 1, topic=msg.topic, message_encoding=msg.message_encoding,
                          metadata={}, schema_id=schema.id)
        channels[channel.id] = channel
        channel.write(inner)
    message_at = inner.count
    Message(channel_id=channel.id, log_time=time_ns, data=msg.data, publish_time=time_ns,
            sequence=counts.get(channel.id, 0) + 1).write(inner)
    records = inner.end()
    chunk_at = out.count
    Chunk(compression="", data=records, message_end_time=time_ns, message_start_time=time_ns,
          uncompressed_crc=zlib.crc32(records), uncompressed_size=len(records)).write(out)
    index_at = out.count
    MessageIndex(channel_id=channel.id, records=[(time_ns, message_at)]).write(out)
    index = ChunkIndex(chunk_length=index_at - chunk_at, chunk_start_offset=start + chunk_at, compression="",
                       compressed_size=len(records), message_end_time=time_ns,
                       message_index_length=out.count - index_at,
                       message_index_offsets={channel.id: start + index_at}, message_start_time=time_ns,
                       uncompressed_size=len(records))
    return index, channel.id


def seal(path: str | Path, ending: Ending | None = None) -> Sealed:
    """Close the cut-short MCAP file ``path`` in place as a valid recording of its whole records.

    ``ending(end_ns)``, given the latest log time kept [ns], gives the message the recording ends
    with, as (log time [ns], message with ``topic``, ``schema_name``, ``schema_encoding``,
    ``schema_data``, ``message_encoding`` and ``data``: a recorder's DerivedMessage), or None; it is
    not asked when the file's data section was whole (only its summary was cut off).

    When the end does not fit (the disk still full), the last chunk is dropped and the end written
    again, until it fits. Raises ValueError when the file has not even its header whole, OSError
    when nothing can be written at all."""
    fd = os.open(path, os.O_RDWR)
    try:
        size = os.fstat(fd).st_size
        if size == 0:
            raise ValueError("the file is empty")
        with mmap.mmap(fd, 0, access=mmap.ACCESS_READ) as data:
            scan = _scan(data)
        chunks = len(scan.chunks)
        while True:
            start, crc, reindex = _cut(scan, chunks)
            tail, sealed = _tail(scan, chunks, start, crc, reindex, ending)
            os.ftruncate(fd, start)  # frees what the cut-off record took
            try:
                _write_all(fd, tail, start)
                os.fsync(fd)
            except OSError:
                if chunks == 0:
                    os.ftruncate(fd, start)
                    raise
                chunks -= 1
                continue
            sealed.chunks_dropped = len(scan.chunks) - chunks
            return sealed
    finally:
        os.close(fd)


def _write_all(fd: int, data: bytes, offset: int) -> None:
    view = memoryview(data)
    while view:
        n = os.pwrite(fd, view, offset)
        view, offset = view[n:], offset + n
