"""The record stream from the simulating process to a recording's writer. Standard library only.

A batch is a run of records, each a header (:data:`HEADER`: kind, channel id, log time [ns]) and a
body:

- :data:`MESSAGE`: a message packed by its codec (:meth:`cosim.codec.json_codec.MessageCodec.write`), laid out
  as its channel's :class:`cosim.codec.jsontext.RecordLayout`;
- :data:`BYTES`: a length (:data:`LENGTH`), then a message's bytes as they are to be written;
- :data:`OTHER`: a length, then a pickled tuple: a schema, a channel, metadata, an attachment or a
  checkpoint (a few per run); the pickle's out-of-band buffers (a checkpoint's arrays) follow it,
  their number and lengths before it (:data:`OTHER_HEAD`, :func:`read_other`).

Records are written into a :class:`Stage`, a buffer allocated once (so its pages stay mapped and
warm in the cache), and sent a batch at a time: numbers go in as they are and arrays as raw bytes,
one copy each, with no Python object made per value.
"""

from __future__ import annotations

import pickle
import struct
from collections.abc import Callable
from typing import Any

HEADER = struct.Struct("<BIq")  # kind, channel id, log time [ns]
LENGTH = struct.Struct("<Q")  # the length of a BYTES or OTHER body [bytes]
OTHER_HEAD = struct.Struct("<I")  # an OTHER body: the number of out-of-band buffers, then each one's LENGTH
MESSAGE, BYTES, OTHER = 0, 1, 2

Write = Callable[[Any, memoryview, int, int, int], int]
"""A codec's ``write(msg, buffer, offset, channel, time_ns)``: the offset just past the record it
wrote; -1 when the message must be encoded the slow way; ``-n`` (n > 1) when the record needs n
bytes and fewer are left (nothing written)."""


class Stage:
    """Records gathered into a buffer of ``size`` bytes, allocated once, and handed to ``send`` (a
    memoryview, valid only during the call) once ``batch`` records or ``batch_bytes`` bytes are in it
    (so the receiver stays close behind), when the next record does not fit, or on :meth:`flush`. A
    record larger than the buffer is sent alone, from a buffer of its own."""

    def __init__(self, size: int, batch: int, send: Callable[[memoryview], None], batch_bytes: int | None = None):
        self.view = memoryview(bytearray(size))
        self.offset = 0
        self.count = 0
        self.batch = batch
        self.batch_bytes = size if batch_bytes is None else min(batch_bytes, size)
        self.send = send

    def add_message(self, write: Write, channel: int, time_ns: int, msg: Any) -> bool:
        """Pack ``msg`` with its codec's ``write``; False, with nothing changed, when it must take the
        slow path instead."""
        end = write(msg, self.view, self.offset, channel, time_ns)
        if end < 0:
            return end != -1 and self._add_large(write, channel, time_ns, msg, -end)
        self.offset = end  # _added, written out: this runs for every exchange
        self.count += 1
        if self.count >= self.batch or end >= self.batch_bytes:
            self.flush()
        return True

    def _add_large(self, write: Write, channel: int, time_ns: int, msg: Any, needed: int) -> bool:
        """A record that does not fit in the space left: packed into a buffer of its own first (a
        message can still be refused while its numbers are packed), then sent after the records
        gathered so far, at the start of the next batch or, larger than the stage, alone."""
        own = memoryview(bytearray(needed))
        if write(msg, own, 0, channel, time_ns) == -1:
            return False
        self.flush()
        if needed > len(self.view):
            self.send(own)
            return True
        self.view[:needed] = own
        self._added(needed)
        return True

    def _added(self, end: int) -> None:
        self.offset = end
        self.count += 1
        if self.count >= self.batch or end >= self.batch_bytes:
            self.flush()

    def add_bytes(self, kind: int, channel: int, time_ns: int, *parts: Any) -> None:
        """A BYTES or OTHER record whose body is the concatenation of ``parts`` (bytes-like)."""
        raws = [memoryview(part).cast("B") for part in parts]
        n = sum(raw.nbytes for raw in raws)
        needed = HEADER.size + LENGTH.size + n
        if self.offset + needed > len(self.view):
            self.flush()
        view, start = (self.view, self.offset) if needed <= len(self.view) else (memoryview(bytearray(needed)), 0)
        HEADER.pack_into(view, start, kind, channel, time_ns)
        at = start + HEADER.size
        LENGTH.pack_into(view, at, n)
        at += LENGTH.size
        for raw in raws:
            view[at:at + raw.nbytes] = raw
            at += raw.nbytes
        if view is self.view:
            self._added(at)
        else:
            self.send(view)

    def add_other(self, record: tuple) -> None:
        """An OTHER record: ``record`` pickled, its pickle buffers (the arrays of a checkpoint, see
        :func:`cosim.codec.json_codec.plain_state`) copied out of band, straight from the arrays."""
        buffers: list[memoryview] = []
        data = pickle.dumps(record, protocol=5, buffer_callback=lambda b: buffers.append(b.raw()))
        head = OTHER_HEAD.pack(len(buffers)) + b"".join(LENGTH.pack(b.nbytes) for b in buffers)
        self.add_bytes(OTHER, 0, 0, head, data, *buffers)

    def flush(self) -> None:
        """Send the records gathered so far."""
        if self.offset:
            offset, self.offset, self.count = self.offset, 0, 0
            self.send(self.view[:offset])


def read_other(body: memoryview) -> tuple:
    """The tuple an OTHER record's body holds (its out-of-band buffers are views into ``body``)."""
    (count,) = OTHER_HEAD.unpack_from(body, 0)
    at = OTHER_HEAD.size
    sizes = [n for (n,) in LENGTH.iter_unpack(body[at:at + LENGTH.size * count])]
    at += LENGTH.size * count
    end = len(body) - sum(sizes)
    buffers = []
    for n in [end - at, *sizes]:
        buffers.append(body[at:at + n])
        at += n
    return pickle.loads(buffers[0], buffers=buffers[1:])
