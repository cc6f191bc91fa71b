"""The last step of encoding: plain values to JSON bytes. Standard library only.

Encoding a message or a checkpoint happens in two halves. The first reads the message into plain
values (:meth:`cosim.codec.MessageCodec.flatten`, :func:`cosim.codec.plain_state`); it is cheap and
runs where the message is made. The second, here, writes the text: every float's shortest
round-trip repr and the base64 of every large array, which is most of the cost. A recording's
writer process runs it, on another core, importing nothing but this module; :func:`cosim.codec.encode`
runs both halves in turn, so the bytes are the same wherever they are made.
"""

from __future__ import annotations

import binascii
import json
from typing import Any, NamedTuple


class TextFormat(NamedTuple):
    """A message type's JSON text as one ``%``-format: ``fmt % args``, where the arguments at
    ``base64_slots`` are raw bytes, written as base64 text."""

    fmt: str
    base64_slots: tuple[int, ...]


def base64_text(data: Any) -> str:
    """The base64 text of bytes (or any byte buffer), as every array in a recording is written."""
    return binascii.b2a_base64(data, newline=False).decode("ascii")


def render(text_format: TextFormat, args: tuple) -> bytes:
    """The JSON bytes of a flattened message (see :meth:`cosim.codec.MessageCodec.flatten`)."""
    if text_format.base64_slots:
        values = list(args)
        for i in text_format.base64_slots:
            values[i] = base64_text(values[i])
        args = tuple(values)
    return (text_format.fmt % args).encode()


def _with_base64(value: Any) -> Any:
    if type(value) is bytes:
        return base64_text(value)
    if type(value) is dict:
        return {k: _with_base64(v) for k, v in value.items()}
    if type(value) is list:
        return [_with_base64(v) for v in value]
    return value


def state_text(plain: Any) -> bytes:
    """The JSON bytes of plain state (see :func:`cosim.codec.plain_state`): JSON values, with the
    arrays' raw bytes written as base64 text."""
    return json.dumps(_with_base64(plain), separators=(",", ":"), allow_nan=False).encode()
