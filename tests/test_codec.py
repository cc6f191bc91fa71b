"""The message codec: every type round-trips bit for bit, schemas describe payloads, bad bytes fail."""

from __future__ import annotations

import base64
import enum
import json
import math
import pickle
from typing import Annotated

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from cosim.codec.json_codec import CodecError, codec_for, decode_state, encode_state, plain_state
from cosim.messages import Array, Message, Vec3, first_difference, message

floats = st.floats(allow_nan=True, allow_infinity=True, width=64)


class Mode(enum.IntEnum):
    OFF = 0
    ON = 1


@message
class Everything(Message):
    """One field of each kind."""

    x: float
    n: int
    flag: bool
    name: str
    mode: Mode
    v: Vec3
    grid: Annotated[np.ndarray, Array("float64", (None, None))]
    ids: Annotated[np.ndarray, Array("int32", (4,))]


def same(a: Message, b: Message) -> bool:
    return first_difference(a, b) is None


everything = st.builds(
    Everything, x=floats, n=st.integers(-2**62, 2**62), flag=st.booleans(), name=st.text(),
    mode=st.sampled_from(Mode), v=hnp.arrays(np.float64, 3, elements=floats),
    grid=hnp.arrays(np.float64, hnp.array_shapes(min_dims=2, max_dims=2, min_side=0, max_side=5), elements=floats),
    ids=hnp.arrays(np.int32, 4))
"""Messages with any value of every field kind, NaN and infinities included."""


@given(everything)
def test_round_trip_is_bit_exact(msg):
    """Any value of every field kind, NaN and infinities included, comes back bit for bit."""
    codec = codec_for(Everything)
    back = codec.decode(codec.encode(msg))
    assert same(msg, back)
    assert isinstance(back.mode, Mode)


def test_small_fixed_arrays_are_plottable_lists_and_large_ones_base64():
    """A Vec3 is written as a JSON list (plottable in Foxglove); a free-shape grid as base64 bytes."""
    msg = Everything(1.5, 2, True, "a", Mode.ON, np.array([0.1, -0.0, 3.0]), np.zeros((2, 3)),
                     np.arange(4, dtype=np.int32))
    data = json.loads(codec_for(Everything).encode(msg))
    assert data["v"] == [0.1, -0.0, 3.0]
    assert set(data["grid"]) == {"dtype", "shape", "base64"} and data["grid"]["shape"] == [2, 3]
    assert data["mode"] == 1


def test_schema_names_and_describes_fields():
    """The JSON schema is named cosim.<Type>, lists every field as required, and documents enums."""
    schema = codec_for(Everything).schema()
    assert schema["title"] == "cosim.Everything"
    assert schema["required"] == ["x", "n", "flag", "name", "mode", "v", "grid", "ids"]
    assert schema["properties"]["v"]["minItems"] == 3
    assert schema["properties"]["mode"]["description"] == "0=off, 1=on"


@pytest.mark.parametrize("payload, pattern", [
    (b"{", r"not valid JSON"),
    (b"[]", r"expected an object"),
    (b'{"x": 1}', r"missing n, flag"),
    (b'{"x":"fast","n":1,"flag":true,"name":"","mode":0,"v":[1,2,3],'
     b'"grid":{"dtype":"<f8","shape":[0,0],"base64":""},"ids":[1,2,3,4]}', r"expected a number, got string 'fast'"),
    (b'{"x":1,"n":1,"flag":true,"name":"","mode":7,"v":[1,2,3],'
     b'"grid":{"dtype":"<f8","shape":[0,0],"base64":""},"ids":[1,2,3,4]}', r"7 is not a Mode"),
    (b'{"x":1,"n":1,"flag":true,"name":"","mode":0,"v":[1,2],'
     b'"grid":{"dtype":"<f8","shape":[0,0],"base64":""},"ids":[1,2,3,4]}',
     r"field 'v': shape \(2,\) does not match \(3,\)"),
])
def test_bad_payloads_raise_codec_error(payload, pattern):
    """Malformed payloads are rejected with a message naming what is wrong."""
    with pytest.raises(CodecError, match=pattern):
        codec_for(Everything).decode(payload)


def test_encode_rejects_wrong_shape():
    """Encoding a message whose array has the wrong shape fails instead of writing bad data."""
    msg = Everything(1.0, 1, True, "", Mode.OFF, np.zeros(4), np.zeros((1, 1)), np.zeros(4, np.int32))
    with pytest.raises(CodecError, match=r"field 'v': shape \(4,\) does not match \(3,\)"):
        codec_for(Everything).encode(msg)


def test_every_physics_message_type_round_trips():
    """Each message type of the components package round-trips a representative value exactly."""
    import components.messages as cm

    rng = np.random.default_rng(1)
    types = [t for t in vars(cm).values() if isinstance(t, type) and issubclass(t, Message) and t is not Message]
    assert len(types) >= 10
    for t in types:
        codec = codec_for(t)
        values = {}
        for spec in codec.fields:
            kind = spec.kind.value
            if kind == "float":
                values[spec.name] = float(rng.normal())
            elif kind == "int":
                values[spec.name] = int(rng.integers(-5, 5))
            elif kind == "bool":
                values[spec.name] = True
            elif kind == "str":
                values[spec.name] = "label"
            elif kind == "enum":
                values[spec.name] = list(spec.enum_type)[-1]
            else:
                shape = tuple(d if d is not None else 3 for d in spec.array.shape)
                values[spec.name] = rng.normal(size=shape).astype(spec.array.dtype)
        msg = t(**values)
        assert same(msg, codec.decode(codec.encode(msg))), t.__name__


@given(st.recursive(
    st.none() | st.booleans() | st.integers(-2**53, 2**53) | floats | st.text(max_size=5),
    lambda children: st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=3), children, max_size=3),
    max_leaves=10))
def test_state_round_trip(value):
    """Plain state data (including NaN, infinities and strings that read 'nan') round-trips."""
    back = decode_state(encode_state(value))
    assert json.dumps(back, sort_keys=True, default=str) == json.dumps(value, sort_keys=True, default=str) or (
        isinstance(value, float) and math.isnan(value) and math.isnan(back))


@given(st.recursive(
    st.none() | st.booleans() | st.integers(-2**70, 2**70) | floats | st.text(max_size=5)
    | hnp.arrays(st.sampled_from([np.float64, np.int32, np.bool_]),
                 hnp.array_shapes(max_dims=2, min_side=0, max_side=3)),
    lambda children: st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=3), children, max_size=3),
    max_leaves=10))
def test_state_text_is_json_dumps_of_the_state_with_base64_arrays(value):
    """The checkpoint text, written in pieces, is byte for byte ``json.dumps`` of the plain state
    with every array's bytes as a base64 string."""
    plain = plain_state(value)

    def with_base64(v):
        if isinstance(v, pickle.PickleBuffer):
            return base64.b64encode(v.raw()).decode()
        if isinstance(v, dict):
            return {k: with_base64(x) for k, x in v.items()}
        if isinstance(v, list):
            return [with_base64(x) for x in v]
        return v

    assert encode_state(value) == json.dumps(with_base64(plain), separators=(",", ":"), allow_nan=False).encode()


def test_state_arrays_round_trip():
    """numpy arrays in state come back with their dtype, shape and bits."""
    state = {"h": np.linspace(0, 1, 12).reshape(3, 4), "n": np.arange(3, dtype=np.int64), "s": "nan"}
    back = decode_state(encode_state(state))
    assert back["h"].tobytes() == state["h"].tobytes() and back["h"].shape == (3, 4)
    assert back["n"].dtype == np.int64 and back["s"] == "nan"


@given(everything)
def test_generated_encoder_writes_exactly_what_json_dumps_writes(msg):
    """The generated fast encoder's bytes equal those of json.dumps over the field dict."""
    codec = codec_for(Everything)
    assert codec.encode(msg) == codec._slow_encode(msg)


@pytest.mark.parametrize("n", [2**70, -2**63 - 1])
def test_an_int_beyond_64_bits_is_encoded_the_slow_way(n):
    """An int field beyond 64 bits cannot be packed into a record (refused while packing, after the
    size check); encode then writes it the slow way, exactly, rather than a half-packed record."""
    msg = Everything(1.0, n, True, "a", Mode.ON, np.zeros(3), np.zeros((1, 1)), np.arange(4, dtype=np.int32))
    codec = codec_for(Everything)
    assert codec.write(msg, memoryview(bytearray(4096)), 0, 0, 0) == -1
    assert codec.encode(msg) == codec._slow_encode(msg)
    assert json.loads(codec.encode(msg))["n"] == n


def test_a_field_with_a_default_may_be_left_out_and_a_required_one_may_not():
    """A message written before a field with a default was added still decodes (the field takes
    its default); leaving out a field without a default is still an error naming it."""
    from components.messages import OccupiedHeight, SkipRecord
    from cosim.codec.json_codec import CodecError, codec_for

    codec = codec_for(OccupiedHeight)
    msg = codec.from_dict({"i0": 1, "j0": 2, "b": []})
    assert msg.i0 == 1 and msg.already_displaced is False
    old_skip = {"index": 1, "touchdown_time": 0.07, "touchdown_x": 0.9, "contact_time": 0.03,
                "takeoff_angle_deg": 9.7, "distance": 0.6, "speed_in": 8.2, "speed_out": 6.6}
    assert codec_for(SkipRecord).from_dict(old_skip).drift == 0.0
    with pytest.raises(CodecError, match="missing j0"):
        codec.from_dict({"i0": 1, "b": []})
