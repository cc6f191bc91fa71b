"""One codec for every message type: a JSON schema plus JSON bytes, and back, bit-exact.

JSON is the form of the few recorded types that have a ``str`` field (stages, events, the status),
of the live view, of checkpointed port slots and of hand-written values; a recording holds the
other types as protobuf (:mod:`cosim.codec.proto_codec`), which :meth:`MessageCodec.decode` reads
too. Exactness comes from Python's shortest round-trip
float repr; non-finite floats are written as the strings ``"nan"``, ``"inf"``, ``"-inf"`` (a NaN with
another sign or payload as ``"nan:<hex bits>"``). Arrays of
at most :data:`INLINE_ARRAY_MAX` fixed elements are written as (nested) lists so they can be plotted;
larger or free-shape arrays as ``{"dtype", "shape", "base64"}`` of their little-endian bytes, which is
both exact and fast for water patches.

Plain component state (for checkpoints) uses :func:`encode_state` / :func:`decode_state`: JSON with
numpy arrays tagged ``{"__ndarray__": ...}``.
"""

from __future__ import annotations

import base64
import dataclasses
import enum
import json
import math
import pickle
import struct
import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from cosim.codec.jsontext import TEXT_LENGTH, RecordLayout, base64_text, nonfinite_text, renderer, state_text
from cosim.codec.proto_codec import ProtoError, is_protobuf_payload, proto_codec_for
from cosim.codec.records import HEADER, MESSAGE, Write
from cosim.messages import Array, FieldKind, FieldSpec, Message, fields_of

INLINE_ARRAY_MAX = 16  # arrays up to this many fixed elements are written inline as JSON lists

SCHEMA_ENCODING = "jsonschema"
MESSAGE_ENCODING = "json"

_NONFINITE = {"nan": math.nan, "inf": math.inf, "-inf": -math.inf}


class CodecError(ValueError):
    """A payload that does not decode to its message type; ``field``: the scalar field it is about, when
    one is (its text then begins with that field's name)."""

    def __init__(self, message: str, field: str | None = None):
        super().__init__(message)
        self.field = field


def _float_out(x: float) -> float | str:
    x = float(x)
    return x if math.isfinite(x) else nonfinite_text(x)


def json_kind(x: Any) -> str:
    """What a decoded JSON or YAML value is, in the file's words: null, true, a list, an object (a
    Python type name, 'NoneType', meant nothing to the one who wrote the file)."""
    if x is None:
        return "null"
    if isinstance(x, bool):
        return "true" if x else "false"
    if isinstance(x, list | tuple):
        return "a list"
    if isinstance(x, dict):
        return "an object"
    return type(x).__name__


def _float_in(x: Any) -> float:
    if isinstance(x, str):
        if x.startswith("nan:") and len(x) == 20:
            try:
                return struct.unpack("<d", bytes.fromhex(x[4:])[::-1])[0]
            except ValueError:
                pass
        try:
            return _NONFINITE[x]
        except KeyError:
            raise CodecError(f"expected a number, got string {x!r}") from None
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise CodecError(f"expected a number, got {json_kind(x)}")
    return float(x)


def _inline(spec: Array) -> bool:
    size = spec.fixed_size
    return size is not None and size <= INLINE_ARRAY_MAX


def _array_out(spec: Array, name: str) -> Callable[[Any], Any]:
    dtype = np.dtype(spec.dtype)

    def check(value: Any) -> np.ndarray:
        arr = np.asarray(value)
        if arr.dtype != dtype:
            arr = arr.astype(dtype) if np.can_cast(arr.dtype, dtype, "same_kind") else None
            if arr is None:
                raise CodecError(f"field {name!r}: dtype {np.asarray(value).dtype} is not {dtype}")
        if len(arr.shape) != len(spec.shape) or any(
            want is not None and want != got for want, got in zip(spec.shape, arr.shape, strict=True)
        ):
            raise CodecError(f"field {name!r}: shape {arr.shape} does not match {spec.shape}")
        return arr

    if _inline(spec):
        shape = tuple(spec.shape)
        isfinite = math.isfinite

        def enc(value: Any) -> Any:
            # fast path: the right ndarray already (the common case, a few microseconds matter here)
            if type(value) is not np.ndarray or value.dtype != dtype or value.shape != shape:
                value = check(value)
            out = value.tolist()
            if dtype.kind != "f":
                return out
            flat = out if len(shape) == 1 else value.ravel().tolist()
            for x in flat:
                if not isfinite(x):
                    return np.vectorize(_float_out, otypes=[object])(value).tolist()
            return out

        return enc

    def enc_b64(value: Any) -> Any:
        arr = np.ascontiguousarray(check(value), dtype=dtype.newbyteorder("<"))
        return {"dtype": dtype.str.replace(">", "<"), "shape": list(arr.shape),
                "base64": base64_text(arr.tobytes())}

    return enc_b64


def _not_an_array(value: list, dtype: np.dtype) -> str:
    """Why the nested lists ``value`` make no array of ``dtype``: rows of different lengths (what
    numpy leaves as lists inside an array of objects), else values that are no numbers of its kind."""
    try:
        ragged = any(isinstance(item, list) for item in np.array(value, dtype=object).ravel())
    except ValueError:  # (lists nested to different depths that not even objects line up)
        ragged = True
    return "its nested lists are not all of one length" if ragged else f"its values must be {dtype.name} numbers"


def _array_in(spec: Array, name: str) -> Callable[[Any], np.ndarray]:
    dtype = np.dtype(spec.dtype)

    def finish(arr: np.ndarray) -> np.ndarray:
        if len(arr.shape) != len(spec.shape) or any(
            want is not None and want != got for want, got in zip(spec.shape, arr.shape, strict=True)
        ):
            raise CodecError(f"field {name!r}: shape {arr.shape} does not match {spec.shape}")
        return arr

    if _inline(spec):
        def dec(value: Any) -> np.ndarray:
            if dtype.kind == "f":
                flat = np.asarray(value, dtype=object).ravel()
                arr = np.array([_float_in(v) for v in flat], dtype=dtype).reshape(np.shape(value))
            else:
                arr = np.asarray(value, dtype=dtype)
            return finish(arr)
        return dec

    def dec_b64(value: Any) -> np.ndarray:
        if isinstance(value, list):  # plain nested lists, as written by hand in a scene's `initial`
            try:
                arr = np.array(value, dtype=dtype)
            except (ValueError, TypeError):
                # in the scene's words, not numpy's ("setting an array element with a sequence ...")
                raise CodecError(f"field {name!r}: bad array ({_not_an_array(value, dtype)})") from None
            return finish(arr.reshape([0] * len(spec.shape) if not value or value == [[]] else np.shape(value)))
        try:
            raw = base64.b64decode(value["base64"], validate=True)
            arr = np.frombuffer(raw, dtype=np.dtype(value["dtype"])).reshape(value["shape"])
        except (KeyError, TypeError, ValueError) as exc:
            raise CodecError(f"field {name!r}: bad array payload ({exc})") from None
        return finish(arr.astype(dtype, copy=True))

    return dec_b64


def _field_coders(spec: FieldSpec) -> tuple[Callable[[Any], Any], Callable[[Any], Any]]:
    if spec.kind is FieldKind.FLOAT:
        return _float_out, _float_in
    if spec.kind is FieldKind.INT:
        def int_in(x: Any) -> int:
            if isinstance(x, bool) or not isinstance(x, int):
                raise CodecError(f"field {spec.name!r}: expected an integer, got {x!r}")
            return x
        return int, int_in
    if spec.kind is FieldKind.BOOL:
        def bool_in(x: Any) -> bool:
            if not isinstance(x, bool):
                raise CodecError(f"field {spec.name!r}: expected true/false, got {x!r}")
            return x
        return bool, bool_in
    if spec.kind is FieldKind.STR:
        return str, str
    if spec.kind is FieldKind.ENUM:
        enum_type = spec.enum_type
        assert enum_type is not None

        def enum_in(x: Any) -> enum.IntEnum:
            try:
                return enum_type(x)
            except ValueError:
                raise CodecError(f"field {spec.name!r}: {x!r} is not a {enum_type.__name__}") from None
        return int, enum_in
    assert spec.array is not None
    return _array_out(spec.array, spec.name), _array_in(spec.array, spec.name)


_STRUCT_CODES = {"f": "d", "i": "q", "u": "q", "b": "?"}  # inline array element kinds -> struct codes
_LITTLE_ENDIAN = sys.byteorder == "little"


def _nested(shape: tuple[int, ...], item: str) -> str:
    """The format of a fixed-shape inline array: nested JSON lists of ``item``."""
    if not shape:
        return item
    return "[" + ",".join([_nested(shape[1:], item)] * shape[0]) + "]"


def _compile_writer(fields: tuple[FieldSpec, ...], encoders: dict[str, Callable[[Any], Any]]
                    ) -> tuple[Write, RecordLayout]:
    """A generated function packing a message into a record (see :mod:`cosim.codec.records`), and the
    record's layout, so that ``renderer(layout)`` of the record equals
    ``json.dumps(to_dict(msg), separators=(",", ":"))`` byte for byte: every number is packed as it
    is (one ``struct`` call for them all), every large array copied once as raw bytes; the text
    (floats' shortest round-trip reprs, non-finite floats as strings, base64) is written later, by
    :func:`cosim.codec.jsontext.renderer`, usually in a recording's writer process. Anything unexpected
    (a list where an array was declared, a wrong shape or dtype, an int beyond 64 bits) gives -1 and
    the caller takes the slow path. Recording every exchange hinges on this."""
    env: dict[str, Any] = {"_json": json.dumps, "_ndarray": np.ndarray, "_contiguous": np.ascontiguousarray,
                           "_error": struct.error, "_text_length": TEXT_LENGTH.pack_into}
    pre: list[str] = []       # statements reading and checking the fields
    codes: list[str] = []     # struct codes of the fixed part
    packed: list[str] = []    # the fixed part's values
    sizes: list[str] = []     # sizes of the variable parts
    tail: list[str] = []      # statements copying the variable parts
    fmt: list[str] = []
    order: list[tuple[str, int]] = []  # per format argument: ("f", fixed index) or ("v", variable index)
    variable: list[tuple[int, tuple[int, ...]]] = []
    bools: list[int] = []
    floats: list[int] = []

    def argument(source: str, index: int, kind: str = "") -> None:
        if kind == "bool":
            bools.append(len(order))
        elif kind == "float":
            floats.append(len(order))
        order.append((source, index))

    def fixed(code: str, value: str, kind: str = "") -> None:
        argument("f", len(codes), kind)
        codes.append(code)
        packed.append(value)

    def text(expression: str, i: int) -> None:
        pre.append(f"t{i} = {expression}.encode()")
        sizes.append(f"{TEXT_LENGTH.size} + len(t{i})")
        tail.extend([f"_text_length(buf, p, len(t{i}))", f"p += {TEXT_LENGTH.size}",
                     f"buf[p:p + len(t{i})] = t{i}", f"p += len(t{i})"])
        argument("v", len(variable))
        variable.append((0, ()))

    for i, spec in enumerate(fields):
        key = json.dumps(spec.name)
        value = f"m.{spec.name}"
        sep = "," if fmt else "{"
        if spec.kind is FieldKind.FLOAT:
            fmt.append(f"{sep}{key}:%r")
            fixed("d", value, "float")
        elif spec.kind in (FieldKind.INT, FieldKind.ENUM):
            fmt.append(f"{sep}{key}:%d")
            fixed("q", value)
        elif spec.kind is FieldKind.BOOL:
            fmt.append(f"{sep}{key}:%s")
            fixed("?", value, "bool")
        elif spec.kind is FieldKind.STR:
            fmt.append(f"{sep}{key}:%s")
            text(f"_json({value})", i)
        else:
            assert spec.array is not None
            array = spec.array
            dtype = np.dtype(array.dtype)
            shape = tuple(array.shape)
            if _inline(array) and dtype.kind in _STRUCT_CODES:
                code = _STRUCT_CODES[dtype.kind]
                kind = {"d": "float", "?": "bool"}.get(code, "")
                item = {"d": "%r", "?": "%s"}.get(code, "%d")
                n = array.fixed_size
                if len(shape) == 1:
                    pre += [f"v{i} = {value}.tolist()", f"if len(v{i}) != {n}: return -1"]
                else:
                    pre += [f"a{i} = {value}", f"if a{i}.shape != {shape!r}: return -1",
                            f"v{i} = a{i}.ravel().tolist()"]
                fmt.append(f"{sep}{key}:" + _nested(shape, item))
                for j in range(n):
                    fixed(code, f"v{i}[{j}]", kind)
                packed[-n:] = [f"*v{i}"] + [""] * (n - 1)
            elif not _inline(array):
                env[f"_dtype{i}"] = dtype
                ndim = len(shape)
                pre += [f"a{i} = {value}",
                        f"if type(a{i}) is not _ndarray or a{i}.dtype != _dtype{i} or a{i}.ndim != {ndim}: return -1",
                        f"if not a{i}.flags.c_contiguous: a{i} = _contiguous(a{i})"]
                if not _LITTLE_ENDIAN:  # records hold little-endian bytes
                    env[f"_little{i}"] = dtype.newbyteorder("<")
                    pre.append(f"a{i} = a{i}.astype(_little{i})")
                pre.append(f"n{i} = a{i}.nbytes")
                fmt.append(f"{sep}{key}:" + "{" + '"dtype":' + json.dumps(dtype.str.replace(">", "<"))
                           + ',"shape":[' + ",".join(["%d"] * ndim) + '],"base64":"%s"}')
                dims = []
                for d in range(ndim):
                    dims.append(len(codes))
                    fixed("q", f"a{i}.shape[{d}]")
                packed[-ndim:] = [f"*a{i}.shape"] + [""] * (ndim - 1)
                sizes.append(f"n{i}")
                tail += [f"if n{i}: buf[p:p + n{i}] = memoryview(a{i}).cast('B')", f"p += n{i}"]
                argument("v", len(variable))
                variable.append((dtype.itemsize, tuple(dims)))
            else:  # a small inline array of another dtype: its JSON text as it is
                env[f"_enc{i}"] = encoders[spec.name]
                fmt.append(f"{sep}{key}:%s")
                text(f"_json(_enc{i}({value}), separators=(',', ':'))", i)
    record = struct.Struct(HEADER.format + "".join(codes))
    env["_pack"] = record.pack_into
    size = " + ".join([str(record.size), *sizes])
    lines = ["def write(m, buf, offset, channel, time_ns):", "    try:"]
    lines += [f"        {line}" for line in pre]
    lines += [f"        end = offset + {size}",
              "        if end > len(buf): return offset - end",
              f"        _pack(buf, offset, {MESSAGE}, channel, time_ns{''.join(', ' + v for v in packed if v)})"]
    if tail:
        lines.append(f"        p = offset + {record.size}")
        lines += [f"        {line}" for line in tail]
    lines.append("        return end")
    lines.append("    except (AttributeError, TypeError, ValueError, OverflowError, _error):")
    lines.append("        return -1")
    exec("\n".join(lines), env)
    nfixed = len(codes)
    layout = RecordLayout(
        fmt="".join(fmt) + "}" if fmt else "{}", fixed="".join(codes), variable=tuple(variable),
        order=tuple(index if source == "f" else nfixed + index for source, index in order),
        bools=tuple(bools), floats=tuple(floats))
    return env["write"], layout


class MessageCodec:
    """Encoder/decoder for one message type (built once per type, see :func:`codec_for`).

    ``write(msg, buffer, offset, channel, time_ns)`` packs a message into a record (see
    :mod:`cosim.codec.records`; -1 when the message needs the slow path: a wrong shape or dtype);
    ``renderer(layout)`` writes a record's JSON text. :meth:`encode` does both.
    """

    def __init__(self, message_type: type[Message]):
        self.message_type = message_type
        self.fields = fields_of(message_type)
        self.schema_name = f"cosim.{message_type.__name__}"
        coders = [_field_coders(spec) for spec in self.fields]
        self._encoders = [(spec.name, enc) for spec, (enc, _) in zip(self.fields, coders, strict=True)]
        self._decoders = [(spec.name, dec) for spec, (_, dec) in zip(self.fields, coders, strict=True)]
        self._defaulted = {f.name for f in dataclasses.fields(message_type)
                           if f.default is not dataclasses.MISSING or f.default_factory is not dataclasses.MISSING}
        self.write, self.layout = _compile_writer(self.fields, dict(self._encoders))
        self._render = renderer(self.layout)

    def to_dict(self, msg: Message) -> dict[str, Any]:
        """The JSON-ready dict of a message."""
        return {name: enc(getattr(msg, name)) for name, enc in self._encoders}

    def encode(self, msg: Message) -> bytes:
        """JSON bytes of a message (compact, keys in declaration order)."""
        needed = self.write(msg, memoryview(b""), 0, 0, 0)  # asks how large the record is
        if needed == -1:
            return self._slow_encode(msg)
        record = memoryview(bytearray(-needed))
        if self.write(msg, record, 0, 0, 0) == -1:  # refused while its numbers were packed
            return self._slow_encode(msg)
        return self._render(record, HEADER.size)[0]

    def _slow_encode(self, msg: Message) -> bytes:
        return json.dumps(self.to_dict(msg), separators=(",", ":"), allow_nan=False).encode()

    def from_dict(self, data: Any) -> Message:
        """Build a message from a decoded dict, checking every field; raises CodecError."""
        if not isinstance(data, dict):
            raise CodecError(f"{self.schema_name}: expected an object, got {json_kind(data)}")
        names = {name for name, _ in self._decoders}
        unknown = sorted(map(str, set(data) - names))  # (a YAML key may be a number or null)
        missing = self.missing(data)
        if unknown or missing:
            parts = []
            if missing:
                parts.append("missing " + ", ".join(missing))
            if unknown:
                parts.append("unknown " + ", ".join(unknown))
            raise CodecError(f"{self.schema_name}: " + "; ".join(parts))
        try:
            values = {name: dec(data[name]) for name, dec in self._decoders if name in data}
        except CodecError as exc:  # said with the field it is about (array fields name themselves)
            raise self._failing_field(data, exc) from None
        return self.message_type(**values)

    def missing(self, data: dict) -> list[str]:
        """The fields a message needs that ``data`` lacks, in declaration order (a field with a default
        may be left out: a message written before the field was added)."""
        return [name for name, _ in self._decoders if name not in data and name not in self._defaulted]

    def _failing_field(self, data: dict, exc: CodecError) -> CodecError:
        """``exc`` led by the field of ``data`` that fails to decode ('x_max: expected a number, got
        string 'abc''; it said which value was wrong, not where), that field its ``field``."""
        for name, dec in self._decoders:
            if name not in data:
                continue
            try:
                dec(data[name])
            except CodecError as failed:
                said = str(failed)
                return failed if said.startswith("field ") else CodecError(f"{name}: {said}", field=name)
        return exc

    def decode(self, payload: bytes) -> Message:
        """Message from JSON bytes, or from the protobuf payload a recording holds for a type that has
        that form (:mod:`cosim.codec.proto_codec`, written with the type's present schema); raises
        CodecError on malformed input."""
        if is_protobuf_payload(payload):
            proto = proto_codec_for(self.message_type)
            if proto is not None:
                try:
                    return proto.decode(payload)
                except (ProtoError, struct.error, TypeError, ValueError) as exc:
                    raise CodecError(f"{self.schema_name}: not a valid protobuf payload ({exc})") from None
        try:
            data = json.loads(payload)
        except (ValueError, UnicodeDecodeError) as exc:
            raise CodecError(f"{self.schema_name}: not valid JSON ({exc})") from None
        return self.from_dict(data)

    def schema(self) -> dict[str, Any]:
        """A JSON Schema (draft 2020-12) describing the payload, with units from the docstring."""
        props: dict[str, Any] = {}
        number = {"oneOf": [{"type": "number"},
                            {"type": "string", "pattern": "^(nan|inf|-inf|nan:[0-9a-f]{16})$"}]}
        for spec in self.fields:
            if spec.kind is FieldKind.FLOAT:
                props[spec.name] = number
            elif spec.kind in (FieldKind.INT, FieldKind.ENUM):
                props[spec.name] = {"type": "integer"}
                if spec.enum_type is not None:
                    props[spec.name]["enum"] = [int(m) for m in spec.enum_type]
                    props[spec.name]["description"] = ", ".join(
                        f"{int(m)}={m.name.lower()}" for m in spec.enum_type)
            elif spec.kind is FieldKind.BOOL:
                props[spec.name] = {"type": "boolean"}
            elif spec.kind is FieldKind.STR:
                props[spec.name] = {"type": "string"}
            else:
                assert spec.array is not None
                if _inline(spec.array):
                    item: dict[str, Any] = number if spec.array.dtype.startswith("float") else {"type": "integer"}
                    for dim in reversed(spec.array.shape):
                        item = {"type": "array", "items": item, "minItems": dim, "maxItems": dim}
                    props[spec.name] = item
                else:
                    props[spec.name] = {
                        "type": "object",
                        "description": f"{spec.array.dtype} array of shape {spec.array.shape}, "
                                       "little-endian bytes in base64",
                        "properties": {"dtype": {"type": "string"},
                                       "shape": {"type": "array", "items": {"type": "integer"}},
                                       "base64": {"type": "string", "contentEncoding": "base64"}},
                    }
        return {
            "$schema": "https://json-schema.org/draft/2020-12/schema",
            "title": self.schema_name,
            "description": (self.message_type.__doc__ or "").strip(),
            "type": "object",
            "properties": props,
            "required": [spec.name for spec in self.fields],
        }

    def schema_bytes(self) -> bytes:
        return json.dumps(self.schema(), sort_keys=True, separators=(",", ":")).encode()


_CODECS: dict[type[Message], MessageCodec] = {}


def codec_for(message_type: type[Message]) -> MessageCodec:
    """The (cached) codec of a message type."""
    codec = _CODECS.get(message_type)
    if codec is None:
        codec = _CODECS[message_type] = MessageCodec(message_type)
    return codec


def encode(msg: Message) -> bytes:
    return codec_for(type(msg)).encode(msg)


def decode(message_type: type[Message], payload: bytes) -> Message:
    return codec_for(message_type).decode(payload)


# --- plain-data state (checkpoints) -------------------------------------------------------------

# the dtype kinds whose array bytes are its values, read back by np.frombuffer: bool, signed and
# unsigned int, float, complex, bytes and str of fixed size. Others are not: an object array's bytes
# are pointers, a datetime64 array gives no buffer, a structured one came back as void bytes.
_PLAIN_ARRAY_KINDS = frozenset("biufcSU")


_TAGS = frozenset({"__ndarray__", "__float__"})  # the keys a state's arrays and non-finite floats are written under


class NotPlainData(TypeError):
    """A state value that is not plain data (:func:`plain_state`): ``what`` is wrong with it, and
    ``path`` the keys and list indexes leading to it from the state given (its text leads the
    message, so the component whose state it is can be named: ``state.label: ...``)."""

    def __init__(self, what: str, path: tuple[str | int, ...] = ()):
        super().__init__(f"{_path_text(path)}: {what}" if path else what)
        self.what, self.path = what, path

    def inside(self, key: str | int) -> NotPlainData:
        """The same fault, seen from the dict or list holding it at ``key``."""
        return NotPlainData(self.what, (key, *self.path))


def _path_text(path: tuple[str | int, ...]) -> str:
    """A key path as code reads it: ``state.records[2]``, ``state['a b']``."""
    text = ""
    for key in path:
        if isinstance(key, int):
            text += f"[{key}]"
        elif key.isidentifier():
            text += f".{key}" if text else key
        else:
            text += f"[{key!r}]"
    return text


def plain_state(value: Any) -> Any:
    """State data (dicts, lists, numbers, strings, numpy arrays) as JSON values, every array as a
    tagged dict holding its little-endian bytes as a :class:`pickle.PickleBuffer` (written as base64
    by :func:`cosim.codec.jsontext.state_text`; pickled out of band). The buffers share the state's arrays:
    use them before the state changes.

    Every value comes out as the exact type the checkpoint codecs write (a ``np.str_`` as a ``str``,
    an int subclass as an ``int``: the protobuf form takes nothing else), and what they could not
    give back as it was is refused with :class:`NotPlainData` (a TypeError) naming where it is: a
    key that is not a string (an int key came back a string, and ``{1: a, "1": b}`` as one key),
    text holding a lone surrogate (both forms' text is UTF-8), an array whose bytes are not its
    values (:data:`_PLAIN_ARRAY_KINDS`: objects, datetimes, structured records). Anything else that
    is not plain data is a TypeError."""
    if isinstance(value, np.ndarray):
        return _plain_array(value)
    if isinstance(value, dict):
        return _plain_dict(value)
    if isinstance(value, (list, tuple)):
        return _plain_list(value)
    if isinstance(value, (np.floating, float)):
        x = float(value)
        # tagged, so a state string that happens to read "nan" stays a string
        return x if math.isfinite(x) else {"__float__": _float_out(x)}
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, enum.Enum):
        return plain_state(value.value)
    if value is None or isinstance(value, bool):
        return value
    if isinstance(value, int):
        return int(value)  # (a subclass of int as the int it is)
    if isinstance(value, str):
        return _plain_text(value, "text")
    raise TypeError(f"state value of type {type(value).__name__} is not plain data")


def _plain_array(value: np.ndarray) -> dict[str, Any]:
    if isinstance(value, np.ma.MaskedArray):
        raise NotPlainData("a masked array is not plain data (its mask would be lost: write the values "
                           "and the mask as two arrays)")
    dtype = value.dtype
    if dtype.kind not in _PLAIN_ARRAY_KINDS or dtype.fields is not None:
        raise NotPlainData(f"an array of dtype {dtype} is not plain data (a checkpoint holds arrays of "
                           "booleans, numbers, or bytes or text of fixed size)")
    arr = np.asarray(value)  # (a subclass's bytes, as the array they are)
    if not arr.flags.c_contiguous:
        arr = arr.copy(order="C")  # (np.ascontiguousarray made a 0-d array 1-d)
    arr = arr.astype(dtype.newbyteorder("<"), copy=False)
    return {"__ndarray__": arr.dtype.str, "shape": list(arr.shape), "base64": pickle.PickleBuffer(arr)}


def _plain_dict(value: dict) -> dict[str, Any]:
    out = {}
    for key, item in value.items():
        if isinstance(key, enum.Enum):
            key = key.value  # (a str-valued member's str() is its name: E.A came back as 'E.A')
        if not isinstance(key, str):
            raise NotPlainData(f"key {key!r} ({type(key).__name__}) is not a string: a checkpoint's keys are "
                               "strings (written as text, it would come back as one)")
        if key in _TAGS:
            raise NotPlainData(f"key {key!r} is the checkpoint's own tag of an array or a non-finite float: "
                               "a mapping holding it would come back as one")
        key = _plain_text(key, "key")
        try:
            out[key] = plain_state(item)
        except NotPlainData as exc:
            raise exc.inside(key) from None
    return out


def _plain_list(value: list | tuple) -> list[Any]:
    out = []
    for i, item in enumerate(value):
        try:
            out.append(plain_state(item))
        except NotPlainData as exc:
            raise exc.inside(i) from None
    return out


def _plain_text(text: str, what: str) -> str:
    """``text`` as a plain ``str``; :class:`NotPlainData` when it holds a lone surrogate (as Python
    carries a file name's byte that is not UTF-8), which a checkpoint's text, UTF-8, cannot: the
    protobuf form would fail in the recording's writer, or be refused by every protobuf reader."""
    text = str(text)
    if not text.isascii():
        try:
            text.encode()
        except UnicodeEncodeError as exc:
            raise NotPlainData(f"{what} {text!r} holds the lone surrogate {text[exc.start]!r}: a checkpoint's "
                               "text must be valid UTF-8") from None
    return text


def _state_in(value: Any) -> Any:
    if isinstance(value, dict):
        if "__ndarray__" in value:
            raw = value["base64"]  # the array's bytes: as base64 text in JSON, raw from a protobuf checkpoint
            if isinstance(raw, str):
                raw = base64.b64decode(raw)
            return np.frombuffer(raw, dtype=np.dtype(value["__ndarray__"])).reshape(value["shape"]).copy()
        if "__float__" in value:
            return _float_in(value["__float__"])
        return {k: _state_in(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_state_in(v) for v in value]
    return value


def encode_state(state: Any) -> bytes:
    """JSON bytes of plain state data (dicts, lists, numbers, strings, numpy arrays), bit-exact."""
    return state_text(plain_state(state))


def decode_state(payload: bytes) -> Any:
    """Inverse of :func:`encode_state`."""
    return _state_in(json.loads(payload))
