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
    Message,
    MessageIndex,
    MetadataIndex,
    Schema,
    Statistics,
)

from cosim.record.output import MCAP_MAGIC
from cosim.record.salvage import chunk_records, message_head

_PREFIX = struct.Struct("<BQ")  # a record's opcode and length


Ending = Callable[[int], "tuple[int, Any] | None"]


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


def _scan(data: Any) -> _Scan:
    """The whole records of the MCAP bytes ``data``, up to the first record cut short or damaged (or
    the data section's end); raises ValueError when not even the magic and header are whole."""
    size = len(data)
    if size < len(MCAP_MAGIC) + _PREFIX.size or bytes(data[:len(MCAP_MAGIC)]) != MCAP_MAGIC:
        raise ValueError("no MCAP magic at its start")
    op, length = _PREFIX.unpack_from(data, len(MCAP_MAGIC))
    at = len(MCAP_MAGIC) + _PREFIX.size + length
    if op != Opcode.HEADER or at > size:
        raise ValueError("its header is cut short")
    found = _Scan(start=at, start_crc=zlib.crc32(data[:at]))
    crc = found.start_crc
    while at + _PREFIX.size <= size:
        op, length = _PREFIX.unpack_from(data, at)
        end = at + _PREFIX.size + length
        if end > size:
            break
        if op in (Opcode.DATA_END, Opcode.FOOTER):
            found.data_complete = True
            break
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
                    break  # a message index belongs right after its chunk
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
        except Exception:  # damaged: the end of what was written whole
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
    return found


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
