"""The last step of encoding: a message's packed record to JSON bytes. Standard library only.

Encoding a message or a checkpoint happens in two halves. The first packs the message into a record
of binary values (:meth:`cosim.codec.json_codec.MessageCodec.write`: every number as it is, every large array's
raw bytes) or a checkpoint into plain data (:func:`cosim.codec.json_codec.plain_state`); it is cheap and runs
where the message is made. The second, here, writes the text: every float's shortest round-trip
repr and the base64 of every large array, which is most of the cost. A recording's writer process
runs it, on another core, importing nothing but this module; :func:`cosim.codec.json_codec.encode` runs both
halves in turn, so the bytes are the same wherever they are made.
"""

from __future__ import annotations

import binascii
import json
import math
import pickle
import struct
from collections.abc import Callable
from operator import itemgetter
from typing import Any, NamedTuple

TEXT_LENGTH = struct.Struct("<I")  # the length prefix of a text piece in a record [bytes]
_CANONICAL_NAN = struct.pack("<d", math.nan)


class RecordLayout(NamedTuple):
    """How a message type's record is laid out, and how it is written as JSON text.

    A record's fixed part is ``struct.Struct("<" + fixed)``: every float, int, enum and bool field,
    every element of a small inline array, and the shape of every large array, in field order. The
    variable parts follow, in field order, one per entry of ``variable``: ``(itemsize, dims)`` is a
    large array's raw little-endian bytes (``itemsize`` times the product of the fixed values at
    ``dims``, written as base64); ``(0, ())`` is a UTF-8 JSON text prefixed by its length
    (:data:`TEXT_LENGTH`). The text is ``fmt % args``, where ``args`` are the fixed values followed by
    the variable pieces, picked in the order ``order``; the arguments at ``bools`` are written as
    true/false, and those at ``floats`` that are not finite as the strings :func:`nonfinite_text`
    gives.
    """

    fmt: str
    fixed: str
    variable: tuple[tuple[int, tuple[int, ...]], ...]
    order: tuple[int, ...]
    bools: tuple[int, ...]
    floats: tuple[int, ...]


def nonfinite_text(x: float) -> str:
    """How a non-finite float is written: ``nan``, ``inf``, ``-inf``, or ``nan:<16 hex digits>`` for
    a NaN with another sign or payload than the canonical one (so its bits survive)."""
    if math.isnan(x):
        bits = struct.pack("<d", x)
        return "nan" if bits == _CANONICAL_NAN else "nan:" + bits[::-1].hex()
    return "inf" if x > 0 else "-inf"


class _JsonString(str):
    """A string that a ``%r`` writes as a JSON string (a non-finite float in a float's slot)."""

    def __repr__(self) -> str:
        return json.dumps(str(self))


def base64_text(data: Any) -> str:
    """The base64 text of bytes (or any byte buffer), as every array in a recording is written."""
    return binascii.b2a_base64(data, newline=False).decode("ascii")


Renderer = Callable[[Any, int], tuple[bytes, int]]
"""``render(buffer, offset)`` -> (JSON bytes of the record's message, offset just past the record)."""


def renderer(layout: RecordLayout) -> Renderer:
    """The function writing the JSON text of records laid out as ``layout``, read from a buffer
    (bytes or a memoryview) at an offset just past the record's header."""
    fixed = struct.Struct("<" + layout.fixed)
    unpack, size = fixed.unpack_from, fixed.size
    fmt, variable, bools, floats = layout.fmt, layout.variable, layout.bools, layout.floats
    order = layout.order
    in_order = not variable and order == tuple(range(len(order)))  # the arguments are the values as they are
    pick: Callable[[tuple], tuple] = (
        itemgetter(*order) if len(order) > 1 else (lambda values: (values[order[0]],)) if order
        else (lambda values: ()))
    isfinite, unpack_length = math.isfinite, TEXT_LENGTH.unpack_from

    def render(buffer: Any, offset: int) -> tuple[bytes, int]:
        values = unpack(buffer, offset)
        offset += size
        if variable:
            pieces = []
            for itemsize, dims in variable:
                if itemsize:
                    n = itemsize
                    for d in dims:
                        n *= values[d]
                    pieces.append(base64_text(buffer[offset:offset + n]))
                else:
                    (n,) = unpack_length(buffer, offset)
                    offset += TEXT_LENGTH.size
                    pieces.append(str(buffer[offset:offset + n], "utf-8"))
                offset += n
            args = pick(values + tuple(pieces))
        else:
            args = values if in_order else pick(values)
        if bools or not isfinite(sum(values)):  # one sum tells whether every number is finite
            edited = list(args)
            for i in bools:
                edited[i] = "true" if edited[i] else "false"
            for i in floats:
                if not isfinite(edited[i]):
                    edited[i] = _JsonString(nonfinite_text(edited[i]))
            args = tuple(edited)
        return (fmt % args).encode(), offset

    return render


_RAW = (bytes, memoryview, pickle.PickleBuffer)  # an array's bytes in plain state, wherever it is read
_SCALARS = (str, int, float, bool, type(None))
_encode = json.JSONEncoder(separators=(",", ":"), allow_nan=False).encode


def _dumps(value: Any) -> bytes:
    return _encode(value).encode()


def _pieces(value: Any, out: list[bytes]) -> None:
    """The JSON text of plain state, in pieces appended to ``out``: an array's base64 is put in as
    it is (it needs no escaping), so the encoder never scans the megabytes of a water state; all else
    is the encoder's own text, so the whole equals ``json.dumps`` of the state with base64 strings."""
    kind = type(value)
    if kind in _RAW:
        out += (b'"', binascii.b2a_base64(value, newline=False), b'"')
    elif kind is dict:
        out.append(b"{")
        for i, (key, item) in enumerate(value.items()):
            out += (b"," if i else b"", _dumps(key), b":")
            _pieces(item, out)
        out.append(b"}")
    elif kind is list:
        if all(type(item) in _SCALARS for item in value):  # a list of numbers: the encoder at once
            out.append(_dumps(value))
            return
        out.append(b"[")
        for i, item in enumerate(value):
            if i:
                out.append(b",")
            _pieces(item, out)
        out.append(b"]")
    else:
        out.append(_dumps(value))


def state_text(plain: Any) -> bytes:
    """The JSON bytes of plain state (see :func:`cosim.codec.json_codec.plain_state`): JSON values, with the
    arrays' raw bytes written as base64 text."""
    out: list[bytes] = []
    _pieces(plain, out)
    return b"".join(out)
