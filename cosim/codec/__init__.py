"""A message's exact wire form, shared by the scene loader, the scheduler's checkpoints and recording.

- :mod:`~cosim.codec.json_codec`: one codec per message type, a JSON schema plus JSON bytes and back,
  bit-exact (:func:`codec_for`), and plain component state for checkpoints;
- :mod:`~cosim.codec.proto_codec`: the protobuf form a recording holds for every type without a
  ``str`` field, packed in one go where the message is made (:func:`proto_codec_for`);
- :mod:`~cosim.codec.records`: the packed records a message or a checkpoint becomes in the simulating
  process (cheap), gathered into batches;
- :mod:`~cosim.codec.jsontext`: the JSON text of a record, written later (usually in the writer
  process); the same bytes as ``json.dumps``.

Public face: :func:`codec_for`, :class:`MessageCodec`, :class:`CodecError`, :func:`encode`,
:func:`decode`, :func:`encode_state`, :func:`decode_state`. Names load on first use, so the writer
process, which needs only the text half, never imports numpy.
"""

from __future__ import annotations

from cosim import lazy_exports

_EXPORTS = {
    "CodecError": "cosim.codec.json_codec",
    "MessageCodec": "cosim.codec.json_codec",
    "codec_for": "cosim.codec.json_codec",
    "decode": "cosim.codec.json_codec",
    "decode_state": "cosim.codec.json_codec",
    "encode": "cosim.codec.json_codec",
    "encode_state": "cosim.codec.json_codec",
}

__all__ = ["CodecError", "MessageCodec", "codec_for", "decode", "decode_state", "encode", "encode_state"]

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
