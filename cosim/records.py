"""The record stream from the simulating process to a recording's writer. Standard library only.

A batch is a run of records, each a header (:data:`HEADER`: kind, channel id, log time [ns]) and a
body:

- :data:`MESSAGE`: a message packed by its codec (:meth:`cosim.codec.MessageCodec.write`), laid out
  as its channel's :class:`cosim.jsontext.RecordLayout`;
- :data:`BYTES`: a length (:data:`LENGTH`), then a message's bytes as they are to be written;
- :data:`OTHER`: a length, then a pickled tuple: a schema, a channel, metadata, an attachment or a
  checkpoint (a few per run).

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
MESSAGE, BYTES, OTHER = 0, 1, 2

Write = Callable[[Any, memoryview, int, int, int], int]
"""A codec's ``write(msg, buffer, offset, channel, time_ns)``: the offset just past the record it
wrote; -1 when the message must be encoded the slow way; ``-n`` (n > 1) when the record needs n
bytes and fewer are left (nothing written)."""


class Stage:
    """Records gathered into a fixed buffer of ``size`` bytes and handed to ``send`` (a memoryview,
    valid only during the call) when the buffer is full, after ``batch`` records, or on
    :meth:`flush`. A record larger than the buffer is sent alone, from a buffer of its own."""

    def __init__(self, size: int, batch: int, send: Callable[[memoryview], None]):
        self.view = memoryview(bytearray(size))
        self.offset = 0
        self.count = 0
        self.batch = batch
        self.send = send

    def add_message(self, write: Write, channel: int, time_ns: int, msg: Any) -> bool:
        """Pack ``msg`` with its codec's ``write``; False, with nothing changed, when it must take the
        slow path instead."""
        end = write(msg, self.view, self.offset, channel, time_ns)
        if end < 0:
            return end != -1 and self._add_large(write, channel, time_ns, msg, -end)
        self.offset = end
        self.count += 1
        if self.count >= self.batch:
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
        self.offset, self.count = needed, 1
        if self.count >= self.batch:
            self.flush()
        return True

    def add_bytes(self, kind: int, channel: int, time_ns: int, data: Any) -> None:
        """A BYTES record of ``data`` (bytes-like), or an OTHER record."""
        raw = memoryview(data).cast("B")
        n = raw.nbytes
        needed = HEADER.size + LENGTH.size + n
        if self.offset + needed > len(self.view):
            self.flush()
        view, start = (self.view, self.offset) if needed <= len(self.view) else (memoryview(bytearray(needed)), 0)
        HEADER.pack_into(view, start, kind, channel, time_ns)
        at = start + HEADER.size
        LENGTH.pack_into(view, at, n)
        at += LENGTH.size
        view[at:at + n] = raw
        if view is self.view:
            self.offset = at + n
            self.count += 1
            if self.count >= self.batch:
                self.flush()
        else:
            self.send(view)

    def add_other(self, record: tuple) -> None:
        """An OTHER record: ``record`` pickled."""
        self.add_bytes(OTHER, 0, 0, pickle.dumps(record, protocol=pickle.HIGHEST_PROTOCOL))

    def flush(self) -> None:
        """Send the records gathered so far."""
        if self.offset:
            offset, self.offset, self.count = self.offset, 0, 0
            self.send(self.view[:offset])
