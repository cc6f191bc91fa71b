"""The protobuf wire format, as far as cosim writes and reads it: varints, tags, length-delimited and
varint fields, and a payload split into its fields. Standard library only: the recording's writer
process uses it (:mod:`cosim.codec.state_proto`) without importing numpy."""

from __future__ import annotations

from typing import Any

VARINT, I64, LEN, I32 = 0, 1, 2, 5  # wire types


class ProtoError(ValueError):
    """A payload or a schema that does not decode."""


def varint(n: int) -> bytes:
    """The protobuf varint of a non-negative integer."""
    out = bytearray()
    while n > 0x7F:
        out.append((n & 0x7F) | 0x80)
        n >>= 7
    out.append(n)
    return bytes(out)


def read_varint(data: Any, at: int) -> tuple[int, int]:
    """(value, the index after it) of the varint at index ``at`` of ``data`` (bytes-like)."""
    n = shift = 0
    while True:
        if at >= len(data) or shift > 63:
            raise ProtoError("truncated or overlong varint")
        b = data[at]
        at += 1
        n |= (b & 0x7F) << shift
        if b < 0x80:
            return n, at
        shift += 7


def fields_on_wire(data: Any) -> list[tuple[int, int, Any]]:
    """(field number, wire type, value) of every field of a protobuf payload, in wire order: an int
    for a varint, the raw bytes (a memoryview) for the other wire types."""
    view = memoryview(data).cast("B")
    out = []
    at, end = 0, len(view)
    while at < end:
        key, at = read_varint(view, at)
        number, wire = key >> 3, key & 7
        if wire == VARINT:
            value, at = read_varint(view, at)
        elif wire in (I64, I32):
            n = 8 if wire == I64 else 4
            value, at = view[at:at + n], at + n
        elif wire == LEN:
            n, at = read_varint(view, at)
            value, at = view[at:at + n], at + n
        else:
            raise ProtoError(f"field {number}: wire type {wire} is not written by cosim")
        if at > end:
            raise ProtoError(f"field {number}: truncated")
        out.append((number, wire, value))
    return out


def tag(number: int, wire: int) -> bytes:
    """The key of field ``number`` of wire type ``wire``."""
    return varint(number << 3 | wire)


def len_field(number: int, payload: bytes) -> bytes:
    """Field ``number`` holding ``payload``, length-delimited."""
    return tag(number, LEN) + varint(len(payload)) + payload


def int_field(number: int, value: int) -> bytes:
    """Field ``number`` holding the non-negative ``value`` as a varint."""
    return tag(number, VARINT) + varint(value)
