"""The record stage: records gathered into batches of bounded count and size, in the order added, a record
that does not fit starting the next batch, one larger than the stage sent alone, a refused message left out."""

from __future__ import annotations

import dataclasses
import pickle
from typing import Annotated

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cosim.codec.json_codec import codec_for, plain_state
from cosim.codec.jsontext import renderer, state_text
from cosim.codec.records import BYTES, HEADER, LENGTH, MESSAGE, OTHER, OTHER_HEAD, Stage, read_other
from cosim.messages import Array, Message, message
from tests.test_codec import Everything, Mode, everything


@message
class Blob(Message):
    """A step k and a free-length payload, so that a record has the size a test wants (29 + 8 n bytes)."""

    k: int
    data: Annotated[np.ndarray, Array("float64", (None,))]


CODECS = {1: codec_for(Everything), 2: codec_for(Blob)}  # channel -> the codec of the messages sent on it
RENDER = {channel: renderer(codec.layout) for channel, codec in CODECS.items()}


def blob(n: int, k: int = 0, time_ns: int = 0) -> tuple:
    return (MESSAGE, 2, time_ns, Blob(k, np.linspace(-1.0, 1.0, n) * k))


def thing(grid: tuple[int, int], x: float = 1.5, time_ns: int = 0) -> tuple:
    msg = Everything(x, -7, True, 'a "b" é', Mode.ON, np.array([0.1, -0.0, np.inf]),
                     np.arange(grid[0] * grid[1], dtype=np.float64).reshape(grid) / 3, np.arange(4, dtype=np.int32))
    return (MESSAGE, 1, time_ns, msg)


def size_of(op: tuple) -> int:
    kind, channel, time_ns, value = op
    if kind == MESSAGE:
        return -CODECS[channel].write(value, memoryview(b""), 0, channel, time_ns)
    if kind == BYTES:
        return HEADER.size + LENGTH.size + len(value)
    return HEADER.size + LENGTH.size + OTHER_HEAD.size + len(pickle.dumps(value, protocol=5))


def add(stage: Stage, op: tuple) -> None:
    kind, channel, time_ns, value = op
    if kind == MESSAGE:
        assert stage.add_message(CODECS[channel].write, channel, time_ns, value)
    elif kind == BYTES:
        stage.add_bytes(BYTES, channel, time_ns, value)
    else:
        stage.add_other(value)


def expected(op: tuple) -> tuple:
    kind, channel, time_ns, value = op
    return (kind, channel, time_ns, CODECS[channel].encode(value) if kind == MESSAGE else value)


def parse(batch: bytes) -> list[tuple]:
    """The records of one batch as (kind, channel, time, JSON bytes | bytes | unpickled tuple)."""
    records, at = [], 0
    while at < len(batch):
        kind, channel, time_ns = HEADER.unpack_from(batch, at)
        at += HEADER.size
        if kind == MESSAGE:
            body, at = RENDER[channel](batch, at)
        else:
            assert kind in (BYTES, OTHER)
            (n,) = LENGTH.unpack_from(batch, at)
            at += LENGTH.size
            body, at = batch[at:at + n], at + n
            body = read_other(memoryview(body)) if kind == OTHER else body
        records.append((kind, channel, time_ns, body))
    assert at == len(batch)
    return records


def staged(size: int, batch: int) -> tuple[Stage, list[bytes]]:
    batches: list[bytes] = []
    return Stage(size, batch, lambda view: batches.append(bytes(view))), batches


def test_batches_are_bounded_in_count_and_size_and_parse_back_in_order():
    """Many messages give batches of at most 5 records and at most the stage's size, cut for both reasons;
    parsed in order they give back every record, each message rendering to exactly its codec's bytes."""
    stage, batches = staged(1000, 5)
    rng = np.random.default_rng(3)
    ops = [thing((int(rng.integers(0, 7)), int(rng.integers(0, 7))), x=[np.nan, 2.5, -np.inf][i % 3],
                 time_ns=int(rng.integers(-2**63, 2**63))) for i in range(60)]
    for op in ops:
        add(stage, op)
    stage.flush()
    counts = [len(parse(b)) for b in batches]
    assert max(counts) == 5 and min(counts[:-1]) < 5  # some cut by count, some by size
    assert all(0 < len(b) <= 1000 for b in batches)
    assert [r for b in batches for r in parse(b)] == [expected(op) for op in ops]


@pytest.mark.parametrize("make", [lambda n: blob((n - 29) // 8, k=n), lambda n: (BYTES, 9, n, bytes(n - 21))],
                         ids=["message", "bytes"])
def test_a_record_that_does_not_fit_starts_the_next_batch_and_a_larger_one_goes_alone(make):
    """A record that does not fit in the space left flushes the batch and starts the next one; a record that
    just fills it completes the batch, sent at once; one larger than the stage is sent alone, in a batch of
    exactly its size, after those before it."""
    first, second, third, huge, after = make(605), make(605), make(397), make(2501), make(101)
    stage, batches = staged(1002, 10)
    add(stage, first)
    add(stage, second)
    assert [parse(b) for b in batches] == [[expected(first)]]
    assert (stage.offset, stage.count) == (size_of(second), 1)
    add(stage, third)  # 605 + 397 = 1002: exactly full, sent
    assert len(batches) == 2 and stage.offset == 0
    add(stage, huge)
    assert [len(b) for b in batches] == [605, 1002, 2501] and size_of(huge) == 2501
    assert [parse(b) for b in batches[1:]] == [[expected(second), expected(third)], [expected(huge)]]
    assert (stage.offset, stage.count) == (0, 0)
    add(stage, after)
    stage.flush()
    assert [parse(b) for b in batches[3:]] == [[expected(after)]]


@pytest.mark.parametrize("bad", [
    {"grid": np.zeros((2, 2), np.float32)}, {"grid": [[1.0, 2.0]]}, {"grid": np.zeros((300, 300), np.float32)},
    {"v": [1.0, 2.0, 3.0]}, {"v": np.zeros(4)}, {"ids": [1, 2, 3, 4]}, {"n": 2**70}])
def test_a_refused_message_leaves_the_stage_as_it_was(bad):
    """A message its codec refuses (wrong dtype, a list for an array, a wrong shape, an int beyond 64 bits) makes
    add_message return False, sends nothing, and leaves offset and count as they were."""
    stage, batches = staged(4000, 5)
    ops = [thing((2, 2)), (BYTES, 3, 4, b"abc")]
    for op in ops:
        add(stage, op)
    state = (stage.offset, stage.count)
    refused = dataclasses.replace(ops[0][3], **bad)
    assert stage.add_message(CODECS[1].write, 1, 5, refused) is False
    assert (stage.offset, stage.count) == state and batches == []
    stage.flush()
    assert [parse(b) for b in batches] == [[expected(op) for op in ops]]


def test_a_message_refused_only_when_packed_is_refused_when_it_does_not_fit():
    """A message refused while packing (an int beyond 64 bits) is refused too when it does not fit in the space
    left: add_message returns False and the stage keeps its records, with nothing sent."""
    ok = thing((0, 0))
    stage, batches = staged(size_of(ok) + 10, 5)
    add(stage, ok)
    assert stage.add_message(CODECS[1].write, 1, 5, dataclasses.replace(ok[3], n=2**70)) is False
    assert (stage.offset, stage.count, batches) == (size_of(ok), 1, [])


def test_bytes_others_and_messages_keep_their_order_and_flush_resets():
    """BYTES records (empty, or of any bytes-like), OTHER records and messages come back in the order added;
    flush on an empty stage sends nothing, and flush leaves offset and count at zero."""
    stage, batches = staged(4096, 100)
    stage.flush()
    assert batches == []
    ops = [(OTHER, 0, 0, ("schema", 1, "cosim.Blob", b"{}")), blob(3, k=1, time_ns=10), (BYTES, 7, 11, b""),
           thing((1, 2), time_ns=12), (BYTES, 2**32 - 1, -1, b"\x00\xff"), (OTHER, 0, 0, ("checkpoint", 1.5, None)),
           blob(0, k=2, time_ns=-(2**63))]
    for op in ops:
        add(stage, op)
    stage.add_bytes(BYTES, 4, 13, np.arange(3.0))
    assert batches == [] and stage.count == len(ops) + 1
    stage.flush()
    assert (stage.offset, stage.count) == (0, 0)
    assert parse(batches[0]) == [expected(op) for op in ops] + [(BYTES, 4, 13, np.arange(3.0).tobytes())]
    stage.flush()  # empty again: nothing sent
    assert len(batches) == 1
    add(stage, blob(1, k=3))
    stage.flush()
    assert [parse(b) for b in batches[1:]] == [[expected(blob(1, k=3))]]


times = st.integers(-2**63, 2**63 - 1)
operations = st.one_of(
    st.builds(blob, st.integers(0, 300), st.integers(-2**62, 2**62), times),
    st.builds(lambda msg, t: (MESSAGE, 1, t, msg), everything, times),
    st.tuples(st.just(BYTES), st.integers(0, 2**32 - 1), times, st.binary(max_size=2500)),
    st.builds(lambda r: (OTHER, 0, 0, r), st.tuples(st.text(max_size=8), st.integers(), st.none())))


@settings(max_examples=200, deadline=None)
@given(st.lists(operations, max_size=40), st.integers(1, 2000), st.integers(1, 8))
def test_any_operations_come_back_in_order(ops, size, batch):
    """Any sequence of messages, byte strings (empty too) and other records, with any stage size and batch
    count, parses back to the same sequence; a batch holds at most `batch` records and the stage's size, or a
    single record larger than the stage."""
    stage, batches = staged(size, batch)
    for op in ops:
        add(stage, op)
    stage.flush()
    assert (stage.offset, stage.count) == (0, 0)
    parsed = [parse(b) for b in batches]
    for b, records in zip(batches, parsed, strict=True):
        assert 1 <= len(records) <= batch
        assert len(b) <= size or len(records) == 1
    assert [r for records in parsed for r in records] == [expected(op) for op in ops]


@settings(max_examples=100, deadline=None)
@given(st.lists(operations, max_size=40), st.integers(1, 2000), st.integers(1, 8), st.sampled_from([0, 3000]))
def test_a_stage_gathering_in_fresh_buffers_sends_the_same_batches(ops, size, batch, fresh_max):
    """A stage given a fresh buffer after each batch (as a ring's free space) sends exactly the
    batches of one with its own buffer, asks for a buffer only when a record comes, and sends each
    batch from the buffer it was given (a record larger than the stage from one of its own, or, a
    byte string or other record up to ``fresh_max`` bytes, from a fresh buffer of its exact size)."""
    fixed, want = staged(size, batch)
    given_out: list[memoryview] = []
    got: list[bytes] = []

    def fresh(n: int) -> memoryview:
        assert (n == size or size < n <= fresh_max) and (not given_out or given_out[-1] is None)
        given_out.append(memoryview(bytearray(n)))
        return given_out[-1]

    from_given = []

    def send(view: memoryview) -> None:
        if given_out and given_out[-1] is not None and view.obj is given_out[-1].obj:
            given_out.append(None)  # that buffer is spent
            from_given.append(view.nbytes)
            if view.nbytes > size:  # a large record in a buffer of its own size: all of it
                assert view.nbytes <= fresh_max and view.nbytes == len(view.obj)
        else:
            assert view.nbytes > size
        got.append(bytes(view))

    ringed = Stage(size, batch, send, fresh=fresh, fresh_max=fresh_max)
    for op in ops:
        add(fixed, op)
        add(ringed, op)
    fixed.flush()
    ringed.flush()
    assert got == want
    assert len([b for b in given_out if b is not None]) == len(from_given)
    assert len([n for n in from_given if n <= size]) == len([b for b in got if len(b) <= size])


def test_a_batch_is_sent_once_it_holds_batch_bytes_and_larger_records_still_fit_the_stage():
    """With batch_bytes below the stage's size, a batch goes as soon as it holds that many bytes, and a
    record larger than batch_bytes (but not than the stage) is gathered in the stage like any other."""
    batches: list[bytes] = []
    stage = Stage(10_000, 100, lambda view: batches.append(bytes(view)), batch_bytes=1000)
    small, large = blob(50), blob(500)  # 429 and 4029 bytes
    add(stage, small)
    add(stage, small)
    assert batches == [] and stage.offset == 2 * size_of(small)
    add(stage, small)  # 1287 bytes >= 1000: sent
    add(stage, large)  # alone past batch_bytes: sent at once, from the stage
    assert [len(b) for b in batches] == [3 * size_of(small), size_of(large)]
    assert [r for b in batches for r in parse(b)] == [expected(op) for op in (small, small, small, large)]


def test_a_checkpoints_arrays_go_out_of_band_and_come_back_as_their_bytes():
    """An OTHER record of plain state carries the arrays' bytes after the pickle, not inside it; read back
    (views into the batch), the state writes the same JSON text as the state itself."""
    state = {"h": np.linspace(0, 1, 300).reshape(20, 15), "v": np.arange(7, dtype=np.int32)[::2], "k": 3}
    record = ("state", 4, 10, plain_state(state))
    stage, batches = staged(100_000, 10)
    stage.add_other(record)
    stage.flush()
    ((kind, channel, time_ns, back),) = parse(batches[0])
    assert (kind, channel, time_ns) == (OTHER, 0, 0)
    assert back[:3] == ("state", 4, 10) and isinstance(back[3]["h"]["base64"], memoryview)
    assert len(batches[0]) < 300 * 8 + 4 * 4 + 400  # each array's bytes once, the pickle small
    assert state_text(back[3]) == state_text(plain_state(state))
