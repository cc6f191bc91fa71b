"""The protobuf form of exchange messages (cosim.codec.proto_codec): exact round trips, a schema the
protobuf library itself reads, older schemas, the slow path, and telling it from JSON."""

from __future__ import annotations

import enum
import struct
from typing import Annotated

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from cosim.codec.json_codec import CodecError, codec_for
from cosim.codec.proto_codec import (
    ProtoError,
    is_protobuf_payload,
    layout_from_schema,
    proto_codec_for,
    schema_bytes,
    varint,
)
from cosim.codec.records import BYTES, HEADER, LENGTH
from cosim.messages import Array, Message, Quat, Vec3, first_difference, message

floats = st.floats(allow_nan=True, allow_infinity=True, width=64)


class Gear(enum.IntEnum):
    LOW = 0
    HIGH = 7


@message
class Numbers(Message):
    """Every field kind with a protobuf form: x [m], a step n, a flag, a gear, v (3,) [m/s], q (4,),
    a float grid (rows, cols) [m], int64 ids of free length, a fixed 2 x 2 matrix and a large fixed
    vector (32,)."""

    x: float
    n: int
    flag: bool
    gear: Gear
    v: Vec3
    q: Quat
    grid: Annotated[np.ndarray, Array("float64", (None, None))]
    ids: Annotated[np.ndarray, Array("int64", (None,))]
    m: Annotated[np.ndarray, Array("float64", (2, 2))]
    big: Annotated[np.ndarray, Array("float32", (32,))]


@message
class Labelled(Message):
    """A type with a str field: JSON only."""

    label: str
    x: float


numbers = st.builds(
    Numbers, x=floats, n=st.integers(-2**63, 2**63 - 1), flag=st.booleans(), gear=st.sampled_from(Gear),
    v=hnp.arrays(np.float64, 3, elements=floats), q=hnp.arrays(np.float64, 4, elements=floats),
    grid=hnp.arrays(np.float64, hnp.array_shapes(min_dims=2, max_dims=2, min_side=0, max_side=6), elements=floats),
    ids=hnp.arrays(np.int64, st.integers(0, 5)), m=hnp.arrays(np.float64, (2, 2), elements=floats),
    big=hnp.arrays(np.float32, 32, elements=st.floats(width=32, allow_nan=True)))


def example(**changes) -> Numbers:
    msg = Numbers(1.5, -3, True, Gear.HIGH, np.array([0.0, -0.0, 1e300]), np.array([1.0, 0, 0, 0]),
                  np.arange(6.0).reshape(2, 3), np.array([5, -6], dtype=np.int64), np.eye(2),
                  np.linspace(0, 1, 32, dtype=np.float32))
    return msg.replace(**changes)


@given(numbers)
def test_every_field_comes_back_bit_for_bit(msg):
    codec = proto_codec_for(Numbers)
    payload = codec.encode(msg)
    back = codec.decode(payload)
    assert first_difference(back, msg) is None
    assert codec.encode(back) == payload
    assert is_protobuf_payload(payload)


def test_nan_payloads_and_signed_zeros_survive():
    odd_nan = struct.unpack("<d", struct.pack("<Q", 0xFFF8_0000_0000_1234))[0]
    msg = example(x=odd_nan, v=np.array([-0.0, np.inf, -np.inf]), grid=np.array([[odd_nan, -0.0]]))
    back = proto_codec_for(Numbers).decode(proto_codec_for(Numbers).encode(msg))
    assert struct.pack("<d", back.x) == struct.pack("<d", odd_nan)
    assert back.v.tobytes() == msg.v.tobytes() and back.grid.tobytes() == msg.grid.tobytes()


def test_the_packed_record_is_a_bytes_record_of_the_payload():
    """``write`` puts a BYTES record (header, length, payload) whose payload is ``encode``'s."""
    codec = proto_codec_for(Numbers)
    msg = example()
    buf = memoryview(bytearray(4096))
    end = codec.write(msg, buf, 10, 7, 123)
    kind, channel, time_ns = HEADER.unpack_from(buf, 10)
    (n,) = LENGTH.unpack_from(buf, 10 + HEADER.size)
    start = 10 + HEADER.size + LENGTH.size
    assert (kind, channel, time_ns) == (BYTES, 7, 123) and end == start + n
    assert bytes(buf[start:end]) == codec.encode(msg)
    assert codec.write(msg, memoryview(bytearray(20)), 0, 7, 123) == -(end - 10)  # too small: the size needed


def test_the_slow_path_makes_fields_what_the_type_declares():
    """Lists, another float dtype, a transposed (not contiguous) grid and an int in a float field are
    refused by the packer and encoded alike by ``encode``."""
    codec = proto_codec_for(Numbers)
    want = codec.encode(example(grid=np.arange(6.0).reshape(2, 3).T.copy()))
    odd = example(x=1.5, v=[0.0, -0.0, 1e300], grid=np.arange(6.0).reshape(2, 3).T, ids=[5, -6])
    assert codec.write(odd, memoryview(b""), 0, 0, 0) == -1
    assert codec.encode(odd) == want
    assert codec.encode(example(grid=np.arange(6, dtype=np.float32).reshape(2, 3).T)) == want
    with pytest.raises(ProtoError):
        codec.encode(example(n=2**70))


@message
class Reading(Message):
    """One reading held as a 0-d array: value [m]."""

    value: Annotated[np.ndarray, Array("float64", ())]


@pytest.mark.parametrize("value", [np.array(1.5), 1.5, np.array(1.5, dtype=np.float32), np.float64(1.5)],
                         ids=["array", "float", "float32-array", "numpy-float"])
def test_a_0d_array_field_takes_a_scalar_as_json_does(value):
    """A 0-d array field given a Python scalar (or another float dtype) is made a 0-d array by the slow
    path, as JSON's encoder makes it (np.ascontiguousarray made it shape (1,), which the packer then
    refused: a ProtoError)."""
    codec = proto_codec_for(Reading)
    back = codec.decode(codec.encode(Reading(value)))
    assert back.value.shape == () and back.value.dtype == np.float64 and back.value == 1.5
    assert codec.encode(Reading(value)) == codec.encode(Reading(np.array(1.5)))
    assert codec_for(Reading).decode(codec_for(Reading).encode(Reading(value))).value.shape == ()


def test_the_protobuf_library_reads_the_schema_and_the_payloads():
    """The hand-written FileDescriptorSet is what protoc would describe: the protobuf library decodes
    the payload to the same numbers, and what it writes back decodes to the same message."""
    pytest.importorskip("google.protobuf")
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    codec = proto_codec_for(Numbers)
    files = descriptor_pb2.FileDescriptorSet.FromString(codec.schema_bytes())
    pool = descriptor_pool.DescriptorPool()
    for file in files.file:
        pool.Add(file)
    cls = message_factory.GetMessageClass(pool.FindMessageTypeByName("cosim.Numbers"))
    msg = example()
    parsed = cls.FromString(codec.encode(msg))
    assert parsed.x == 1.5 and parsed.n == -3 and parsed.flag and parsed.gear == 7
    assert list(parsed.grid) == list(range(6)) and list(parsed.grid_shape) == [2, 3]
    assert list(parsed.ids) == [5, -6] and list(parsed.m) == [1, 0, 0, 1]
    assert np.array_equal(np.array(parsed.big, dtype=np.float32), msg.big)
    assert first_difference(codec.decode(parsed.SerializeToString()), msg) is None


def test_a_recording_made_before_a_field_was_added_still_reads():
    """Decoded with the schema it was written with, a payload lacking a field that now has a
    default takes the default; one lacking a field without a default is an error."""

    @message
    class Old(Message):
        """x [m] and a grid."""

        x: float
        grid: Annotated[np.ndarray, Array("float64", (None, None))]

    @message
    class New(Message):
        """x [m], a grid, and a count added later."""

        x: float
        grid: Annotated[np.ndarray, Array("float64", (None, None))]
        count: int = 4

    old = proto_codec_for(Old)
    payload = old.encode(Old(2.0, np.ones((2, 2))))
    written_with = schema_bytes("New", old.layout)  # the type's schema when it had no count yet
    back = proto_codec_for(New).decoder(written_with)(payload)
    assert back.x == 2.0 and back.count == 4 and np.array_equal(back.grid, np.ones((2, 2)))

    @message
    class Newer(Message):
        """x [m], a grid and a required y [m]."""

        x: float
        grid: Annotated[np.ndarray, Array("float64", (None, None))]
        y: float

    with pytest.raises(ProtoError, match="lacks y"):
        proto_codec_for(Newer).decoder(schema_bytes("Newer", old.layout))(payload)


def test_the_schema_names_every_field_with_its_number():
    layout = proto_codec_for(Numbers).layout
    assert layout_from_schema(schema_bytes("Numbers", layout), "cosim.Numbers") == layout
    numbers = [f.number for f in layout.fields]
    assert numbers == list(range(1, len(numbers) + 1))
    with pytest.raises(ProtoError):
        layout_from_schema(schema_bytes("Numbers", layout), "cosim.Other")


def test_types_with_a_string_stay_json():
    assert proto_codec_for(Labelled) is None


def test_the_json_codec_reads_both_forms():
    """``MessageCodec.decode`` takes a JSON payload or a protobuf one; a damaged protobuf payload is
    a CodecError, as a damaged JSON one."""
    msg = example()
    json_codec = codec_for(Numbers)
    assert first_difference(json_codec.decode(json_codec.encode(msg)), msg) is None
    assert first_difference(json_codec.decode(proto_codec_for(Numbers).encode(msg)), msg) is None
    assert not is_protobuf_payload(json_codec.encode(msg)) and not is_protobuf_payload(b"")
    payload = proto_codec_for(Numbers).encode(msg)
    for damaged in (payload[:-3], payload[:1] + b"\xff" * 12):
        with pytest.raises(CodecError):
            json_codec.decode(damaged)


def test_varints():
    assert [varint(n) for n in (0, 1, 127, 128, 300)] == [b"\x00", b"\x01", b"\x7f", b"\x80\x01", b"\xac\x02"]
