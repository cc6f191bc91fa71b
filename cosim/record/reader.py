"""Reading a recording back: its scene, channels, messages and status, with clear errors.

Everything that can go wrong with a file given by a user (missing, not MCAP, truncated, corrupt, not
written by cosim) becomes a one-line :class:`RecordingError`.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError
from mcap.reader import make_reader

from cosim.codec.json_codec import CodecError, codec_for, decode_state
from cosim.errors import RecordingError, ScenarioError
from cosim.messages import Message
from cosim.record.recorder import CHECKPOINT_TOPIC, METADATA_NAME, SCENE_ATTACHMENT, STATUS_TOPIC, RunStatus
from cosim.scenario import Scene, loads


@dataclass
class ChannelInfo:
    topic: str
    schema_name: str
    message_encoding: str
    count: int
    schema_encoding: str = ""
    schema_data: bytes = b""

    def json_properties(self) -> set[str]:
        """Property names of a JSON-schema channel (empty for other encodings)."""
        if self.schema_encoding != "jsonschema":
            return set()
        try:
            return set(json.loads(self.schema_data).get("properties", {}))
        except ValueError:
            return set()


class Recording:
    """A cosim MCAP file, checked on open (magic, summary, metadata and scene must be present)."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        if not self.path.exists():
            raise RecordingError(f"{self.path}: no such file")
        try:
            with open(self.path, "rb") as f:
                reader = make_reader(f)
                header = reader.get_header()
                summary = reader.get_summary()
                metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
                attachments = {a.name: a.data for a in reader.iter_attachments()}
        except (McapError, ValueError, EOFError, OSError, KeyError, AssertionError) as exc:
            raise RecordingError(f"{self.path}: not a readable MCAP recording (truncated or corrupt: "
                                 f"{type(exc).__name__}: {exc})") from None
        if summary is None or summary.statistics is None:
            raise RecordingError(f"{self.path}: the recording has no summary (truncated or not closed)")
        if METADATA_NAME not in metadata or SCENE_ATTACHMENT not in attachments:
            raise RecordingError(f"{self.path}: not a cosim recording (no '{METADATA_NAME}' metadata "
                                 f"or '{SCENE_ATTACHMENT}' attachment; written by {header.library!r})")
        self.library = header.library
        self.metadata = metadata[METADATA_NAME]
        self.scene_text = attachments[SCENE_ATTACHMENT].decode()
        self.overrides: list[str] = json.loads(self.metadata.get("overrides", "[]"))
        counts = summary.statistics.channel_message_counts
        self.channels = {}
        for cid, ch in summary.channels.items():
            schema = summary.schemas.get(ch.schema_id)
            self.channels[ch.topic] = ChannelInfo(
                ch.topic, schema.name if schema else "", ch.message_encoding, counts.get(cid, 0),
                schema.encoding if schema else "", schema.data if schema else b"")
        self.start_ns = summary.statistics.message_start_time
        self.end_ns = summary.statistics.message_end_time

    def scene(self, overrides: list[str] | None = None) -> Scene:
        """The recorded scene, with the recorded overrides and then ``overrides`` applied."""
        try:
            return loads(self.scene_text, source=f"{self.path}:{SCENE_ATTACHMENT}",
                         overrides=self.overrides + list(overrides or []))
        except ScenarioError:
            raise
        except Exception as exc:
            raise RecordingError(f"{self.path}: the recorded scene cannot be loaded ({exc})") from None

    def raw(self, topics: list[str] | None = None) -> Iterator[tuple[str, int, bytes]]:
        """(topic, log_time_ns, payload) in log-time order; errors become RecordingError."""
        try:
            with open(self.path, "rb") as f:
                reader = make_reader(f)
                for _, channel, msg in reader.iter_messages(topics=topics, log_time_order=True):
                    yield channel.topic, msg.log_time, msg.data
        except (McapError, ValueError, EOFError, OSError) as exc:
            raise RecordingError(f"{self.path}: corrupt data ({type(exc).__name__}: {exc})") from None

    def messages(self, topic: str, msg_type: type[Message]) -> list[tuple[int, Message]]:
        """Every message of one channel decoded as ``msg_type``, in time order."""
        codec = codec_for(msg_type)
        out = []
        for _, stamp, data in self.raw([topic]):
            try:
                out.append((stamp, codec.decode(data)))
            except CodecError as exc:
                raise RecordingError(f"{self.path}: {topic} at {stamp} ns: {exc}") from None
        return out

    def status(self) -> RunStatus | None:
        found = self.messages(STATUS_TOPIC, RunStatus) if STATUS_TOPIC in self.channels else []
        return found[-1][1] if found else None

    def checkpoints(self) -> list[tuple[int, dict[str, Any]]]:
        """(time_ns, checkpoint) pairs, in time order."""
        if CHECKPOINT_TOPIC not in self.channels:
            return []
        return [(stamp, decode_state(data)) for _, stamp, data in self.raw([CHECKPOINT_TOPIC])]
