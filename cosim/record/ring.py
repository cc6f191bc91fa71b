"""Batches of bytes from one process to another through a ring in shared memory. Standard library only.

The producer copies each batch (a list of byte buffers) into the ring, or gathers it in the ring's
own space in the first place (:meth:`RingProducer.reserve`, :meth:`RingProducer.commit`: no copy),
and sends its place on a control pipe; the consumer reads it in place and acknowledges how far it
has read on a second pipe.
Compared with writing the bytes down a pipe, this saves the kernel's copy and most of the turns
between the two processes: a recording streams tens of megabytes a second this way while the
simulation goes on.

Control records (producer -> consumer): ``<QI`` offset in the ring and number of parts, then each
part's length as ``<Q``. An offset of :data:`INLINE` means the parts follow on the pipe itself (a
batch larger than the ring). Acknowledgements (consumer -> producer): ``<Q``, the stream position
read up to, or :data:`FINISHED` as the consumer's last word. When the ring is full the producer waits
for the consumer; when the producer's end of the control pipe closes (on purpose or because the
process died) the consumer's iteration ends. A producer may also end one stream of batches and
start another on the same ring (:meth:`RingProducer.end_stream`: an offset of :data:`END`, answered
with :data:`FINISHED` once the consumer is done with the stream), as a writer process kept for the
next recording does.

Either side can die part-way, and the other can still save what it holds. After the ring's bytes,
the shared memory holds a small control block (:data:`CONTROL_BYTES`):

- the producer's *mark* (:meth:`RingProducer.mark`): the stream position of the space
  :meth:`RingProducer.reserve` gave, and how many of its bytes hold records gathered but not yet
  committed, up to a point the producer chooses (a recording marks each completed step). A producer
  that dies (SIGSEGV, SIGKILL) leaves it behind, and the consumer reads those records too
  (:meth:`RingConsumer.unsent`); one that hangs up clears it.
- the consumer's *tallies* (:meth:`RingConsumer.tally`): for each batch, by its number (batches are
  numbered from 0 in the order they are sent, on both sides), a count the consumer keeps of what
  it had done before it (a recording's writer: messages written). The producer keeps the batches
  that are still whole in the ring (:meth:`RingProducer.held`): with the tallies it can tell which of
  them hold what a consumer that died had not yet made durable.

A consumer that is alive but gets nowhere (its process stopped, or stuck) would hold a producer
waiting for room, or for its last word, for ever: a wait gives up (:class:`RingStuck`) once the
consumer has made no progress at all for :data:`SILENT_S` (no answer, and, where the producer knows
its process, no CPU time used), or its process has been found stopped for :data:`STOPPED_S`. A
merely slow consumer answers, or at least uses CPU time, now and then, and is waited for however
long it takes.
"""

from __future__ import annotations

import mmap
import os
import select
import struct
import time
from collections import deque
from collections.abc import Iterator, Sequence
from typing import Any

INLINE = (1 << 64) - 1  # control offset: the batch's parts follow on the pipe
END = (1 << 64) - 2  # control offset: the stream of batches ends here, the ring stays for the next one
FINISHED = (1 << 64) - 1  # acknowledgement: the consumer has done all it had to (e.g. finished a file)
_HEAD = struct.Struct("<QI")
_LENGTH = struct.Struct("<Q")
# the control block after the ring's bytes: the producer's mark, then the consumer's tallies
# the reserved space's stream position, the bytes of it marked (native order: set through a memoryview)
_MARK = struct.Struct("=QQ")
_TALLY = struct.Struct("<QQ")  # a batch's number, the consumer's count before it
TALLIES = 256  # batches whose tally is kept (the ring holds far fewer whole batches)
_TALLIES_AT = 64  # bytes into the control block
CONTROL_BYTES = _TALLIES_AT + TALLIES * _TALLY.size
MADV_POPULATE_WRITE = getattr(mmap, "MADV_POPULATE_WRITE", 23)  # Linux 5.14 and later
_PREFAULT_CHUNK = 1 << 20  # [bytes] the ring is made resident this much at a time, from its end


class RingError(RuntimeError):
    """The other side of the ring is gone."""


class RingStalled(RingError):
    """The consumer has not answered for as long as the producer was told to wait once asked to stop
    (:meth:`RingProducer.interrupted`): it may still be there (stopped, or stuck on a file system)."""


class RingStuck(RingError):
    """The consumer makes no progress while the producer waits for it, though nobody asked the
    producer to stop: its process found stopped, or neither an answer from it nor CPU time used by it
    for a long while (see :class:`_Progress`). The message says which."""


WAIT_SLICE_S = 0.25  # a wait for the consumer looks at the clock this often
STALL_S = 10.0  # asked to stop once, the producer waits at most this long for the consumer's next word
# unasked, a wait gives up on a consumer that has made no progress at all for this long: no answer,
# and no CPU time used (a slow consumer on a busy machine, a large batch, a file being finished all
# use some, however slowly they go)
SILENT_S = 60.0
# ... or whose process has been found stopped (SIGSTOP, a debugger's stop) for this long: it goes
# nowhere until someone continues it
STOPPED_S = 10.0
_STOPPED_STATES = ("T", "t")  # /proc/PID/stat: stopped by a signal, stopped by a debugger


def _process_state(pid: int) -> tuple[str, int] | None:
    """(state letter, CPU time used [clock ticks], all its threads') of process ``pid`` from
    ``/proc/PID/stat``; None where there is no such file (another system, the process gone)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            fields = f.read().rsplit(b")", 1)[1].split()  # after the command name, which may hold anything
        return fields[0].decode(), int(fields[11]) + int(fields[12])  # fields 3, 14 (utime) and 15 (stime)
    except (OSError, ValueError, IndexError, UnicodeDecodeError):
        return None


class _Progress:
    """Whether a consumer the producer waits for (without an answer so far) is getting anywhere.

    Its process using CPU time counts as progress; where its process is not known (``pid`` None, or
    no ``/proc``) only an answer does, which ends the wait. :meth:`stuck` says why the wait should
    give up: no progress for :data:`SILENT_S`, or the process found stopped for :data:`STOPPED_S`
    (the constants are read when asked, so that tests can shorten them)."""

    def __init__(self, pid: int | None):
        self.pid = pid
        self.progress_at = time.monotonic()  # the wait's start, then the last time CPU time was seen used
        self.cpu: int | None = None  # CPU time used when last looked at
        self.stopped_at: float | None = None  # when the process was first found stopped, in a row

    def stuck(self) -> str | None:
        """Why the consumer is to be given up on, or None while it may still be getting somewhere."""
        now = time.monotonic()
        found = _process_state(self.pid) if self.pid is not None else None
        if found is not None:
            state, cpu = found
            if self.cpu is not None and cpu != self.cpu:
                self.progress_at = now
            self.cpu = cpu
            if state not in _STOPPED_STATES:
                self.stopped_at = None
            elif self.stopped_at is None:
                self.stopped_at = now
            elif now - self.stopped_at >= STOPPED_S:
                return f"its process has been stopped for {STOPPED_S:g} s"
        if now - self.progress_at >= SILENT_S:
            if found is None:
                return f"it has not answered for {SILENT_S:g} s"
            return f"it has neither answered nor used any CPU time for {SILENT_S:g} s"
        return None


def shared_memory_fd(size: int) -> int:
    """A file descriptor of ``size`` bytes of anonymous shared memory (no name in any file system, so
    nothing is left behind when both processes end, however they end)."""
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("cosim-ring")
    else:  # an unlinked temporary file elsewhere
        import tempfile

        with tempfile.TemporaryFile() as f:
            fd = os.dup(f.fileno())
    try:
        os.ftruncate(fd, size)
    except BaseException:  # a file-size limit below it (EFBIG): not left open
        os.close(fd)
        raise
    return fd


def _note_tally(shared: Any, size: int, number: int, count: int) -> None:
    """Note ``count`` as the consumer's count before batch ``number`` in the control block of the
    shared memory ``shared`` (a ring of ``size`` bytes), in that batch's slot."""
    _TALLY.pack_into(shared, size + _TALLIES_AT + number % TALLIES * _TALLY.size, number, count)


def _size_of(part: Any) -> int:
    """Bytes in a part, whatever its item format (a float64 memoryview, a numpy array, bytes)."""
    return memoryview(part).nbytes


def _read_exact(fd: int, n: int) -> bytes | None:
    chunks = []
    while n:
        chunk = os.read(fd, n)
        if not chunk:
            return None
        chunks.append(chunk)
        n -= len(chunk)
    return b"".join(chunks)


def _write_all(fd: int, data: Any) -> None:
    view = memoryview(data).cast("B")
    while view:
        view = view[os.write(fd, view):]


class RingProducer:
    """The sending side: :meth:`put` a batch; ``fd`` and ``size`` go to the consumer process."""

    def __init__(self, size: int):
        self.size = size
        self.fd = shared_memory_fd(size + CONTROL_BYTES)
        self._map = mmap.mmap(self.fd, size + CONTROL_BYTES)
        self._view = memoryview(self._map)[:size]
        self._head = 0  # stream position of the next byte written
        self._tail = 0  # stream position the consumer has acknowledged
        self._acks = b""
        self._reserved: int | None = None  # stream position of the space reserve() gave
        self._sent = 0  # batches sent (the next one's number)
        # (number, stream position, length) of each batch still whole in the ring, oldest first
        self._held: deque[tuple[int, int, int]] = deque()
        self._unsent: tuple[int, Sequence[Any]] | None = None  # a batch too large for the ring, while it is sent
        # the mark: [the reserved space's stream position, the bytes of it marked] (see mark())
        self.marked = memoryview(self._map)[size:size + _MARK.size].cast("Q")
        self.control_fd = -1
        self.ack_fd = -1
        self.finished = False  # the consumer said FINISHED
        self.interrupts = 0  # how often the producer was asked to stop (interrupted())
        self._heard_at = 0.0  # time.monotonic() of the consumer's last word, or of the first interrupt
        # the consumer's process, when known (set by whoever started it): a wait watches whether it
        # gets anywhere (_Progress)
        self.consumer_pid: int | None = None

    def interrupted(self) -> None:
        """The producer's process was asked to stop (a Ctrl-C, a SIGTERM; safe from a signal handler):
        from now on a wait for the consumer gives up (:class:`RingStalled`) once it has not answered
        for :data:`STALL_S`, and at once when asked a second time. A consumer stopped or stuck would
        otherwise hold the process however often it was asked to end."""
        self.interrupts += 1
        if self.interrupts == 1:
            self._heard_at = time.monotonic()

    def forget_interrupts(self) -> None:
        """A new stream (the next recording of a kept writer): the interrupts of the last one are not its."""
        self.interrupts = 0

    def _stalled(self, waiting_since: float) -> bool:
        if self.interrupts >= 2:
            return True
        # silent for STALL_S: since its last word, the interrupt, and the start of this wait alike
        return self.interrupts == 1 and time.monotonic() - max(self._heard_at, waiting_since) >= STALL_S

    def connect(self, control_fd: int, ack_fd: int) -> None:
        """Start talking to the consumer: its control pipe (write end) and acknowledgement pipe (read end)."""
        self.control_fd, self.ack_fd = control_fd, ack_fd
        os.set_blocking(ack_fd, False)
        os.set_blocking(control_fd, False)  # a full pipe is waited on as the ring is (see _send)

    def _send(self, data: Any) -> None:
        """Write ``data`` whole down the control pipe. While the pipe is full (the consumer not reading:
        a batch larger than the ring goes down it whole, :meth:`put`), wait for it as for an answer:
        :class:`RingStalled` when asked to stop and it reads nothing for :data:`STALL_S`,
        :class:`RingStuck` when it makes no progress at all (:class:`_Progress`). A blocking write
        waited for ever on a stopped consumer."""
        view = memoryview(data).cast("B")
        since = time.monotonic()
        progress: _Progress | None = None
        while view:
            try:
                view = view[os.write(self.control_fd, view):]
            except BlockingIOError:
                pass
            else:  # the consumer read some: a new wait from here
                since, progress = time.monotonic(), None
                if self.interrupts:
                    self._heard_at = since
                continue
            if progress is None:
                progress = _Progress(self.consumer_pid)
            self._read_acks(wait=False)  # the consumer never waits on a full acknowledgement pipe meanwhile
            if not select.select([], [self.control_fd], [], WAIT_SLICE_S)[1]:
                self._give_up_if_nowhere(since, progress, "the consumer has not read the control pipe")

    def _free(self, total: int) -> int:
        """Where in the stream ``total`` bytes go next (after the head, or at the ring's start when
        they do not fit before its end), once the consumer has read what was there."""
        start = self._head
        if start % self.size + total > self.size:  # no room before the ring's end: start over at 0
            start += self.size - start % self.size
        end = start + total
        # the bytes to overwrite were written a lap earlier (or, after a skip to the ring's start,
        # may include this lap's): wait until the consumer has read them; it can never get past
        # the head, and once there the whole ring is free
        free_from = min(end - self.size, self._head)
        self._read_acks(wait=False)
        while self._tail < free_from:
            self._read_acks(wait=True)
        held = self._held
        while held and held[0][1] + self.size < end:  # its bytes are about to be written over
            held.popleft()
        return start

    def reserve(self, n: int) -> memoryview:
        """``n`` bytes of the ring to gather a batch in (at most the ring's size), free of anything the
        consumer has still to read (waits until they are): a batch written there is sent with
        :meth:`commit`, without a copy. The space stays the producer's until then; :meth:`put` gives
        it up."""
        start = self._free(n)
        self._reserved = start
        self.marked[1] = 0  # in this order: a process dying in between leaves nothing marked
        self.marked[0] = start
        at = start % self.size
        return self._view[at:at + n]

    def owns(self, part: Any) -> bool:
        """Whether ``part`` is a view of the ring itself (space given by :meth:`reserve`)."""
        return isinstance(part, memoryview) and part.obj is self._map

    def commit(self, used: int) -> None:
        """Send the first ``used`` bytes of the space :meth:`reserve` gave as one batch."""
        start, self._reserved = self._reserved, None
        if start is None:
            raise RingError("commit without reserve")
        self._head = start + used
        self._held.append((self._sent, start, used))
        self._sent += 1
        self._send(_HEAD.pack(start % self.size, 1) + _LENGTH.pack(used))

    def put(self, parts: Sequence[Any]) -> None:
        """Send one batch (bytes-like parts); waits while the consumer is a ring's length behind."""
        sizes = [_size_of(p) for p in parts]
        total = sum(sizes)
        lengths = b"".join(_LENGTH.pack(n) for n in sizes)
        if total > self.size:
            # nothing before it can be continued from the ring once it has gone: it is not held
            self._held.clear()
            self._unsent = (self._sent, parts)
            self._sent += 1
            self._send(_HEAD.pack(INLINE, len(parts)) + lengths)
            for part in parts:
                self._send(part)
            self._unsent = None
            return
        self._reserved = None  # any space reserved is given up: this batch may take it
        start = self._free(total)
        end = start + total
        offset = at = start % self.size
        for part, n in zip(parts, sizes, strict=True):
            self._view[at:at + n] = memoryview(part).cast("B")
            at += n
        self._head = end
        self._held.append((self._sent, start, total))
        self._sent += 1
        # only now that the bytes are in place may the consumer hear of them
        self._send(_HEAD.pack(offset, len(parts)) + lengths)

    def mark(self, used: int) -> None:
        """Mark the first ``used`` bytes of the space :meth:`reserve` gave last as whole records: should
        this process die before it commits them, the consumer reads them too
        (:meth:`RingConsumer.unsent`). (A caller marking often sets ``marked[1] = used`` itself: a
        third of the cost.) A mark on space already committed is ignored."""
        self.marked[1] = used

    def held(self) -> list[tuple[int, memoryview]]:
        """(number, bytes) of each batch sent that the ring still holds whole, oldest first, whether
        or not the consumer has read it; and a batch too large for the ring whose sending failed.
        Valid until the ring is written to or closed."""
        out = [(number, self._view[start % self.size:start % self.size + n]) for number, start, n in self._held]
        if self._unsent is not None:
            number, parts = self._unsent
            out.append((number, memoryview(b"".join(memoryview(p).cast("B") for p in parts))))
        return out

    def tallies(self) -> dict[int, int]:
        """The consumer's count before each batch it noted (:meth:`RingConsumer.tally`), by the
        batch's number; 0 before the first."""
        found = {0: 0}
        for i in range(TALLIES):
            number, count = _TALLY.unpack_from(self._map, self.size + _TALLIES_AT + i * _TALLY.size)
            if number and number % TALLIES == i:
                found[number] = count
        return found

    @property
    def sent(self) -> int:
        """Batches sent so far (the next one's number)."""
        return self._sent

    def _wait_for_answer(self) -> None:
        """Wait until the consumer has something to say on the acknowledgement pipe (or has closed
        it): :class:`RingStalled` when asked to stop and it stays silent (:meth:`interrupted`),
        :class:`RingStuck` when it makes no progress at all (:class:`_Progress`)."""
        since = time.monotonic()
        progress = _Progress(self.consumer_pid)
        while not select.select([self.ack_fd], [], [], WAIT_SLICE_S)[0]:
            self._give_up_if_nowhere(since, progress, "the consumer has not answered")

    def _give_up_if_nowhere(self, since: float, progress: _Progress, silent: str) -> None:
        """After a slice of a wait for the consumer begun at ``since`` that brought nothing:
        :class:`RingStalled` (saying ``silent``) when asked to stop and it stays silent
        (:meth:`interrupted`), :class:`RingStuck` when it makes no progress at all (``progress``)."""
        if self._stalled(since):
            raise RingStalled(silent)
        stuck = progress.stuck()
        if stuck is not None:
            raise RingStuck(stuck)

    def _read_acks(self, wait: bool) -> None:
        if wait:
            self._wait_for_answer()
        try:
            data = os.read(self.ack_fd, 1 << 16)
        except BlockingIOError:
            return
        if not data:
            raise RingError("the consumer has gone")
        if self.interrupts:
            self._heard_at = time.monotonic()
        data = self._acks + data
        whole = len(data) - len(data) % _LENGTH.size
        if whole:
            last = _LENGTH.unpack_from(data, whole - _LENGTH.size)[0]
            if last == FINISHED:
                self.finished = True
            else:
                self._tail = last
        self._acks = data[whole:]

    def end_stream(self) -> bool:
        """End this stream of batches and wait until the consumer has done all it had to with it
        (:meth:`RingConsumer.finish_stream`), keeping the ring and both pipes for another stream; True
        then, False when the consumer has gone (its batches are still :meth:`held`)."""
        self.marked[1] = 0  # ending on purpose: nothing is left unsent
        try:
            self._send(_HEAD.pack(END, 0))
            while not self.finished:
                self._read_acks(wait=True)
        except (RingStalled, RingStuck):  # the consumer is there, but not answering: the caller decides
            raise
        except (RingError, OSError):
            return False
        self.finished = False
        self._tail = self._head  # the consumer read the whole stream before it finished
        self._held.clear()  # a later stream's salvage must not reach back into this one
        # the next stream's count starts over before its first batch (the batches' numbers go on)
        _note_tally(self._map, self.size, self._sent, 0)
        return True

    def hang_up(self, wait: bool = True) -> bool:
        """Close the control pipe (the consumer then finishes) and read the consumer's last
        acknowledgements until it closes its end (so it never waits on a full pipe), or, asked to stop
        (:meth:`interrupted`), until it has not answered for :data:`STALL_S`, or until it makes no
        progress at all (:class:`RingStuck`). True when its last word was :data:`FINISHED`. Without
        ``wait`` (a consumer given up on), nothing is read, and the mark stays for the consumer to
        read the records it covers (:meth:`RingConsumer.unsent`)."""
        if self.fd >= 0 and wait:  # hanging up on purpose: nothing is left unsent
            self.marked[1] = 0
        if self.control_fd >= 0:
            os.close(self.control_fd)
            self.control_fd = -1
        if self.ack_fd >= 0:
            try:
                while wait:
                    try:
                        self._read_acks(wait=True)
                    except RingError:  # the consumer has closed its end, or stopped answering
                        break
            finally:
                os.close(self.ack_fd)
                self.ack_fd = -1
        return self.finished

    def close(self) -> None:
        """Close the control pipe (the consumer then finishes) and the producer's mapping (the
        acknowledgement pipe stays open: see :meth:`hang_up`)."""
        if self.control_fd >= 0:
            os.close(self.control_fd)
            self.control_fd = -1
        if self.fd >= 0:  # safe to call twice: never closes a number another file may have reused
            self.marked.release()
            self._view.release()
            try:
                self._map.close()
            except BufferError:  # space reserve() gave is still viewed: unmapped once that view goes
                pass
            os.close(self.fd)
            self.fd = -1


class RingConsumer:
    """The receiving side, over the producer's ``fd`` of ``size`` bytes and the two pipes."""

    def __init__(self, fd: int, size: int, control_fd: int, ack_fd: int):
        self.size = size
        self._map = mmap.mmap(fd, size + CONTROL_BYTES)
        self._view = memoryview(self._map)[:size]
        self.control_fd, self.ack_fd = control_fd, ack_fd
        self._position = 0  # stream position read up to (mirrors the producer's head)
        self._number = 0  # the number of the batch last given (or next to be)
        self.ended = False  # the last stream of batches ended with END (the producer goes on)

    def prefault(self) -> bool:
        """Make the whole ring resident, as the producer's first lap through it would (False where
        the system cannot: the producer's writes then fault the pages in as before).

        Shared memory is allocated (and zeroed) page by page as it is first written, a few
        milliseconds per 16 MiB; done here, in the consumer's process, that work is off the
        producer's thread, whose first touch of each page then only maps it. From the ring's end
        backwards, so as to stay out of the producer's way: it starts at the ring's beginning.
        Nothing in the ring changes (the pages are faulted in as if for writing, without a write).
        """
        if not hasattr(self._map, "madvise"):
            return False
        try:
            for end in range(self.size, 0, -_PREFAULT_CHUNK):
                start = max(0, end - _PREFAULT_CHUNK)
                self._map.madvise(MADV_POPULATE_WRITE, start, end - start)
        except (OSError, ValueError, OverflowError):  # an older kernel, or no such advice here
            return False
        return True

    def batches(self) -> Iterator[list[Any]]:
        """Each batch's parts (memoryviews into the ring, valid until the next batch is asked for),
        until the producer ends the stream (:attr:`ended` then True: answer with
        :meth:`finish_stream`) or closes the control pipe."""
        self.ended = False
        while True:
            head = _read_exact(self.control_fd, _HEAD.size)
            if head is None:
                return
            offset, count = _HEAD.unpack(head)
            if offset == END:
                self.ended = True
                return
            lengths = _read_exact(self.control_fd, _LENGTH.size * count) if count else b""
            if lengths is None:
                return
            sizes = [n for (n,) in _LENGTH.iter_unpack(lengths)]
            if offset == INLINE:
                parts = [_read_exact(self.control_fd, n) for n in sizes]
                if any(p is None for p in parts):
                    return
                yield parts
                self._number += 1
                continue
            # where the producer put it: after the last batch, or at the ring's start
            start = self._position
            if start % self.size != offset:
                start += self.size - start % self.size
            parts, at = [], offset
            for n in sizes:
                parts.append(self._view[at:at + n])
                at += n
            yield parts
            self._number += 1
            self._position = start + sum(sizes)
            if self.ack_fd >= 0:
                try:
                    _write_all(self.ack_fd, _LENGTH.pack(self._position))
                except OSError:  # the producer has gone: read on to the batches it has already sent
                    self.ack_fd = -1

    def finish_stream(self) -> None:
        """Tell the producer this side has done all it had to with the stream that ended, and wait
        for the next one (see :meth:`RingProducer.end_stream`)."""
        if self.ack_fd >= 0:
            try:
                _write_all(self.ack_fd, _LENGTH.pack(FINISHED))
            except BrokenPipeError:  # a producer that gave up on this side and hung up: nobody to tell
                pass

    def tally(self, count: int) -> None:
        """Note ``count`` (what this side has done so far, e.g. messages written) as its count before
        the next batch; call it once the batch last given is done with."""
        _note_tally(self._map, self.size, self._number + 1, count)

    def unsent(self) -> memoryview | None:
        """Once :meth:`batches` has ended: the records a producer that died had gathered in the ring
        and marked (:meth:`RingProducer.mark`) but not committed, as one batch; None when there are
        none (a producer that hung up clears its mark)."""
        start, used = _MARK.unpack_from(self._map, self.size)
        end = start + used
        if start == self._position:  # the space came after the last batch...
            at = start % self.size
        elif start > self._position and start % self.size == 0 and start - self._position < self.size:
            at = 0  # ...or at the ring's start, the last batch leaving too little room before its end
        else:  # no mark, or one in a batch already read
            return None
        if not 0 < end - start <= self.size - at:
            return None
        return self._view[at:at + end - start]

    def finish(self) -> None:
        """Tell the producer this side has done all it had to (see :meth:`RingProducer.hang_up`), and
        close the acknowledgement pipe."""
        if self.ack_fd >= 0:
            try:
                _write_all(self.ack_fd, _LENGTH.pack(FINISHED))
            except OSError:  # the producer has gone: nobody to tell
                pass
            os.close(self.ack_fd)
            self.ack_fd = -1
