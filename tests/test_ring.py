"""The shared-memory ring (cosim.record.ring): every batch arrives whole and in order, around the ring's end,
inline when larger than the ring, and under backpressure; either side ending is seen by the other.

Most tests run the consumer in a child process, as a recording's writer does::

    test process                                     child process
    RingProducer --control pipe: offset, sizes-->    RingConsumer --> (length, sha256) of each part,
       |   ^-------- ack pipe: position read --------   |              on stdout when the ring closes
       '------------ memfd: the bytes -------------------'

The child checksums each part when it gets it and again just before asking for the next batch, so a
producer that overwrote bytes still being read would show. Tests that need exact control of the
order of events run the consumer in this process (a generator, or a thread).
"""

from __future__ import annotations

import hashlib
import json
import mmap
import os
import pickle
import random
import select
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cosim.record.ring import RingConsumer, RingError, RingProducer

ROOT = Path(__file__).resolve().parents[1]
RING = 4096  # bytes: small, so that a few hundred batches go around it many times
WATCHDOG_S = 10.0  # a child consumer still running after this long is killed: a hang fails the test, never stalls it

CONSUMER = r"""
import hashlib, json, os, sys, time
from cosim.record.ring import RingConsumer

fd, size, control, ack, delay, die_after, busy = sys.argv[1:]
delay, die_after, busy = float(delay), int(die_after), busy == "busy"
report = []
for parts in RingConsumer(int(fd), int(size), int(control), int(ack)).batches():
    sums = [hashlib.sha256(p).hexdigest() for p in parts]
    if busy:  # a consumer working on the batch all that time (CPU time used, nothing said)
        end = time.monotonic() + delay
        while time.monotonic() < end:
            pass
    else:
        time.sleep(delay)  # a slow consumer: the producer must wait rather than overwrite these bytes
    report.append([[memoryview(p).nbytes, s, hashlib.sha256(p).hexdigest() == s] for p, s in zip(parts, sums)])
    if len(report) == die_after:
        os._exit(0)  # dies holding this batch, never acknowledged
sys.stdout.write(json.dumps(report))
"""


def digest(batch: list) -> list:
    """What the child consumer reports for a batch it read intact."""
    return [[memoryview(p).nbytes, hashlib.sha256(p).hexdigest(), True] for p in batch]


class Child:
    """A RingConsumer in a child process, connected to ``producer`` through two fresh pipes; it sleeps
    ``delay`` seconds on each batch (or, ``busy``, works that long), and exits holding batch number
    ``die_after`` (0: never)."""

    def __init__(self, producer: RingProducer, delay: float = 0.0, die_after: int = 0, busy: bool = False):
        control_r, control_w = os.pipe()
        ack_r, ack_w = os.pipe()
        self.producer = producer
        self.proc = subprocess.Popen(
            [sys.executable, "-P", "-c", CONSUMER, str(producer.fd), str(producer.size), str(control_r),
             str(ack_w), str(delay), str(die_after), "busy" if busy else "idle"],
            pass_fds=(producer.fd, control_r, ack_w), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            env={**os.environ, "PYTHONPATH": str(ROOT)})
        os.close(control_r)
        os.close(ack_w)
        producer.connect(control_w, ack_r)
        self.ack_r = ack_r
        self.producer_closed = self.ack_closed = False
        # killing a stuck child closes the ack pipe, which wakes a producer waiting on it (RingError)
        self.watchdog = threading.Timer(WATCHDOG_S, self.proc.kill)
        self.watchdog.start()

    def finish(self) -> list:
        """Close the producer and return the child's report of every batch it read (the ack pipe stays
        open until the child has exited, as cosim.record.writer.ProcessSink keeps it)."""
        self.close_producer()
        out, err = self.proc.communicate(timeout=WATCHDOG_S)
        self.close_ack()
        assert self.proc.returncode == 0, err.decode()
        return json.loads(out)

    def close_producer(self) -> None:
        if not self.producer_closed:  # RingProducer.close is not safe to call twice
            self.producer_closed = True
            self.producer.close()

    def close_ack(self) -> None:
        if not self.ack_closed:
            self.ack_closed = True
            os.close(self.ack_r)

    def die(self) -> None:
        """Close both of the producer's pipe ends, as the kernel does when the producing process ends."""
        self.close_producer()
        self.close_ack()

    def cleanup(self) -> None:
        self.watchdog.cancel()
        self.die()
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.communicate()


@pytest.fixture
def child():
    """Makes child consumers (``child(producer, delay=..., die_after=...)``) and cleans them up."""
    made: list[Child] = []

    def make(producer: RingProducer, **kw) -> Child:
        made.append(Child(producer, **kw))
        return made[-1]

    yield make
    for c in made:
        c.cleanup()


class Local:
    """A producer and a consumer in this process, over two fresh pipes."""

    def __init__(self, size: int = RING):
        self.producer = RingProducer(size)
        self.control_r, control_w = os.pipe()
        self.ack_r, self.ack_w = os.pipe()
        self.producer.connect(control_w, self.ack_r)
        self.consumer = RingConsumer(self.producer.fd, size, self.control_r, self.ack_w)
        self.open = [self.control_r, self.ack_r, self.ack_w]
        self.producer_open = True
        self._lock = threading.Lock()
        # closing the producer wakes a consumer stuck waiting for bytes that never come: a hang fails the test
        self.watchdog = threading.Timer(WATCHDOG_S, self.close_producer)
        self.watchdog.start()

    def close_consumer(self) -> None:
        """What the kernel does when the consumer's process dies: close its pipe ends."""
        for fd in (self.control_r, self.ack_w):
            if fd in self.open:
                self.open.remove(fd)
                os.close(fd)

    def close_producer(self) -> None:
        with self._lock:  # RingProducer.close is not safe to call twice
            if self.producer_open:
                self.producer_open = False
                self.producer.close()

    def cleanup(self) -> None:
        self.watchdog.cancel()
        self.close_producer()
        for fd in self.open:
            os.close(fd)


@pytest.fixture
def local():
    pair = Local()
    yield pair
    pair.cleanup()


def consume_in_thread(consumer: RingConsumer) -> tuple[threading.Thread, list[list[bytes]]]:
    """A thread copying every batch's parts until the producer closes."""
    got: list[list[bytes]] = []

    def run() -> None:
        for parts in consumer.batches():
            got.append([bytes(p) for p in parts])

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread, got


class Worker(threading.Thread):
    """Runs ``fn(*args)`` in a daemon thread, keeping what it raised in ``error`` (rather than
    reporting it as an unhandled thread exception)."""

    def __init__(self, fn, *args):
        super().__init__(daemon=True)
        self.fn, self.fn_args, self.error = fn, args, None

    def run(self) -> None:
        try:
            self.fn(*self.fn_args)
        except BaseException as exc:
            self.error = exc


def in_thread(fn, *args) -> Worker:
    """A started Worker running ``fn(*args)``."""
    worker = Worker(fn, *args)
    worker.start()
    return worker


def random_batches(rng: random.Random, n: int, max_total: int) -> list[list[bytes]]:
    """``n`` batches of 1 to 3 random parts, each batch at most ``max_total`` bytes."""
    batches = []
    for _ in range(n):
        sizes = [rng.randint(0, max_total // 3) for _ in range(rng.randint(1, 3))]
        batches.append([rng.randbytes(size) for size in sizes])
    return batches


# --- every batch arrives ------------------------------------------------------------------------------


def test_batches_arrive_whole_and_in_order_whatever_their_parts(child):
    """Batches of one or several parts, empty parts, no parts at all, and memoryview, bytearray and
    pickle-buffer parts each arrive in order with every part's bytes and boundaries intact."""
    floats = np.linspace(-1.0, 1.0, 100)
    batches = [
        [b"hello"],
        [b"a", b"", b"bc"],
        [],
        [b""],
        [memoryview(bytearray(b"xyz" * 100))],
        [memoryview(b"0123456789")[2:7], bytearray(b"ba"), b"tail"],
        [memoryview(floats).cast("B")],
        [pickle.PickleBuffer(floats.tobytes()).raw(), b"", b"!"],
        [bytes(range(256)) * 3],
    ] * 5
    producer = RingProducer(RING)
    consumer = child(producer)
    for batch in batches:
        producer.put(batch)
    assert consumer.finish() == [digest(batch) for batch in batches]


def test_many_batches_wrap_around_a_small_ring_byte_identical(child):
    """Hundreds of random batches (up to half the ring each) go around a 4 KiB ring dozens of times,
    starting over at its beginning wherever the next one does not fit, and arrive byte-identical.

    Batches over half the ring may hang the producer: see
    test_a_batch_that_must_start_over_at_the_rings_beginning_does_not_hang."""
    batches = random_batches(random.Random(7), 400, RING // 2)
    assert sum(len(p) for b in batches for p in b) > 50 * RING
    producer = RingProducer(RING)
    consumer = child(producer)
    for batch in batches:
        producer.put(batch)
    assert consumer.finish() == [digest(batch) for batch in batches]


def test_batches_gathered_in_the_ring_itself_arrive_between_copied_ones(child):
    """Batches written straight into space the ring reserved (any part of it used), mixed with
    copied ones, go around a small ring many times and arrive byte-identical, never overwritten
    while a slow consumer still reads them."""
    rng = random.Random(11)
    producer = RingProducer(RING)
    consumer = child(producer, delay=0.0005)
    sent = []
    for i in range(300):
        data = rng.randbytes(rng.randint(0, RING // 4))
        if i % 3:
            view = producer.reserve(RING // 4)
            assert producer.owns(view) and view.nbytes == RING // 4
            view[:len(data)] = data
            producer.commit(len(data))
        else:
            assert not producer.owns(memoryview(data))
            producer.put([data])
        sent.append([data])
    del view
    assert consumer.finish() == [digest(batch) for batch in sent]


@settings(max_examples=40, deadline=None)
@given(st.lists(st.lists(st.binary(max_size=RING // 6), max_size=3), max_size=60))
def test_any_batches_round_trip_through_the_ring(batches):
    """Any sequence of batches (up to half the ring each) comes out as it went in, part for part."""
    pair = Local()
    try:
        thread, got = consume_in_thread(pair.consumer)
        for batch in batches:
            pair.producer.put(batch)
        pair.close_producer()
        thread.join(WATCHDOG_S)
        assert not thread.is_alive()
        assert got == batches
    finally:
        pair.cleanup()


def test_batches_larger_than_the_ring_arrive_between_ring_batches(child):
    """Batches larger than the ring (sent inline on the pipe, here far larger than a pipe's buffer)
    keep their place among the batches that go through the ring; a batch of exactly the ring's size
    (first, into the empty ring) still goes through the ring, one byte more goes inline."""
    rng = random.Random(3)
    big = [rng.randbytes(150_000), b"", memoryview(rng.randbytes(RING))]
    batches = [[rng.randbytes(RING)], [b"before"], big, [rng.randbytes(RING + 1)], [b"x" * 1500], big, [b"after"]]
    producer = RingProducer(RING)
    consumer = child(producer)
    for batch in batches:
        producer.put(batch)
    assert consumer.finish() == [digest(batch) for batch in batches]


def test_a_batch_larger_than_the_ring_comes_off_the_pipe(local):
    """A batch larger than the ring reaches the consumer as bytes read from the pipe, not as views
    into the ring; a batch that fits comes as views into the ring."""
    gen = local.consumer.batches()
    local.producer.put([b"small"])
    (part,) = next(gen)
    assert isinstance(part, memoryview) and part == b"small"
    big = os.urandom(3 * RING)
    put = in_thread(local.producer.put, [big[:RING], big[RING:]])  # 12 KiB fit in a pipe's buffer; do not count on it
    parts = next(gen)
    put.join(WATCHDOG_S)
    assert put.error is None
    assert [type(p) for p in parts] == [bytes, bytes]
    assert b"".join(parts) == big and [len(p) for p in parts] == [RING, 2 * RING]


def test_prefault_makes_the_ring_resident_and_changes_none_of_its_bytes():
    """The consumer's prefault allocates the whole ring's memory (the shared memory file then holds
    every page, where before it held only the pages written) without touching what the producer has
    put there; where the system cannot, it says so and nothing changes."""
    size = 64 * mmap.PAGESIZE
    pair = Local(size)
    try:
        gen = pair.consumer.batches()
        batch = [os.urandom(3 * mmap.PAGESIZE), b"tail"]
        pair.producer.put(batch)
        before = os.fstat(pair.producer.fd).st_blocks * 512  # bytes allocated (tmpfs, or a temporary file)
        assert before < size  # only the pages written so far
        done = pair.consumer.prefault()
        after = os.fstat(pair.producer.fd).st_blocks * 512
        if done:
            assert after >= size
        else:  # an older kernel: the producer's writes fault the pages in, as without the call
            assert after == before
        assert [bytes(p) for p in next(gen)] == batch
        pair.producer.put([b"next"])
        assert [bytes(p) for p in next(gen)] == [b"next"]
    finally:
        pair.cleanup()


# --- backpressure ---------------------------------------------------------------------------------------


def test_producer_waits_for_the_consumer_instead_of_overwriting(local):
    """With the ring full, put waits; the batch being read keeps its bytes until the consumer asks for
    the next one (only then is it acknowledged), and the waiting put goes on at that moment:

        ring: [ A: 2000 'a' | B: 2000 'b' | 96 free ]   put C (1000 'c') must start over at 0, on A
    """
    gen = local.consumer.batches()
    local.producer.put([b"a" * 2000])
    local.producer.put([b"b" * 2000])
    put_c = in_thread(local.producer.put, [b"c" * 1000])
    put_c.join(0.2)
    assert put_c.is_alive()  # nothing read yet: C waits
    (a,) = next(gen)
    put_c.join(0.2)
    assert put_c.is_alive()  # A is being read, not yet acknowledged: C still waits
    assert a == b"a" * 2000
    (b,) = next(gen)  # asking for B acknowledges A: now C may go where A was
    put_c.join(WATCHDOG_S)
    assert not put_c.is_alive() and put_c.error is None
    assert b == b"b" * 2000
    (c,) = next(gen)
    assert c == b"c" * 1000


def test_slow_consumer_reads_every_batch_unchanged(child):
    """A consumer that takes 2 ms per batch gets every one of 150 batches with the checksum it had on
    arrival still holding after the wait; the producer, a ring ahead at most, waited for it."""
    delay = 0.002
    batches = [[random.Random(i).randbytes(random.Random(-i).randint(500, 1500))] for i in range(150)]
    producer = RingProducer(RING)
    consumer = child(producer, delay=delay)
    start = time.perf_counter()
    for batch in batches:
        producer.put(batch)
    elapsed = time.perf_counter() - start
    assert consumer.finish() == [digest(batch) for batch in batches]
    # at most RING // 500 batches fit in the ring, so the producer waited out the consumer's other sleeps
    assert elapsed >= (len(batches) - 2 * (RING // 500)) * delay


# --- the ends ------------------------------------------------------------------------------------------


def test_closing_the_producer_ends_the_consumers_iteration(local):
    """After the producer closes, the consumer gets the batches already sent, then its iteration ends."""
    for i in range(3):
        local.producer.put([bytes([i]) * 10])
    local.close_producer()
    assert [[bytes(p) for p in parts] for parts in local.consumer.batches()] == [[bytes([i]) * 10] for i in range(3)]


def test_a_child_consumer_finishes_when_the_producer_closes(child):
    """A consumer in another process reads every batch sent, then ends its iteration and exits 0 when
    the producer closes (the producer keeps reading acknowledgements until then, as ProcessSink does)."""
    producer = RingProducer(RING)
    consumer = child(producer, delay=0.05)
    for i in range(3):
        producer.put([bytes([i]) * 10])
    assert consumer.finish() == [digest([bytes([i]) * 10]) for i in range(3)]


@pytest.mark.parametrize("sent", [1, 5])
def test_a_producer_process_ending_ends_the_consumers_iteration(child, sent):
    """The producer sends a few batches and its process ends at once (both its pipe ends close) while
    a slow consumer is still on the first: the consumer still gets every batch, then finishes."""
    producer = RingProducer(RING)
    consumer = child(producer, delay=0.2)
    for i in range(sent):
        producer.put([bytes([i]) * 10])
    consumer.die()
    assert consumer.finish() == [digest([bytes([i]) * 10]) for i in range(sent)]


def test_put_to_a_consumer_gone_before_reading_raises_ring_error(local):
    """A batch for the ring, with the consumer gone and nothing acknowledged, raises RingError."""
    local.close_consumer()
    with pytest.raises(RingError, match="the consumer has gone"):
        local.producer.put([b"x"])


def test_put_to_a_consumer_gone_after_acknowledging_raises(local):
    """When the dead consumer's last acknowledgements are still in the pipe, the first put reads them
    and then fails writing the control record (BrokenPipeError); the next put sees the ack pipe's end
    (RingError). Callers catch both (cosim.record.writer.ProcessSink catches RingError and OSError)."""
    gen = local.consumer.batches()
    local.producer.put([b"1"])
    local.producer.put([b"2"])
    next(gen)
    next(gen)  # acknowledges the first batch
    select.select([local.ack_r], [], [], WATCHDOG_S)
    local.close_consumer()
    with pytest.raises(BrokenPipeError):
        local.producer.put([b"3"])
    with pytest.raises(RingError, match="the consumer has gone"):
        local.producer.put([b"4"])


def test_inline_put_to_a_gone_consumer_raises_broken_pipe(local):
    """A batch larger than the ring goes straight down the pipe: with the consumer gone, BrokenPipeError."""
    local.close_consumer()
    with pytest.raises(BrokenPipeError):
        local.producer.put([b"x" * (RING + 1)])


def test_producer_waiting_on_a_full_ring_wakes_when_the_consumer_dies(child):
    """A producer waiting for room is not left waiting forever when the consumer process dies holding
    a batch: put raises RingError."""
    producer = RingProducer(RING)
    consumer = child(producer, delay=0.1, die_after=1)
    producer.put([b"a" * 3000])
    put = in_thread(producer.put, [b"b" * 3000])  # must start over at 0, on the unacknowledged first batch
    put.join(WATCHDOG_S / 2)  # woken by the death, not by the watchdog
    assert not put.is_alive()
    assert isinstance(put.error, RingError) and str(put.error) == "the consumer has gone"
    consumer.proc.wait(WATCHDOG_S)
    assert consumer.proc.returncode == 0


def test_a_killed_child_consumer_makes_put_fail(child):
    """SIGKILL of the consumer's process makes the next put raise (RingError, or BrokenPipeError when
    its last acknowledgements were still unread) rather than hang."""
    producer = RingProducer(RING)
    consumer = child(producer)
    for _ in range(3):
        producer.put([b"y" * 100])
    consumer.proc.kill()
    consumer.proc.wait(WATCHDOG_S)
    with pytest.raises((RingError, BrokenPipeError)):
        for _ in range(100):
            producer.put([b"z" * 1000])


@pytest.mark.parametrize("first, second", [(100, 4000), (6, RING)])
def test_a_batch_that_must_start_over_at_the_rings_beginning_does_not_hang(local, first, second):
    """After a small batch has been read and acknowledged (the ring is empty), a batch that does not fit
    between its end and the ring's end (so starts over at 0), but fits in the ring, goes at once."""
    thread, got = consume_in_thread(local.consumer)
    local.producer.put([b"a" * first])
    select.select([local.ack_r], [], [], WATCHDOG_S)  # the first batch is acknowledged: the ring is empty
    put = in_thread(local.producer.put, [b"b" * second])
    put.join(0.5)
    stuck = put.is_alive()
    if stuck:
        # the consumer thread is waiting on the control pipe and will not write again: closing its ack
        # end wakes the producer (RingError in its thread), which frees the thread
        local.open.remove(local.ack_w)
        os.close(local.ack_w)
        put.join(WATCHDOG_S)
    local.close_producer()
    thread.join(WATCHDOG_S)
    assert not stuck, "put of a batch starting over at the ring's beginning waited forever"
    assert got == [[b"a" * first], [b"b" * second]]



def test_parts_of_any_item_format_arrive_as_their_bytes_and_close_is_idempotent(child):
    """A float64 memoryview and a numpy array go through the ring, and inline past it, as their raw
    bytes; closing the producer twice is harmless."""
    values = np.arange(6, dtype=np.float64)
    big = np.zeros(RING // 8 + 1)  # larger than the ring: inline
    producer = RingProducer(RING)
    consumer = child(producer)
    producer.put([memoryview(values), values])
    producer.put([big])
    assert consumer.finish() == [digest([values.tobytes(), values.tobytes()]), digest([big.tobytes()])]
    producer.close()
    producer.close()


@pytest.mark.parametrize("finishes", [True, False])
def test_hang_up_says_whether_the_consumer_finished(local, finishes):
    """hang_up closes the control pipe, then waits until the consumer closes its acknowledgement pipe;
    it returns True only when the consumer's last word was FINISHED (a recording's writer says so
    once its file is complete), False when the consumer just went away."""
    local.producer.put([b"x" * 100])

    def consume() -> None:
        for _ in local.consumer.batches():
            pass
        if finishes:
            local.open.remove(local.ack_w)  # finish() closes it
            local.consumer.finish()
        else:
            local.close_consumer()

    worker = in_thread(consume)
    assert local.producer.hang_up() is finishes
    local.open.remove(local.ack_r)  # hang_up closed it
    worker.join(WATCHDOG_S)
    assert worker.error is None and local.producer.ack_fd == -1 and local.producer.control_fd == -1
    local.producer_open = False
    local.producer.close()  # after hang_up: releases the mapping, safe to call again


def test_asked_to_stop_the_producer_stops_waiting_for_a_consumer_that_does_not_answer(local, monkeypatch):
    """With the ring full and the consumer silent: before any interrupt of this stream (one of the
    stream before is forgotten), put waits; once the producer is told of one (RingProducer.interrupted),
    it gives up when the consumer has not answered for STALL_S (RingStalled), and at once when told a
    second time. (A stopped writer held a Ctrl-C'd run however often it was interrupted.)"""
    import cosim.record.ring as ring

    monkeypatch.setattr(ring, "STALL_S", 0.3)
    monkeypatch.setattr(ring, "WAIT_SLICE_S", 0.05)
    local.producer.interrupted()  # a stream before this one was interrupted (a kept writer's last recording)
    local.producer.forget_interrupts()  # this stream is new: that interrupt is not its own
    local.producer.put([b"a" * 2000])
    local.producer.put([b"b" * 2000])
    put_c = in_thread(local.producer.put, [b"c" * 1000])
    put_c.join(0.5)
    assert put_c.is_alive()  # no interrupt of its own: it waits for the consumer (up to SILENT_S)
    local.producer.interrupted()
    put_c.join(WATCHDOG_S)
    assert not put_c.is_alive() and isinstance(put_c.error, ring.RingStalled)
    monkeypatch.setattr(ring, "STALL_S", WATCHDOG_S * 10)  # only the second interrupt can end the next wait
    local.producer.interrupted()
    put_d = in_thread(local.producer.put, [b"d" * 1000])
    put_d.join(WATCHDOG_S)
    assert not put_d.is_alive() and isinstance(put_d.error, ring.RingStalled)


# --- a consumer that is there but gets nowhere ------------------------------------------------------------


def fill_the_ring(producer: RingProducer) -> Worker:
    """Two batches that fill the ring, then a put that must wait for the consumer (in a thread)."""
    producer.put([b"a" * 2000])
    producer.put([b"b" * 2000])
    return in_thread(producer.put, [b"c" * 1000])


def test_a_consumer_that_makes_no_progress_is_given_up_on_unasked(local, monkeypatch):
    """With the ring full and the consumer silent (alive, but reading nothing; here its process is
    not known, so only an answer is progress), a put gives up once there has been no progress for
    SILENT_S, though nobody asked the producer to stop: RingStuck, saying so. (It waited for ever:
    a writer stopped, or stuck, held `cosim run` without a word.)"""
    import cosim.record.ring as ring

    monkeypatch.setattr(ring, "SILENT_S", 0.3)
    monkeypatch.setattr(ring, "WAIT_SLICE_S", 0.05)
    put_c = fill_the_ring(local.producer)
    put_c.join(WATCHDOG_S)
    assert not put_c.is_alive() and isinstance(put_c.error, ring.RingStuck)
    assert str(put_c.error) == "it has not answered for 0.3 s"


def test_a_consumer_whose_process_is_stopped_is_given_up_on(child, monkeypatch):
    """The consumer's process stopped (SIGSTOP) with the ring full: once found stopped for STOPPED_S
    the put gives up (RingStuck, saying so), however long SILENT_S is."""
    import signal

    import cosim.record.ring as ring

    monkeypatch.setattr(ring, "SILENT_S", WATCHDOG_S * 10)  # only the stopped process can end the wait
    monkeypatch.setattr(ring, "STOPPED_S", 0.3)
    monkeypatch.setattr(ring, "WAIT_SLICE_S", 0.05)
    producer = RingProducer(RING)
    consumer = child(producer)
    producer.consumer_pid = consumer.proc.pid
    os.kill(consumer.proc.pid, signal.SIGSTOP)  # before it can read anything: the third put must wait
    try:
        put_c = fill_the_ring(producer)
        put_c.join(WATCHDOG_S)
    finally:
        os.kill(consumer.proc.pid, signal.SIGCONT)
    assert not put_c.is_alive() and isinstance(put_c.error, ring.RingStuck)
    assert str(put_c.error) == "its process has been stopped for 0.3 s"


PIPE_FILLER = 1 << 20  # [bytes] a batch larger than the ring and than any pipe's buffer: its inline write must wait


def test_a_batch_larger_than_the_ring_gives_up_on_a_consumer_that_reads_nothing(local, monkeypatch):
    """A batch larger than the ring goes down the control pipe itself; with the consumer silent
    (reading nothing; its process not known) the write waits like a wait for room in the ring and gives
    up once there has been no progress for SILENT_S: RingStuck. (The write blocked for ever.)"""
    import cosim.record.ring as ring

    monkeypatch.setattr(ring, "SILENT_S", 0.3)
    monkeypatch.setattr(ring, "WAIT_SLICE_S", 0.05)
    put = in_thread(local.producer.put, [b"x" * PIPE_FILLER])
    put.join(WATCHDOG_S)
    assert not put.is_alive() and isinstance(put.error, ring.RingStuck)
    assert str(put.error) == "it has not answered for 0.3 s"


def test_a_batch_larger_than_the_ring_gives_up_on_a_stopped_consumer(child, monkeypatch):
    """The consumer's process stopped (SIGSTOP) while a batch larger than the ring goes down the
    pipe: found stopped for STOPPED_S, the put gives up (RingStuck), however long SILENT_S is; once
    asked to stop, it gives up after STALL_S without a read."""
    import signal

    import cosim.record.ring as ring

    monkeypatch.setattr(ring, "SILENT_S", WATCHDOG_S * 10)
    monkeypatch.setattr(ring, "STOPPED_S", 0.3)
    monkeypatch.setattr(ring, "WAIT_SLICE_S", 0.05)
    producer = RingProducer(RING)
    consumer = child(producer)
    producer.consumer_pid = consumer.proc.pid
    os.kill(consumer.proc.pid, signal.SIGSTOP)
    try:
        put = in_thread(producer.put, [b"x" * PIPE_FILLER])
        put.join(WATCHDOG_S)
    finally:
        os.kill(consumer.proc.pid, signal.SIGCONT)
    assert not put.is_alive() and isinstance(put.error, ring.RingStuck)
    assert str(put.error) == "its process has been stopped for 0.3 s"


def test_a_batch_larger_than_the_ring_stops_waiting_when_asked(local, monkeypatch):
    """Asked to stop (RingProducer.interrupted) while a batch larger than the ring waits on a full
    pipe: RingStalled once the consumer has read nothing for STALL_S."""
    import cosim.record.ring as ring

    monkeypatch.setattr(ring, "SILENT_S", WATCHDOG_S * 10)
    monkeypatch.setattr(ring, "STALL_S", 0.3)
    monkeypatch.setattr(ring, "WAIT_SLICE_S", 0.05)
    local.producer.interrupted()
    put = in_thread(local.producer.put, [b"x" * PIPE_FILLER])
    put.join(WATCHDOG_S)
    assert not put.is_alive() and isinstance(put.error, ring.RingStalled)


@pytest.mark.parametrize("busy", [False, True], ids=["answering-slowly", "working-without-a-word"])
def test_a_slow_consumer_is_waited_for_however_long_it_takes(child, monkeypatch, busy):
    """No progress, not time, ends a wait: a consumer answering every 50 ms keeps the producer
    waiting for it well past SILENT_S in all; one that works on a batch for longer than SILENT_S
    without a word uses CPU time all along, which counts as progress (its process known). Every
    batch arrives."""
    import cosim.record.ring as ring

    silent_s = 0.5
    monkeypatch.setattr(ring, "SILENT_S", silent_s)
    monkeypatch.setattr(ring, "WAIT_SLICE_S", 0.05)
    producer = RingProducer(RING)
    if busy:  # one batch worked on for three times SILENT_S, the ring full behind it
        consumer = child(producer, delay=3 * silent_s, busy=True)
        batches = [[b"a" * 3000], [b"b" * 3000]]
    else:  # forty batches, each waited for, three times SILENT_S in all
        consumer = child(producer, delay=3 * silent_s / 40)
        batches = [[bytes([i]) * 3000] for i in range(40)]
    producer.consumer_pid = consumer.proc.pid
    for batch in batches:
        producer.put(batch)
    assert consumer.finish() == [digest(batch) for batch in batches]
