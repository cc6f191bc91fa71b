"""Exchange messages as protobuf: a record the simulating process packs in one go, that the writer
only copies. Numpy is needed to pack; the schema and the wire format are written here by hand, so
neither recording nor reading needs the protobuf package.

Why: written as JSON, a recording's floats need their shortest repr and its arrays base64, which
cost the writer process about as much CPU as the physics; on a machine whose other core is busy
that CPU is the run's wall time. As protobuf every number goes out as its 8 bytes (a float64 comes
back bit for bit, NaN payloads included) and an array as its little-endian bytes, and Foxglove
still plots every field (the schema is a ``FileDescriptorSet`` naming the message ``cosim.<Type>``).

The wire layout of a type (:class:`ProtoLayout`) is fixed by its fields:

- every float is a ``double``; every int and enum an ``sfixed64``; every bool a ``bool``: each one
  tag byte and a fixed number of bytes, so a message's numbers go out in one ``struct`` call;
- an array is a packed repeated field of its dtype (``double``, ``float``, ``sfixed64``,
  ``sfixed32``, ``fixed64``, ``fixed32``, ``bool``); a free-shape array carries its shape beside it
  as ``<name>_shape`` (packed ``sfixed64``);
- field numbers follow the wire order: the fixed-size fields in declaration order, then the shapes,
  then the arrays whose size varies. So the first byte of a payload is field 1's tag (0x08 to 0x0D),
  never the ``{`` of a JSON payload, and :func:`cosim.codec.json_codec.MessageCodec.decode` tells
  the two apart.

A type with a ``str`` field, or an array of another dtype, has no protobuf form (:func:`proto_codec_for`
gives None) and stays JSON: such messages are few (stages, events, the status) and the panels that
show them read JSON's labels.
"""

from __future__ import annotations

import dataclasses
import struct
import sys
import types
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from cosim.codec.protowire import I32, I64, LEN, VARINT, ProtoError, fields_on_wire, int_field, len_field, tag, varint
from cosim.codec.records import BYTES, HEADER, LENGTH, Write
from cosim.messages import FieldKind, FieldSpec, Message, fields_of

SCHEMA_ENCODING = "protobuf"
MESSAGE_ENCODING = "protobuf"
PACKAGE = "cosim"
INLINE_ELEMENTS = 16  # a fixed-shape array of at most this many elements is packed with the numbers

# google/protobuf/descriptor.proto: FieldDescriptorProto.Type and .Label
_TYPE_DOUBLE, _TYPE_FLOAT, _TYPE_BOOL = 1, 2, 8
_TYPE_FIXED64, _TYPE_FIXED32, _TYPE_SFIXED32, _TYPE_SFIXED64 = 6, 7, 15, 16
_LABEL_OPTIONAL, _LABEL_REPEATED = 1, 3

# array dtype -> (protobuf type, struct code of one element)
_ELEMENTS = {"float64": (_TYPE_DOUBLE, "d"), "float32": (_TYPE_FLOAT, "f"), "int64": (_TYPE_SFIXED64, "q"),
             "int32": (_TYPE_SFIXED32, "i"), "uint64": (_TYPE_FIXED64, "Q"), "uint32": (_TYPE_FIXED32, "I"),
             "bool": (_TYPE_BOOL, "?")}
_ELEMENT_DTYPES = {kind: np.dtype(name).newbyteorder("<") for name, (kind, _) in _ELEMENTS.items()}
_SCALARS = {FieldKind.FLOAT: (_TYPE_DOUBLE, "d"), FieldKind.INT: (_TYPE_SFIXED64, "q"),
            FieldKind.ENUM: (_TYPE_SFIXED64, "q"), FieldKind.BOOL: (_TYPE_BOOL, "?")}
_WIRE_OF = {_TYPE_DOUBLE: I64, _TYPE_SFIXED64: I64, _TYPE_FIXED64: I64, _TYPE_FLOAT: I32,
            _TYPE_SFIXED32: I32, _TYPE_FIXED32: I32, _TYPE_BOOL: VARINT}
_LITTLE_ENDIAN = sys.byteorder == "little"


# --- the layout of a type ------------------------------------------------------------------------

class ProtoField(NamedTuple):
    """One protobuf field: its name, number, protobuf type, and whether it is repeated."""

    name: str
    number: int
    type: int
    repeated: bool


class ProtoLayout(NamedTuple):
    """The protobuf fields of a message type in wire order, and which of them a field's array shape
    is in (``shapes``: field name -> the ``<name>_shape`` field's name)."""

    fields: tuple[ProtoField, ...]
    shapes: dict[str, str]


def _element(spec: FieldSpec) -> tuple[int, str] | None:
    assert spec.array is not None
    return _ELEMENTS.get(np.dtype(spec.array.dtype).name)


def _inline(spec: FieldSpec) -> bool:
    size = spec.array.fixed_size if spec.array is not None else None
    return size is not None and size <= INLINE_ELEMENTS


def layout_of(specs: tuple[FieldSpec, ...]) -> ProtoLayout | None:
    """The wire layout of a type's fields, or None when one of them has no protobuf form."""
    fixed, shapes, variable = [], [], []
    names = {spec.name for spec in specs}
    shape_of: dict[str, str] = {}
    for spec in specs:
        if spec.kind in _SCALARS:
            fixed.append((spec.name, _SCALARS[spec.kind][0], False))
        elif spec.kind is FieldKind.ARRAY and _element(spec) is not None:
            kind = _element(spec)[0]  # type: ignore[index]
            if _inline(spec):
                fixed.append((spec.name, kind, True))
                continue
            variable.append((spec.name, kind, True))
            if spec.array.fixed_size is None:  # type: ignore[union-attr]
                shape = f"{spec.name}_shape"
                if shape in names:
                    return None
                shape_of[spec.name] = shape
                shapes.append((shape, _TYPE_SFIXED64, True))
        else:
            return None
    ordered = fixed + shapes + variable
    return ProtoLayout(tuple(ProtoField(name, i + 1, kind, repeated)
                             for i, (name, kind, repeated) in enumerate(ordered)), shape_of)


# --- the schema: a FileDescriptorSet, written by hand ---------------------------------------------

def schema_bytes(type_name: str, layout: ProtoLayout) -> bytes:
    """A serialized ``google.protobuf.FileDescriptorSet`` holding the message ``cosim.<type_name>``
    (proto3: repeated numbers are packed)."""
    fields = b"".join(len_field(2, len_field(1, f.name.encode()) + int_field(3, f.number)
                                 + int_field(4, _LABEL_REPEATED if f.repeated else _LABEL_OPTIONAL)
                                 + int_field(5, f.type) + len_field(10, f.name.encode()))
                      for f in layout.fields)
    message = len_field(1, type_name.encode()) + fields
    file = (len_field(1, f"{PACKAGE}/{type_name}.proto".encode()) + len_field(2, PACKAGE.encode())
            + len_field(4, message) + len_field(12, b"proto3"))
    return len_field(1, file)


def layout_from_schema(data: bytes, schema_name: str) -> ProtoLayout:
    """The layout of the message ``schema_name`` in a serialized FileDescriptorSet (a recording's
    schema: what it was written with, which may be an older version of the type)."""
    package, _, name = schema_name.rpartition(".")
    for number, _, file in fields_on_wire(data):
        if number != 1:
            continue
        entries = fields_on_wire(file)
        file_package = next((bytes(v).decode() for n, _, v in entries if n == 2), "")
        if file_package != package:
            continue
        for n, _, message in entries:
            if n != 4:
                continue
            parts = fields_on_wire(message)
            if next((bytes(v).decode() for k, _, v in parts if k == 1), "") != name:
                continue
            fields = []
            for k, _, field in parts:
                if k != 2:
                    continue
                values = {key: value for key, _, value in fields_on_wire(field)}
                fields.append(ProtoField(bytes(values.get(1, b"")).decode(), values.get(3, 0), values.get(5, 0),
                                         values.get(4, _LABEL_OPTIONAL) == _LABEL_REPEATED))
            names = {f.name for f in fields}
            shapes = {f.name: f"{f.name}_shape" for f in fields if f"{f.name}_shape" in names}
            return ProtoLayout(tuple(fields), shapes)
    raise ProtoError(f"the schema holds no message {schema_name!r}")


# --- packing ---------------------------------------------------------------------------------------

_PREFIXES_KEPT = 1024  # sizes remembered per array field


def _prefix(seen: dict[int, bytes], key: bytes, n: int) -> bytes:
    """The tag (``key``) and length of an array field of ``n`` bytes, remembered in ``seen``."""
    if len(seen) >= _PREFIXES_KEPT:
        seen.clear()
    prefix = seen[n] = key + varint(n)
    return prefix


def _compile_writer(specs: tuple[FieldSpec, ...], layout: ProtoLayout) -> Write:
    """A generated ``write(msg, buffer, offset, channel, time_ns)`` putting a BYTES record (see
    :mod:`cosim.codec.records`) holding the message's protobuf payload into ``buffer``: one
    ``struct`` call for the header, every tag and every number, and one copy of each large array's
    bytes. Anything unexpected (a list where an array was declared, another dtype or shape, an int
    beyond 64 bits) gives -1, and the caller takes the slow path (:meth:`ProtoCodec.encode`)."""
    by_name = {spec.name: spec for spec in specs}
    env: dict[str, Any] = {"_ndarray": np.ndarray, "_contiguous": np.ascontiguousarray, "_prefix": _prefix,
                           "_error": struct.error}
    codes, values, pre, sizes, tail = [], [], [], [], []
    constants: list[bytes] = []

    def constant(data: bytes) -> None:
        """Tag (and length) bytes: packed as one ``Ns`` argument with those that precede it."""
        if codes and codes[-1].endswith("s") and values[-1].startswith("_k"):
            constants[-1] += data
            codes[-1] = f"{len(constants[-1])}s"
        else:
            constants.append(data)
            codes.append(f"{len(data)}s")
            values.append(f"_k{len(constants) - 1}")

    shapes = {shape: name for name, shape in layout.shapes.items()}
    for field in layout.fields:
        if field.name in shapes:  # a free-shape array's shape
            name = shapes[field.name]
            ndim = len(by_name[name].array.shape)  # type: ignore[union-attr]
            constant(tag(field.number, LEN) + varint(8 * ndim))
            codes.append("q" * ndim)
            values.append(f"*a_{name}.shape")
            continue
        spec = by_name[field.name]
        if spec.kind in _SCALARS:
            wire = _WIRE_OF[field.type]
            constant(tag(field.number, wire))
            codes.append(_SCALARS[spec.kind][1])
            values.append(f"m.{spec.name}")
            continue
        array = spec.array
        assert array is not None
        dtype = np.dtype(array.dtype)
        code = _ELEMENTS[dtype.name][1]
        value = f"m.{spec.name}"
        if _inline(spec):
            n = array.fixed_size
            shape = tuple(array.shape)
            if len(shape) == 1:
                pre += [f"v_{spec.name} = {value}.tolist()", f"if len(v_{spec.name}) != {n}: return -1"]
            else:
                pre += [f"i_{spec.name} = {value}", f"if i_{spec.name}.shape != {shape!r}: return -1",
                        f"v_{spec.name} = i_{spec.name}.ravel().tolist()"]
            constant(tag(field.number, LEN) + varint(n * dtype.itemsize))  # type: ignore[operator]
            codes.append(code * n)  # type: ignore[operator]
            values.append(f"*v_{spec.name}")
            continue
        env[f"_dtype_{spec.name}"] = dtype
        a = f"a_{spec.name}"
        pre += [f"{a} = {value}",
                f"if type({a}) is not _ndarray or {a}.dtype != _dtype_{spec.name} or {a}.ndim != {len(array.shape)}: "
                "return -1",
                f"if not {a}.flags.c_contiguous: {a} = _contiguous({a})"]
        if array.fixed_size is not None:
            pre.append(f"if {a}.shape != {tuple(array.shape)!r}: return -1")
        if not _LITTLE_ENDIAN:  # the wire holds little-endian numbers
            env[f"_little_{spec.name}"] = dtype.newbyteorder("<")
            pre.append(f"{a} = {a}.astype(_little_{spec.name})")
        # the tag and length bytes of each size met so far (a run sends few sizes, many times each)
        env[f"_t_{spec.name}"] = tag(field.number, LEN)
        env[f"_seen_{spec.name}"] = {}
        pre += [f"n_{spec.name} = {a}.nbytes",
                f"l_{spec.name} = _seen_{spec.name}.get(n_{spec.name})",
                f"if l_{spec.name} is None: l_{spec.name} = _prefix(_seen_{spec.name}, _t_{spec.name}, n_{spec.name})"]
        sizes.append(f"len(l_{spec.name}) + n_{spec.name}")
        tail += [f"buf[p:p + len(l_{spec.name})] = l_{spec.name}", f"p += len(l_{spec.name})",
                 f"if n_{spec.name}: buf[p:p + n_{spec.name}] = memoryview({a}).cast('B')",
                 f"p += n_{spec.name}"]
    for i, data in enumerate(constants):
        env[f"_k{i}"] = data
    fixed = struct.Struct(HEADER.format + LENGTH.format[1:] + "".join(codes))
    env["_pack"] = fixed.pack_into
    head = HEADER.size + LENGTH.size
    body = " + ".join([str(fixed.size - head), *sizes])
    lines = ["def write(m, buf, offset, channel, time_ns):", "    try:"]
    lines += [f"        {line}" for line in pre]
    lines += [f"        body = {body}",
              f"        end = offset + {head} + body",
              "        if end > len(buf): return offset - end",
              f"        _pack(buf, offset, {BYTES}, channel, time_ns, body{''.join(', ' + v for v in values)})"]
    if tail:
        lines.append(f"        p = offset + {fixed.size}")
        lines += [f"        {line}" for line in tail]
    lines += ["        return end",
              "    except (AttributeError, TypeError, ValueError, OverflowError, _error):",
              "        return -1"]
    exec("\n".join(lines), env)
    return env["write"]


# --- the codec -------------------------------------------------------------------------------------

class ProtoCodec:
    """The protobuf form of one message type (see :func:`proto_codec_for`).

    ``write(msg, buffer, offset, channel, time_ns)`` packs a message into a BYTES record of
    :mod:`cosim.codec.records` (-1 when it needs the slow path); :meth:`encode` gives the payload
    alone, for any message the type's fields accept; :meth:`decode` reads one back, and
    :meth:`decoder` one written with a recording's own schema.
    """

    def __init__(self, message_type: type[Message], layout: ProtoLayout):
        self.message_type = message_type
        self.fields = fields_of(message_type)
        self.schema_name = f"{PACKAGE}.{message_type.__name__}"
        self.layout = layout
        self.write = _compile_writer(self.fields, layout)
        self._schema = schema_bytes(message_type.__name__, layout)
        self._defaults = {f.name for f in dataclasses.fields(message_type)
                          if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING}
        self._decoders: dict[bytes, Callable[[Any], Message]] = {}

    def schema_bytes(self) -> bytes:
        return self._schema

    def encode(self, msg: Message) -> bytes:
        """The protobuf payload of a message; its fields are first made what the type declares (a
        list becomes an array, an int a float); raises ProtoError when one cannot be."""
        for candidate in (msg, self._normalised(msg)):
            needed = self.write(candidate, memoryview(b""), 0, 0, 0)  # asks how large the record is
            if needed == -1:
                continue
            record = memoryview(bytearray(-needed))
            if self.write(candidate, record, 0, 0, 0) != -1:
                return bytes(record[HEADER.size + LENGTH.size:])
        raise ProtoError(f"{self.schema_name}: a field's value has no protobuf form (an int beyond 64 bits?)")

    def _normalised(self, msg: Message) -> Any:
        values = {}
        for spec in self.fields:
            value = getattr(msg, spec.name)
            if spec.kind is FieldKind.FLOAT:
                value = float(value)
            elif spec.kind in (FieldKind.INT, FieldKind.ENUM):
                value = int(value)
            elif spec.kind is FieldKind.BOOL:
                value = bool(value)
            elif spec.kind is FieldKind.ARRAY:
                assert spec.array is not None
                dtype = np.dtype(spec.array.dtype)
                arr = np.asarray(value)
                if arr.dtype != dtype:
                    if not np.can_cast(arr.dtype, dtype, "same_kind"):
                        raise ProtoError(f"field {spec.name!r}: dtype {arr.dtype} is not {dtype}")
                    arr = arr.astype(dtype)
                # (np.ascontiguousarray made a 0-d array, as a Python scalar gives, 1-d: refused by its shape)
                value = arr if arr.flags.c_contiguous else arr.copy(order="C")
            values[spec.name] = value
        return types.SimpleNamespace(**values)

    def decode(self, payload: Any) -> Message:
        """A message from a payload written with this type's own schema."""
        return self.decoder(self._schema)(payload)

    def decoder(self, schema: bytes) -> Callable[[Any], Message]:
        """The decoder of payloads written with ``schema`` (a recording's FileDescriptorSet): fields
        are matched by name, so a recording made before a field was added still reads (the field
        takes its default)."""
        decode = self._decoders.get(schema)
        if decode is None:
            layout = self.layout if schema == self._schema else layout_from_schema(schema, self.schema_name)
            decode = self._decoders[schema] = _decoder(self, layout)
        return decode


def _decoder(codec: ProtoCodec, layout: ProtoLayout) -> Callable[[Any], Message]:
    """A decoder reading payloads laid out as ``layout`` into ``codec``'s message type."""
    by_number = {f.number: f for f in layout.fields}
    specs = {spec.name: spec for spec in codec.fields}
    shape_fields = set(layout.shapes.values())
    missing = [name for name in specs if name not in {f.name for f in layout.fields} and name not in codec._defaults]
    name = codec.schema_name

    def field_value(spec: FieldSpec, field: ProtoField, wire: int, raw: Any) -> Any:
        if spec.kind in _SCALARS:
            want_type = _SCALARS[spec.kind][0]
            if field.type != want_type or wire != _WIRE_OF[want_type]:
                raise ProtoError(f"{name}: field {spec.name!r} is not written as cosim writes it")
            if spec.kind is FieldKind.FLOAT:
                return struct.unpack("<d", raw)[0]
            if spec.kind is FieldKind.BOOL:
                return bool(raw)
            value = struct.unpack("<q", raw)[0]
            return spec.enum_type(value) if spec.enum_type is not None else value
        assert spec.array is not None
        if wire != LEN or field.type not in _ELEMENT_DTYPES:
            raise ProtoError(f"{name}: field {spec.name!r} is not a packed array")
        dtype = np.dtype(spec.array.dtype)
        wire_dtype = _ELEMENT_DTYPES[field.type]
        if raw.nbytes % wire_dtype.itemsize:
            raise ProtoError(f"{name}: field {spec.name!r}: {raw.nbytes} bytes is not a whole number of elements")
        return np.frombuffer(raw, dtype=wire_dtype).astype(dtype, copy=True)

    def decode(payload: Any) -> Message:
        if missing:
            raise ProtoError(f"{name}: the recording's schema lacks {', '.join(missing)}")
        try:
            entries = fields_on_wire(payload)
        except ProtoError as exc:
            raise ProtoError(f"{name}: {exc}") from None
        values: dict[str, Any] = {}
        shapes: dict[str, tuple[int, ...]] = {}
        for number, wire, raw in entries:
            field = by_number.get(number)
            if field is None:
                continue  # a field this version of the type no longer has
            if field.name in shape_fields:
                if wire != LEN or raw.nbytes % 8:
                    raise ProtoError(f"{name}: field {field.name!r} is not a packed shape")
                shapes[field.name] = tuple(int(d) for d in np.frombuffer(raw, dtype="<i8"))
                continue
            spec = specs.get(field.name)
            if spec is not None:
                values[field.name] = field_value(spec, field, wire, raw)
        for spec in codec.fields:
            if spec.kind is not FieldKind.ARRAY:
                if spec.name not in values and spec.name not in codec._defaults:
                    values[spec.name] = _zero(spec)  # proto3: a field left out is its zero
                continue
            assert spec.array is not None
            if spec.name not in values:
                if spec.name in codec._defaults and spec.name not in {f.name for f in layout.fields}:
                    continue
                values[spec.name] = np.zeros(0, dtype=spec.array.dtype)
            shape_name = layout.shapes.get(spec.name)
            if shape_name is not None:
                shape = shapes.get(shape_name, tuple(0 for _ in spec.array.shape))
            else:
                shape = tuple(spec.array.shape)  # type: ignore[arg-type]
            arr = values[spec.name]
            if len(shape) != len(spec.array.shape) or any(
                    want is not None and want != got for want, got in zip(spec.array.shape, shape, strict=True)):
                raise ProtoError(f"{name}: field {spec.name!r}: shape {shape} does not match {spec.array.shape}")
            if int(np.prod(shape, dtype=np.int64)) != arr.size:
                raise ProtoError(f"{name}: field {spec.name!r}: {arr.size} elements for shape {shape}")
            values[spec.name] = arr.reshape(shape)
        return codec.message_type(**values)

    return decode


def _zero(spec: FieldSpec) -> Any:
    if spec.kind is FieldKind.FLOAT:
        return 0.0
    if spec.kind is FieldKind.BOOL:
        return False
    if spec.kind is FieldKind.ENUM and spec.enum_type is not None:
        return spec.enum_type(0)
    return 0


_CODECS: dict[type[Message], ProtoCodec | None] = {}


def proto_codec_for(message_type: type[Message]) -> ProtoCodec | None:
    """The (cached) protobuf codec of a message type, or None when the type has no protobuf form
    (a ``str`` field, an array of another dtype) and is recorded as JSON."""
    if message_type not in _CODECS:
        layout = layout_of(fields_of(message_type))
        _CODECS[message_type] = None if layout is None else ProtoCodec(message_type, layout)
    return _CODECS[message_type]


def is_protobuf_payload(payload: Any) -> bool:
    """Whether a cosim payload is protobuf rather than JSON: a protobuf payload starts with field 1's
    tag, a JSON one with ``{``."""
    first = bytes(payload[:1])
    return bool(first) and 0x08 <= first[0] <= 0x0D
