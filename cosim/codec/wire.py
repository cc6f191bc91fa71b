"""The codec of a message type's recorded form."""

from __future__ import annotations

from typing import Any

from cosim.codec.json_codec import codec_for
from cosim.codec.proto_codec import proto_codec_for
from cosim.messages import Message


def wire_codec(msg_type: type[Message]) -> Any:
    """The codec of a type's recorded form: protobuf where the type has it, else JSON (both have
    ``write`` packing a record, ``encode`` giving the payload and ``decode`` reading it back)."""
    return proto_codec_for(msg_type) or codec_for(msg_type)
