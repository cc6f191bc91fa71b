"""Checkpoints as protobuf (cosim.codec.state_proto): the same state as the JSON form, bit for bit,
readable by any protobuf reader from the recording's own schema, and JSON checkpoints of older
recordings still read; what a checkpoint cannot give back as it was is refused, naming where it is."""

import math
import pickle
import re

import hypothesis.extra.numpy as hnp
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from cosim.codec.json_codec import decode_state, encode_state, plain_state
from cosim.codec.state_proto import SCHEMA, SCHEMA_NAME, decode_checkpoint, state_bytes

floats = st.floats(allow_nan=True, allow_infinity=True) | st.sampled_from([-0.0, 5e-324, 1.7976931348623157e308])
states = st.recursive(
    st.none() | st.booleans() | st.integers(-2**70, 2**70) | floats | st.text(max_size=5)
    | hnp.arrays(st.sampled_from([np.float64, np.float32, np.int64, np.int32, np.bool_]),
                 hnp.array_shapes(min_dims=0, max_dims=3, min_side=0, max_side=3)),
    lambda children: st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=3), children, max_size=3),
    max_leaves=12)


def same(a, b) -> bool:
    """Equal bit for bit: arrays by dtype, shape and bytes; floats by their bits."""
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
    if isinstance(a, dict):
        return isinstance(b, dict) and list(a) == list(b) and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(map(same, a, b))
    if isinstance(a, float):
        return isinstance(b, float) and np.float64(a).tobytes() == np.float64(b).tobytes()
    return type(a) is type(b) and a == b


@given(states)
def test_a_checkpoint_reads_back_as_the_json_form_does(value):
    """Whatever plain state holds (NaN payloads, -0.0, ints beyond 64 bits, empty and 0-d arrays,
    strings reading 'nan'), the protobuf form gives back exactly what the JSON form gives."""
    assert same(decode_checkpoint(state_bytes(plain_state(value))), decode_state(encode_state(value)))


def test_an_array_goes_out_as_its_raw_bytes():
    """A 1 MB array makes a checkpoint of 1 MB and a few bytes (base64 text would be 4/3 of it),
    whichever buffer type holds it when it is written (the writer process gets memoryviews)."""
    h = np.random.default_rng(1).normal(size=(500, 250))
    plain = plain_state({"pond": {"h": h, "steps": 3}})
    data = state_bytes(plain)
    assert h.nbytes < len(data) < h.nbytes + 100
    assert h.tobytes() in data
    buffers: list = []
    out_of_band = pickle.dumps(plain, protocol=5, buffer_callback=lambda b: buffers.append(b.raw()))
    in_ring = pickle.loads(out_of_band, buffers=[memoryview(bytearray(b)) for b in buffers])  # as the writer reads it
    assert state_bytes(in_ring) == data
    assert state_bytes(pickle.loads(pickle.dumps(plain, protocol=5))) == data  # in band: bytes
    back = decode_checkpoint(data)["pond"]["h"]
    assert back.tobytes() == h.tobytes() and back.flags.writeable


def test_the_schema_decodes_a_checkpoint_in_a_protobuf_reader():
    """The recording's schema is a FileDescriptorSet any protobuf reader builds the message from: it
    parses a checkpoint and writes it back byte for byte."""
    pytest.importorskip("google.protobuf")
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    pool = descriptor_pool.DescriptorPool()
    for file in descriptor_pb2.FileDescriptorSet.FromString(SCHEMA).file:
        pool.Add(file)
    checkpoint = message_factory.GetMessageClass(pool.FindMessageTypeByName(SCHEMA_NAME))
    state = {"pond": {"h": np.arange(6.0).reshape(2, 3), "steps": -4, "model": {"c": 0.5, "on": True}},
             "stone": [1.5, None, "label", 2**70, math.inf]}
    data = state_bytes(plain_state(state))
    parsed = checkpoint.FromString(data)
    assert parsed.SerializeToString() == data
    pond = {e.key: e.value for e in parsed.state.map.entries}["pond"]
    h = {e.key: e.value for e in pond.map.entries}["h"].array
    assert (h.dtype, list(h.shape), h.data) == ("<f8", [2, 3], state["pond"]["h"].tobytes())
    assert parsed.state.map.entries[1].value.list.items[3].big_integer == str(2**70)


@pytest.mark.parametrize("payload", [b"", b"\x0a\x02\x08\x01", b"\x0a\x03\x0d\x00\x00", b"{\"a\": 1}",
                                     b"\x0a\x04\x3a\x02\x0a\x00", b"\x0a\x05\x3a\x03\x0a\x01\x0a"])
def test_what_is_not_a_checkpoint_is_refused(payload):
    with pytest.raises(ValueError):
        decode_checkpoint(payload)


def test_json_checkpoints_of_an_older_recording_still_read(tmp_path, monkeypatch):
    """A recording made before checkpoints were protobuf holds them as JSON (message encoding
    ``json``): they read back as they were written, and a recording now holds them as protobuf."""
    from pathlib import Path

    from cosim.record import recorder as rec
    from cosim.record.reader import Recording
    from cosim.runner import run_scene
    from cosim.scenario import load

    scene_file = Path(__file__).resolve().parents[1] / "scenarios" / "ping_pong.yaml"
    run_scene(load(scene_file, overrides=["until=2.0"]), tmp_path / "new.mcap", progress=False)

    def json_checkpoint(self, sim):  # the recorder as it was
        channel = self._channel(rec.CHECKPOINT_TOPIC, "cosim.Checkpoint", "jsonschema",
                                b'{"title": "cosim.Checkpoint", "type": "object"}', "json")
        self.sink.add_message(channel, sim.time_ns, encode_state(sim.checkpoint()))

    monkeypatch.setattr(rec.Recorder, "write_checkpoint", json_checkpoint)
    run_scene(load(scene_file, overrides=["until=2.0"]), tmp_path / "old.mcap", progress=False)

    old, new = Recording(tmp_path / "old.mcap"), Recording(tmp_path / "new.mcap")
    assert old.channels[rec.CHECKPOINT_TOPIC].message_encoding == "json"
    assert new.channels[rec.CHECKPOINT_TOPIC].message_encoding == "protobuf"
    assert [t for t, _ in old.checkpoints()] == [t for t, _ in new.checkpoints()] == [0, 10**9, 2 * 10**9]
    assert all(same(a, b) for (_, a), (_, b) in zip(old.checkpoints(), new.checkpoints(), strict=True))


class Count(int):
    """An int subclass, as a library may hand one over."""


def test_text_and_int_subclasses_are_written_as_plain_text_and_ints():
    """A ``np.str_`` (a value or a key) and an int subclass are written as the str and int they are:
    the protobuf writer takes exact types only, and a ``np.str_`` in a state failed the recording's
    writer, so that the whole recording was lost."""
    state = {"label": np.str_("hello"), np.str_("count"): Count(3), "big": Count(2**70)}
    plain = plain_state(state)
    assert [type(k) for k in plain] == [str, str, str] and type(plain["label"]) is str
    assert type(plain["count"]) is int and type(plain["big"]) is int
    back = decode_checkpoint(state_bytes(plain))
    assert back == {"label": "hello", "count": 3, "big": 2**70}
    assert same(back, decode_state(encode_state(state)))


@pytest.mark.parametrize(("state", "where"), [
    ({"state": {"label": "file\udcff.dat"}}, r"state\.label: text 'file\\udcff\.dat'"),
    ({"state": {"files": ["a", ["b", "\ud800"]]}}, r"state\.files\[1\]\[1\]: text '\\ud800'"),
    ({"state": {"a b": {"x\udcff": 1.0}}}, r"state\['a b'\]: key 'x\\udcff'"),
], ids=["value", "in-a-list", "key"])
def test_text_holding_a_lone_surrogate_is_refused_naming_where_it_is(state, where):
    """A lone surrogate (a file name's byte that is not UTF-8) has no UTF-8 form, which a protobuf
    checkpoint's text must have (any protobuf reader refuses it): refused, naming its key path, in
    the JSON form as well so the two agree (it failed the writer and lost the recording)."""
    for encode in (plain_state, encode_state):
        with pytest.raises(TypeError, match=where + r".* holds the lone surrogate '\\ud[89a-f][0-9a-f]{2}': a "
                                            r"checkpoint's text must be valid UTF-8"):
            encode(state)


@pytest.mark.parametrize("array", [
    np.array([1.5, "a", None], dtype=object),
    np.array(["2020-01-01"], dtype="datetime64[D]"),
    np.array([3], dtype="timedelta64[s]"),
    np.zeros(2, dtype=[("a", "<f8"), ("b", "<i4")]),
    np.zeros(2, dtype="V4"),
], ids=["object", "datetime64", "timedelta64", "structured", "void"])
def test_an_array_whose_bytes_are_not_its_values_is_refused(array):
    """An object array's bytes are pointers (they were recorded as such), a datetime64 array has no
    buffer (an internal error), a structured one came back as void bytes: each is refused as not
    plain data (a TypeError, which the recorder says as the component's failure), naming where."""
    with pytest.raises(TypeError, match=rf"^state\.s\[0\]: an array of dtype {re.escape(str(array.dtype))} is not "
                                        r"plain data \(a checkpoint holds arrays of booleans, numbers, or bytes or "
                                        r"text of fixed size\)$"):
        plain_state({"state": {"s": [array]}})


@pytest.mark.parametrize("array", [
    np.array(["ab", "c"]), np.array([b"ab", b""]), np.array([1 + 2j], dtype=np.complex64),
    np.array([1.5, -2.0], dtype=np.float16), np.arange(4, dtype=">i4"), np.array([True, False]),
], ids=["str", "bytes", "complex", "float16", "big-endian", "bool"])
def test_arrays_of_numbers_and_fixed_size_text_read_back_in_both_forms(array):
    """Every dtype kind a checkpoint holds comes back with its values, shape and (little-endian)
    dtype, alike from the protobuf and the JSON form."""
    back = decode_checkpoint(state_bytes(plain_state({"a": array})))["a"]
    assert back.dtype == array.dtype.newbyteorder("<") and back.shape == array.shape and (back == array).all()
    assert same(back, decode_state(encode_state({"a": array}))["a"])


def test_a_0d_array_keeps_its_shape_and_a_strided_one_its_values():
    """A 0-d array comes back 0-d (np.ascontiguousarray made it shape (1,)); a transposed or strided
    one comes back C-ordered with its values."""
    grid = np.arange(12.0).reshape(3, 4)
    state = {"acc": np.array(2.5), "flag": np.array(True), "t": grid.T, "every_other": grid[:, ::2]}
    for back in (decode_checkpoint(state_bytes(plain_state(state))), decode_state(encode_state(state))):
        assert back["acc"].shape == () and back["acc"] == 2.5
        assert back["flag"].shape == () and back["flag"].dtype == np.bool_
        assert back["t"].tobytes() == np.ascontiguousarray(grid.T).tobytes() and back["t"].shape == (4, 3)
        assert back["every_other"].tolist() == grid[:, ::2].tolist()


@pytest.mark.parametrize(("state", "said"), [
    ({"hist": {1: 2.0, "1": 3.0}}, r"^hist: key 1 \(int\) is not a string"),
    ({"hist": [{(0, 1): 2.0}]}, r"^hist\[0\]: key \(0, 1\) \(tuple\) is not a string"),
    ({None: 1}, r"^key None \(NoneType\) is not a string"),
], ids=["int", "tuple", "none"])
def test_a_key_that_is_not_a_string_is_refused(state, said):
    """Keys are written as text: an int key came back a string, and {1: a, "1": b} as one key, the
    other value dropped without a word. Refused, naming where (no component of the project keys its
    state by anything but strings)."""
    with pytest.raises(TypeError, match=said + r": a checkpoint's keys are strings \(written as text, it would "
                                               r"come back as one\)$"):
        plain_state(state)


@pytest.mark.parametrize("tag", ["__ndarray__", "__float__"])
def test_a_key_that_is_the_checkpoints_own_tag_is_refused(tag):
    """A state mapping keyed "__float__" or "__ndarray__" is how a checkpoint writes a non-finite float
    or an array: {"__float__": "nan"} came back as the float nan. Refused, naming where."""
    with pytest.raises(TypeError, match=rf"^mode: key '{tag}' is the checkpoint's own tag"):
        plain_state({"mode": {tag: "nan"}})


def test_an_enum_key_is_written_as_its_value_and_a_masked_array_is_refused():
    """A str-valued enum member as a key came back as its name ('E.A', where the same member as a
    value came back 'a'); a masked array lost its mask without a word."""
    import enum

    class Mode(str, enum.Enum):  # noqa: UP042 (the mixin whose str() is its name, unlike StrEnum)
        GLIDE = "glide"

    for back in (decode_checkpoint(state_bytes(plain_state({Mode.GLIDE: 1.5}))),
                 decode_state(encode_state({Mode.GLIDE: 1.5}))):
        assert back == {"glide": 1.5}
    with pytest.raises(TypeError, match=r"^m: a masked array is not plain data"):
        plain_state({"m": np.ma.array([1.0, 2.0], mask=[0, 1])})
