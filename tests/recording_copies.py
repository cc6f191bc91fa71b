"""Copies of a recording with one part changed, every CRC matching: what the tests of damaged or
crafted recordings are made from (a reader then meets the change itself, not a broken file)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap.writer import Writer


def copy_recording(src: Path, dst: Path, *,
                   metadata: Callable[[str, dict], dict] = lambda name, fields: fields,
                   attachment: Callable[[Any], bytes] = lambda att: att.data,
                   message: Callable[[Any, Any], bytes] = lambda channel, msg: msg.data,
                   log_time: Callable[[Any, Any], int] = lambda channel, msg: msg.log_time) -> Path:
    """Write ``dst``, a copy of the MCAP recording ``src`` record by record, each metadata record's
    fields as ``metadata(name, fields)`` gives them, each attachment's data as ``attachment(att)``,
    each message's as ``message(channel, msg)`` at the log time ``log_time(channel, msg)``; ``dst``."""
    with open(src, "rb") as f, open(dst, "wb") as out:
        reader = make_reader(f)
        summary = reader.get_summary()
        writer = Writer(out)
        writer.start(profile="", library="test")
        schemas = {sid: writer.register_schema(s.name, s.encoding, s.data) for sid, s in summary.schemas.items()}
        ids = {cid: writer.register_channel(c.topic, c.message_encoding, schemas.get(c.schema_id, 0), c.metadata)
               for cid, c in summary.channels.items()}
        for meta in reader.iter_metadata():
            writer.add_metadata(meta.name, metadata(meta.name, dict(meta.metadata)))
        for att in reader.iter_attachments():
            writer.add_attachment(att.log_time, att.create_time, att.name, att.media_type, attachment(att))
        for _, channel, msg in reader.iter_messages(log_time_order=False):
            writer.add_message(ids[channel.id], log_time(channel, msg), message(channel, msg), msg.publish_time)
        writer.finish()
    return dst
