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
warm in the cache) or the free space of a ring in shared memory, and sent a batch at a time:
numbers go in as they are and arrays as raw bytes, one copy each, with no Python object made per
value.
"""

from __future__ import annotations

import pickle
import struct
from collections.abc import Callable, Iterator
from typing import Any

HEADER = struct.Struct("<BIq")  # kind, channel id, log time [ns]
LENGTH = struct.Struct("<Q")  # the length of a BYTES or OTHER body [bytes]
OTHER_HEAD = struct.Struct("<I")  # an OTHER body: the number of out-of-band buffers, then each one's LENGTH
MESSAGE, BYTES, OTHER = 0, 1, 2

Write = Callable[[Any, memoryview, int, int, int], int]
"""A codec's ``write(msg, buffer, offset, channel, time_ns)``: the offset just past the record it
wrote; -1 when the message must be encoded the slow way; ``-n`` (n > 1) when the record needs n
bytes and fewer are left (nothing written)."""


_NO_ROOM = memoryview(b"")


class Stage:
    """Records gathered into a buffer of ``size`` bytes and handed to ``send`` (a memoryview, valid
    only during the call) once ``batch`` records or ``batch_bytes`` bytes are in it (so the receiver
    stays close behind), when the next record does not fit, or on :meth:`flush`. A record larger
    than the buffer is sent alone, from a buffer of its own (or, up to ``fresh_max`` bytes, from
    space ``fresh`` gives for it alone).

    The buffer is allocated once, or, with ``fresh``, asked for anew after each batch is sent:
    ``fresh(size)`` gives ``size`` bytes to gather the next batch in (a ring's free space in shared
    memory, so a batch reaches the other process without a copy). It is asked for only when a
    record comes, so the packing of each message does not test for it: an empty buffer makes the
    record's ``write`` report the room it needs, which takes the slow branch here.
    """

    def __init__(self, size: int, batch: int, send: Callable[[memoryview], None], batch_bytes: int | None = None,
                 fresh: Callable[[int], memoryview] | None = None, fresh_max: int = 0):
        self.size = size
        self.fresh = fresh
        # a BYTES or OTHER record larger than the stage but at most this large is written straight
        # into space of its own that ``fresh`` gives (a checkpoint of a large pond: no copy on the way)
        self.fresh_max = fresh_max if fresh is not None else 0
        self.view = memoryview(bytearray(size)) if fresh is None else _NO_ROOM
        self.offset = 0
        self.count = 0
        self.batch = batch
        self.batch_bytes = size if batch_bytes is None else min(batch_bytes, size)
        self.send = send
        # where a record that does not fit in the space left is packed first (_add_large): kept and
        # reused, up to the stage's size, so that packing a water field (a megabyte) neither asks
        # the system for fresh pages nor takes their faults each time
        self._scratch = memoryview(bytearray(0))

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

    def _room(self, needed: int) -> bool:
        """Make room for a record of ``needed`` bytes at :attr:`offset` (sending the records gathered
        so far, taking a fresh buffer); False when it is larger than any buffer."""
        if self.offset + needed <= len(self.view):
            return True
        self.flush()
        if needed > self.size:
            return False
        if len(self.view) < needed:
            assert self.fresh is not None  # a buffer allocated once has ``size`` bytes
            self.view = self.fresh(self.size)
        return True

    def _add_large(self, write: Write, channel: int, time_ns: int, msg: Any, needed: int) -> bool:
        """A record that does not fit in the space left: packed first into space kept for that
        (:meth:`_packing_space`; a message can still be refused while its numbers are packed: then
        nothing has changed), then
        put after the records gathered so far, at the start of the next batch or, larger than the
        stage, sent alone. (With ``fresh``, the first record of each batch comes this way: one
        record's copy a batch.)"""
        own = self._packing_space(needed)
        if write(msg, own, 0, channel, time_ns) == -1:
            return False
        if not self._room(needed):
            self.send(own)
            return True
        self.view[self.offset:self.offset + needed] = own
        self._added(self.offset + needed)
        return True

    def _packing_space(self, needed: int) -> memoryview:
        """``needed`` bytes to pack one record in before it is placed: the kept scratch space (grown
        as records need, to at most the stage's size), or, for a record larger than the stage, space
        of its own. Valid until the next record: what is packed there is copied or sent at once."""
        if needed > self.size:
            return memoryview(bytearray(needed))
        if len(self._scratch) < needed:
            self._scratch = memoryview(bytearray(min(self.size, max(needed, 2 * len(self._scratch), 1 << 16))))
        return self._scratch[:needed]

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
        if self._room(needed):
            view, start = self.view, self.offset
        elif needed <= self.fresh_max:
            view, start = self.fresh(needed), 0  # type: ignore[misc]  (fresh_max is 0 without fresh)
        else:
            view, start = memoryview(bytearray(needed)), 0
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
        """Send the records gathered so far (with ``fresh``, the buffer goes with them)."""
        if self.offset:
            offset, self.offset, self.count = self.offset, 0, 0
            self.send(self.view[:offset])
            if self.fresh is not None:
                self.view = _NO_ROOM


def iter_records(batch: memoryview, renderers: dict[int, Callable[[memoryview, int], tuple[bytes, int]]]
                 ) -> Iterator[tuple[int, int, int, Any]]:
    """(kind, channel id, log time [ns], payload) of each record of a batch, in order: a MESSAGE's
    payload is its bytes as ``renderers[channel](batch, offset)`` renders them, a BYTES or OTHER
    record's its body (a view into the batch; :func:`read_other` reads an OTHER one)."""
    offset, end = 0, len(batch)
    while offset < end:
        kind, channel, time_ns = HEADER.unpack_from(batch, offset)
        offset += HEADER.size
        if kind == MESSAGE:
            data, offset = renderers[channel](batch, offset)
            yield kind, channel, time_ns, data
            continue
        (n,) = LENGTH.unpack_from(batch, offset)
        offset += LENGTH.size
        yield kind, channel, time_ns, batch[offset:offset + n]
        offset += n


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
