"""A recording whose writer process died part-way, rebuilt from what is left of it.

The writer process (:mod:`cosim.record.writer`) can die while the run goes on (killed, out of
memory, a crash). Everything the run recorded up to then is still to be had, from three places:

- the private file the writer was writing: an MCAP file cut short, whose complete chunks (each
  checked against its CRC; reading stops at the first record cut short or damaged, such as the
  chunk being written, whose length is not filled in yet) hold the first messages of the record
  stream, in order (:func:`complete_messages`);
- the ring (:mod:`cosim.record.ring`): the batches sent that it still holds whole, numbered, and the
  writer's tally of the messages it had written before each batch it took; so the batch holding the
  first message missing from the file is known, and everything from there on is taken from the
  ring (:func:`ring_messages`), also what the writer had taken but not yet put on disk (its chunk
  in memory) and the batches it never took;
- the sink's own copy of the records that are not messages (schemas, channels, metadata such as
  ``cosim``, attachments such as ``scene.yaml``).

:func:`rebuild` writes them, in that order, to a fresh file. If the ring no longer reaches back to
the file's end (a record larger than the ring went through it), the recording holds the file's
messages only: :attr:`Salvaged.complete` says which.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import Any, Protocol

from mcap.data_stream import ReadDataStream
from mcap.records import Channel, Chunk, Message
from mcap.stream_reader import StreamReader, get_chunk_data_stream

from cosim.codec.records import BYTES, MESSAGE, OTHER, iter_records, read_other
from cosim.codec.state_proto import state_bytes

# a record inside a chunk: opcode, length; a message record's fixed part: channel id, sequence,
# log time, publish time (the MCAP specification). Read here rather than with mcap's breakup_chunk,
# which makes an object of every message: three times slower on a long recording.
_RECORD = struct.Struct("<BQ")
_MESSAGE_HEAD = struct.Struct("<HIQQ")
_OP_CHANNEL, _OP_MESSAGE = 0x04, 0x05
# the target is asked whether its writes still succeed every this many messages (its MCAP writer
# does not raise when a write fails, and a copy onto a full disk would go on to the last message)
CHECK_EVERY = 4096


def chunk_records(chunk: Chunk) -> Iterator[tuple[int, int, int, int, bytes]]:
    """(opcode, offset of the record, offset of its body, length of its body, the chunk's records)
    of every record in a chunk, in order, its records decompressed once. Raises whatever a damaged
    chunk makes the reader raise (its CRC is checked), or ValueError for a record running past the
    chunk's end."""
    stream, size = get_chunk_data_stream(chunk, validate_crc=True)
    data = stream.read(size)
    at = 0
    while at < size:
        op, length = _RECORD.unpack_from(data, at)
        body = at + _RECORD.size
        if body + length > size:
            raise ValueError("a chunk's record runs past its end")
        yield op, at, body, length, data
        at = body + length


def message_head(data: bytes, at: int) -> tuple[int, int]:
    """(channel id, log time [ns]) of the message record whose body starts at ``at`` in ``data``."""
    channel, _, log_time, _ = _MESSAGE_HEAD.unpack_from(data, at)
    return channel, log_time


def _chunk_messages(chunk: Chunk, topics: dict[int, str]) -> list[tuple[str, int, bytes]]:
    """(topic, log time [ns], payload) of every message in a chunk; the channels it defines go into
    ``topics``. Raises whatever a damaged chunk makes the reader raise (its CRC is checked)."""
    found = []
    for op, _, at, length, data in chunk_records(chunk):
        if op == _OP_MESSAGE:
            channel, log_time = message_head(data, at)
            found.append((topics.get(channel, ""), log_time, data[at + _MESSAGE_HEAD.size:at + length]))
        elif op == _OP_CHANNEL:
            record = Channel.read(ReadDataStream(BytesIO(data[at:at + length])))
            topics[record.id] = record.topic
    return found


def complete_messages(path: str | Path) -> Iterator[tuple[str, int, bytes]]:
    """(topic, log time [ns], payload) of every message an MCAP file holds in full, in file order, up
    to the first record that is cut short or damaged: what a writer that died had put on disk."""
    topics: dict[int, str] = {}
    try:
        f = open(path, "rb")
    except OSError:
        return
    with f:
        records = StreamReader(f, emit_chunks=True, validate_crcs=True).records
        while True:
            try:
                record = next(records)
                if isinstance(record, Chunk):
                    found = _chunk_messages(record, topics)
                elif isinstance(record, Channel):
                    topics[record.id] = record.topic
                    continue
                elif isinstance(record, Message):
                    found = [(topics.get(record.channel_id, ""), record.log_time, record.data)]
                else:
                    continue
            except StopIteration:
                return
            except Exception:  # the end of what was written whole (any error a cut-short file gives)
                return
            yield from found


def ring_messages(batch: memoryview, renderers: dict[int, Any]) -> Iterator[tuple[int, int, bytes]]:
    """(channel id, log time [ns], payload) of every message in a batch of records, as the writer
    would write them (:meth:`cosim.record.writer._Apply.apply_batch`: the same renderers, the same
    checkpoint text); the other records are skipped."""
    for kind, channel, time_ns, payload in iter_records(batch, renderers):
        if kind == MESSAGE:
            yield channel, time_ns, payload
        elif kind == BYTES:
            yield channel, time_ns, bytes(payload)
        elif kind == OTHER:
            record = read_other(payload)
            if record[0] == "state":
                yield record[1], record[2], state_bytes(record[3])
        else:
            raise ValueError(f"unknown record kind {kind}")


def resume_point(held: Sequence[tuple[int, memoryview]], tallies: dict[int, int],
                 written: int) -> tuple[int, int] | None:
    """Where the ring continues a file holding the stream's first ``written`` messages: (index in
    ``held``, messages of it and the batches after it to skip), from the latest held batch whose
    tally (messages written before it) is at most ``written``; None when the ring no longer reaches
    back that far."""
    for i in range(len(held) - 1, -1, -1):
        before = tallies.get(held[i][0])
        if before is not None and before <= written:
            return i, written - before
    return None


@dataclass
class Salvaged:
    """What a rebuilt recording holds."""

    messages: int = 0  # messages written
    from_file: int = 0  # of which read back from the file the writer left
    end_ns: int = 0  # the latest log time among them [ns]
    complete: bool = False  # every message the run sent is there (else only the file's)
    channels: set[int] = field(default_factory=set)  # channel ids with at least one message


class _Target(Protocol):
    """What :func:`rebuild` writes to (:class:`cosim.record.writer._Apply`): records applied with
    ``apply``, messages logged through ``logs[channel](data, log_time)``, the ``renderers`` of the
    channels' packed records, ``after(channel, log_time, data)`` writing what is derived from a
    message where the recording is written (:mod:`cosim.record.derive`), and ``check()`` raising
    the first write that failed (the disk full: its MCAP writer only logs such failures)."""

    logs: dict[int, Callable[[bytes, int], None]]
    renderers: dict[int, Any]

    def apply(self, record: tuple) -> int: ...

    def after(self, channel: int, time_ns: int, data: bytes) -> None: ...

    def check(self) -> None: ...


def rebuild(out: _Target, part: str | Path, directory: Sequence[tuple], held: Sequence[tuple[int, memoryview]],
            tallies: dict[int, int]) -> Salvaged:
    """Write to ``out`` what a writer that died left: the ``directory`` (the schema, channel, metadata
    and attachment records the run sent, in order), the messages complete in its file ``part``, and
    the rest from the ring's ``held`` batches (see :func:`resume_point`).

    The viewer channels the writer derived from the recorded messages (on channels the directory
    does not name: :mod:`cosim.record.derive`) are not copied from the file but derived again, as
    each message is written: the same messages, to the end of what is salvaged.

    A write that fails (the disk full, a file-size limit) is raised within :data:`CHECK_EVERY`
    messages of it (``out.check()``), not after the rest has been copied in vain."""
    for record in directory:
        out.apply(record)
    by_topic = {record[2]: record[1] for record in directory if record[0] == "channel"}
    kept = Salvaged()
    logs = out.logs

    def log(channel: int, time_ns: int, data: bytes) -> None:
        logs[channel](data, time_ns)
        out.after(channel, time_ns, data)
        kept.messages += 1
        kept.end_ns = max(kept.end_ns, time_ns)
        kept.channels.add(channel)
        if not kept.messages % CHECK_EVERY:
            out.check()

    written = 0  # messages of the stream the run sent that are in the file (its first ones)
    for topic, time_ns, data in complete_messages(part):
        channel = by_topic.get(topic)
        if channel is not None:  # (not one the writer derived: those are not in the stream)
            written += 1
            log(channel, time_ns, data)
    kept.from_file = kept.messages
    start = resume_point(held, tallies, written)
    if start is None:
        return kept
    first, skip = start
    for _, batch in held[first:]:
        for channel, time_ns, data in ring_messages(batch, out.renderers):
            if skip:
                skip -= 1
            else:
                log(channel, time_ns, data)
    out.check()
    kept.complete = True
    return kept
