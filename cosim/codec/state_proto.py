"""Checkpoints as protobuf: plain state (:func:`cosim.codec.json_codec.plain_state`) with every array's
bytes as they are. Encoding is standard library only (the recording's writer process runs it).

Why: a checkpoint is mostly arrays (the pond's heights and velocities: 5.6 MB each time for the
reference skip). Written as JSON, their base64 text cost the writer process about a quarter of its CPU,
which on a machine whose other core is busy is the run's wall time, and made the file's checkpoints
a third larger before compression. As protobuf an array goes out as its raw little-endian bytes,
copied once; the structure around it (components, names, numbers) is a small tree of ``Value``
messages, and Foxglove and any protobuf reader still decode the whole (the schema is
:data:`SCHEMA`, a ``FileDescriptorSet`` written here by hand):

.. code-block:: protobuf

    message Checkpoint { Value state = 1; }
    message Value {
      oneof kind {
        double number = 1;       // a float (a non-finite one is a Map {"__float__": text}, as in JSON)
        sint64 integer = 2;
        string text = 3;
        bool flag = 4;
        bool null = 5;           // None
        List list = 6;
        Map map = 7;
        Array array = 8;         // a numpy array
        string big_integer = 9;  // an int beyond 64 bits, in decimal
      }
    }
    message List { repeated Value items = 1; }
    message Map { repeated Entry entries = 1; }
    message Entry { string key = 1; Value value = 2; }
    message Array { string dtype = 1; repeated int64 shape = 2; bytes data = 3; }

A recording made before this module holds JSON checkpoints; :func:`decode_checkpoint` reads these
ones, :func:`cosim.codec.json_codec.decode_state` those.
"""

from __future__ import annotations

import pickle
import struct
from typing import Any

from cosim.codec.protowire import (
    I64,
    LEN,
    VARINT,
    ProtoError,
    fields_on_wire,
    int_field,
    len_field,
    read_varint,
    tag,
    varint,
)

SCHEMA_NAME = "cosim.Checkpoint"
ENCODING = "protobuf"  # schema and message encoding

_RAW = (bytes, bytearray, memoryview, pickle.PickleBuffer)  # an array's bytes, wherever plain state is read
_DOUBLE = struct.Struct("<d")
_INT64_MIN, _INT64_MAX = -(1 << 63), (1 << 63) - 1

# field numbers of Value's oneof
NUMBER, INTEGER, TEXT, FLAG, NULL, LIST, MAP, ARRAY, BIG_INTEGER = range(1, 10)


_NUMBER_KEY = tag(NUMBER, I64)
_INTEGER_KEY = tag(INTEGER, VARINT)
_FLAG_TRUE, _FLAG_FALSE = tag(FLAG, VARINT) + b"\x01", tag(FLAG, VARINT) + b"\x00"
_NULL = tag(NULL, VARINT) + b"\x01"


def _wrap(number: int, pieces: list[Any], size: int, out: list[Any]) -> int:
    """Append field ``number`` holding ``pieces`` (``size`` bytes) as a length-delimited field; its
    size on the wire."""
    head = tag(number, LEN) + varint(size)
    out.append(head)
    out.extend(pieces)
    return len(head) + size


def _text(number: int, text: str, out: list[Any]) -> int:
    data = text.encode()
    return _wrap(number, [data], len(data), out)


def _is_array(value: dict) -> bool:
    return len(value) == 3 and "__ndarray__" in value and "shape" in value and type(value.get("base64")) in _RAW


def _bytes_of(raw: Any) -> memoryview:
    """The bytes of an array's buffer as one flat view (no copy)."""
    view = raw.raw() if type(raw) is pickle.PickleBuffer else memoryview(raw)
    if view.nbytes == 0:
        return memoryview(b"")
    return view if view.ndim == 1 and view.format == "B" else view.cast("B")


def _value(value: Any, out: list[Any]) -> int:
    """Append the content of the ``Value`` message of plain ``value`` to ``out``; its size [bytes]."""
    kind = type(value)
    if kind is float:
        out.append(_NUMBER_KEY + _DOUBLE.pack(value))
        return 9
    if kind is bool:
        out.append(_FLAG_TRUE if value else _FLAG_FALSE)
        return 2
    if kind is int:
        if _INT64_MIN <= value <= _INT64_MAX:
            data = _INTEGER_KEY + varint((value << 1) ^ (value >> 63))  # zigzag: sint64
            out.append(data)
            return len(data)
        return _text(BIG_INTEGER, str(value), out)
    if kind is str:
        return _text(TEXT, value, out)
    if value is None:
        out.append(_NULL)
        return 2
    inner: list[Any] = []
    if kind is dict and _is_array(value):
        size = _text(1, value["__ndarray__"], inner)
        dims = b"".join(varint(int(d)) for d in value["shape"])
        if dims:
            size += _wrap(2, [dims], len(dims), inner)
        data = _bytes_of(value["base64"])
        if data.nbytes:  # proto3: an empty bytes field is left out
            size += _wrap(3, [data], data.nbytes, inner)
        return _wrap(ARRAY, inner, size, out)
    if kind is dict:
        size = 0
        for key, item in value.items():
            entry: list[Any] = []
            body: list[Any] = []
            n = _text(1, key, entry)
            n += _wrap(2, body, _value(item, body), entry)  # body is filled before _wrap reads it
            size += _wrap(1, entry, n, inner)
        return _wrap(MAP, inner, size, out)
    if kind is list:
        size = 0
        for item in value:
            body = []
            size += _wrap(1, body, _value(item, body), inner)  # body is filled before _wrap reads it
        return _wrap(LIST, inner, size, out)
    raise TypeError(f"checkpoint value of type {kind.__name__} is not plain state")


def state_bytes(plain: Any) -> bytes:
    """The protobuf ``cosim.Checkpoint`` of plain state (:func:`cosim.codec.json_codec.plain_state`;
    its arrays' bytes, wherever they are, are copied once, into the result)."""
    out: list[Any] = []
    body: list[Any] = []
    _wrap(1, body, _value(plain, body), out)
    return b"".join(out)


# --- reading back ------------------------------------------------------------------------------

def decode_checkpoint(payload: Any) -> Any:
    """The state of a ``cosim.Checkpoint`` payload: dicts, lists, numbers, strings and numpy arrays
    (each a copy of its bytes), as :func:`cosim.codec.json_codec.decode_state` gives it from JSON.
    Raises ValueError when the payload is not one."""
    try:
        fields = fields_on_wire(payload)
    except ProtoError as exc:
        raise ValueError(f"not a checkpoint: {exc}") from None
    states = [raw for number, wire, raw in fields if number == 1 and wire == LEN]
    if len(states) != 1:
        raise ValueError("not a checkpoint: no state, or more than one")
    from cosim.codec.json_codec import _state_in  # numpy: only where a checkpoint is read back

    return _state_in(_value_in(states[0]))


def _value_in(data: Any) -> Any:
    """The plain state (:func:`cosim.codec.json_codec.plain_state`'s form) of a ``Value`` message."""
    fields = fields_on_wire(data)
    if len(fields) != 1:
        raise ValueError(f"a checkpoint value holds {len(fields)} fields, not one")
    number, wire, raw = fields[0]
    expected = I64 if number == NUMBER else VARINT if number in (INTEGER, FLAG, NULL) else LEN
    if wire != expected or not NUMBER <= number <= BIG_INTEGER:
        raise ValueError(f"a checkpoint value has field {number} of wire type {wire}")
    if number == NUMBER:
        return _DOUBLE.unpack(raw)[0]
    if number == INTEGER:
        return (raw >> 1) ^ -(raw & 1)
    if number == FLAG:
        return bool(raw)
    if number == NULL:
        return None
    if number == TEXT:
        return str(raw, "utf-8")
    if number == BIG_INTEGER:
        return int(str(raw, "utf-8"))
    if number == LIST:
        return [_value_in(item) for n, w, item in fields_on_wire(raw) if n == 1 and w == LEN]
    if number == MAP:
        out = {}
        for n, w, entry in fields_on_wire(raw):
            if n != 1 or w != LEN:
                continue
            parts = {k: v for k, _, v in fields_on_wire(entry)}
            if 2 not in parts:
                raise ValueError("a checkpoint map entry has no value")
            out[str(parts.get(1, b""), "utf-8")] = _value_in(parts[2])
        return out
    parts = {k: v for k, _, v in fields_on_wire(raw)}  # ARRAY: as plain_state holds it, its bytes raw
    shape: list[int] = []
    dims = memoryview(parts.get(2, b"")).cast("B")
    at = 0
    while at < len(dims):
        d, at = read_varint(dims, at)
        shape.append(d)
    return {"__ndarray__": str(parts.get(1, b""), "utf-8"), "shape": shape, "base64": parts.get(3, b"")}


# --- the schema -----------------------------------------------------------------------------------------

# google/protobuf/descriptor.proto: FieldDescriptorProto.Type and .Label
_T_DOUBLE, _T_INT64, _T_BOOL, _T_STRING, _T_MESSAGE, _T_BYTES, _T_SINT64 = 1, 3, 8, 9, 11, 12, 18
_OPTIONAL, _REPEATED = 1, 3


def _field(name: str, number: int, kind: int, label: int = _OPTIONAL, type_name: str = "",
           oneof: int | None = None) -> bytes:
    out = (len_field(1, name.encode()) + int_field(3, number) + int_field(4, label) + int_field(5, kind)
           + (len_field(6, f".cosim.{type_name}".encode()) if type_name else b"")
           + (int_field(9, oneof) if oneof is not None else b"") + len_field(10, name.encode()))
    return len_field(2, out)


def _message(name: str, *fields: bytes, oneof: str = "") -> bytes:
    return len_field(4, len_field(1, name.encode()) + b"".join(fields)
                      + (len_field(8, len_field(1, oneof.encode())) if oneof else b""))


SCHEMA = len_field(1, (
    len_field(1, b"cosim/Checkpoint.proto") + len_field(2, b"cosim")
    + _message("Checkpoint", _field("state", 1, _T_MESSAGE, type_name="Value"))
    + _message("Value",
               _field("number", NUMBER, _T_DOUBLE, oneof=0), _field("integer", INTEGER, _T_SINT64, oneof=0),
               _field("text", TEXT, _T_STRING, oneof=0), _field("flag", FLAG, _T_BOOL, oneof=0),
               _field("null", NULL, _T_BOOL, oneof=0), _field("list", LIST, _T_MESSAGE, type_name="List", oneof=0),
               _field("map", MAP, _T_MESSAGE, type_name="Map", oneof=0),
               _field("array", ARRAY, _T_MESSAGE, type_name="Array", oneof=0),
               _field("big_integer", BIG_INTEGER, _T_STRING, oneof=0), oneof="kind")
    + _message("List", _field("items", 1, _T_MESSAGE, _REPEATED, "Value"))
    + _message("Map", _field("entries", 1, _T_MESSAGE, _REPEATED, "Entry"))
    + _message("Entry", _field("key", 1, _T_STRING), _field("value", 2, _T_MESSAGE, type_name="Value"))
    + _message("Array", _field("dtype", 1, _T_STRING), _field("shape", 2, _T_INT64, _REPEATED),
               _field("data", 3, _T_BYTES))
    + len_field(12, b"proto3")))
"""The serialized ``FileDescriptorSet`` of ``cosim.Checkpoint`` (and the messages it holds)."""
