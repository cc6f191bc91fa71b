"""Reading a recording back: its scene, channels, messages and status, with clear errors.

Everything that can go wrong with a file given by a user (missing, not MCAP, truncated, corrupt, not
written by cosim) becomes a one-line :class:`RecordingError`. Every CRC the file carries is checked
when it is opened (the data section's, which covers every chunk, attachment and metadata record,
and the summary's) and again for each chunk as it is read, so a changed byte is an error, never a
wrong value.
"""

from __future__ import annotations

import json
import re
import struct
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.reader import make_reader

from cosim.codec import state_proto
from cosim.codec.json_codec import codec_for, decode_state
from cosim.codec.proto_codec import MESSAGE_ENCODING as PROTO_ENCODING
from cosim.codec.proto_codec import ProtoError, proto_codec_for
from cosim.errors import RecordingError, ScenarioError, shortened
from cosim.messages import Message
from cosim.record.output import MCAP_MAGIC, being_written
from cosim.record.recorder import CHECKPOINT_TOPIC, METADATA_NAME, SCENE_ATTACHMENT, STATUS_TOPIC, RunStatus
from cosim.record.seal import FOOTER, FOOTER_TAIL, footer_fields
from cosim.scenario import MAX_TIME_NS, Scene, loads

MAGIC = MCAP_MAGIC
_DATA_END = struct.Struct("<BQI")  # opcode, record length, data section CRC
DATA_END_OP = 0x0F
_DIGITS = re.compile(r"[0-9]+")  # a whole number as the recorder writes it (str.isdigit also takes "²")
_READ = 1 << 20


def _crc(f: Any, start: int, end: int) -> int:
    """CRC-32 of the bytes [start, end) of an open file."""
    f.seek(start)
    crc, left = 0, end - start
    while left > 0:
        block = f.read(min(_READ, left))
        if not block:
            break
        crc = zlib.crc32(block, crc)
        left -= len(block)
    return crc


def _footer(f: Any, size: int) -> tuple[int, int, int] | None:
    """(summary start, summary offset start, summary CRC) of the open MCAP file ``f`` of ``size``
    bytes when it ends as a closed one does, its footer record then the magic; None if it does not."""
    if size < len(MAGIC) + FOOTER_TAIL:
        return None
    f.seek(size - FOOTER_TAIL)
    return footer_fields(f.read(FOOTER_TAIL))


def ends_in_footer(path: Path) -> bool:
    """Whether the MCAP file ``path`` ends as a closed one does (its footer, then the magic), that is,
    was not cut short; one that does and still cannot be read is damaged."""
    with open(path, "rb") as f:
        return _footer(f, f.seek(0, 2)) is not None


def check_integrity(path: Path) -> None:
    """The file ends in an MCAP footer (it was closed, not cut short) and its data-section and summary
    CRCs match; otherwise a RecordingError saying which."""
    with open(path, "rb") as f:
        size = f.seek(0, 2)
        f.seek(0)
        if f.read(len(MAGIC)) != MAGIC:
            raise RecordingError(f"{path}: not a readable MCAP recording (no MCAP magic at its start)")
        if size < 2 * len(MAGIC) + FOOTER.size:
            raise RecordingError(f"{path}: not a readable MCAP recording (truncated: {size} bytes, no footer)")
        footer = _footer(f, size)
        if footer is None:
            where, repair = _damage(path)
            if where:
                raise RecordingError(f"{path}: not a readable MCAP recording (truncated or corrupt: no footer at its "
                                     f"end; the file was cut short, or its writer was killed, and {where}: {repair})")
            raise RecordingError(f"{path}: not a readable MCAP recording (truncated or corrupt: no footer at its "
                                 "end; the file was cut short, or its writer was killed: cosim repair makes what "
                                 "it holds a valid recording)")
        summary_start, summary_offsets, summary_crc = footer
        footer_at = size - FOOTER_TAIL
        if not 0 <= summary_start <= footer_at or not 0 <= summary_offsets <= footer_at:
            raise RecordingError(f"{path}: corrupt: its footer points outside the file")
        if summary_start == 0:
            raise RecordingError(f"{path}: the recording has no summary (truncated or not closed)")
        if summary_crc and _crc(f, summary_start, footer_at + FOOTER.size - 4) != summary_crc:
            raise RecordingError(f"{path}: corrupt: the CRC of its summary does not match (changed on disk?)")
        data_end = summary_start - _DATA_END.size
        f.seek(data_end)
        raw = f.read(_DATA_END.size)
        if data_end < len(MAGIC) or len(raw) != _DATA_END.size:
            raise RecordingError(f"{path}: corrupt: no data-end record before its summary")
        op, length, data_crc = _DATA_END.unpack(raw)
        if op != DATA_END_OP or length != 4:
            raise RecordingError(f"{path}: corrupt: no data-end record before its summary")
        if data_crc and _crc(f, 0, data_end) != data_crc:
            where, repair = _damage(path)
            raise RecordingError(f"{path}: corrupt: the CRC of its data does not match (changed on disk?)"
                                 + (f": {where} ({repair})" if where else ""))


def _damage(path: Path) -> tuple[str, str]:
    """Where the MCAP file ``path`` is damaged ("the chunk at byte 483093 fails its CRC") and what
    ``cosim repair`` makes of it, as :func:`cosim.record.seal.find_damage` finds it; ("", "") when no
    record of its data section is found damaged."""
    from cosim.record.seal import find_damage_and_names

    try:
        damage, metadata, attachments = find_damage_and_names(path)
    except (ValueError, OSError):  # not even its header whole, or unreadable: said by what calls this
        return "", ""
    if not damage:
        return "", ""
    shown = damage[:3]
    where = "; ".join(d.what for d in shown) + (f"; and {len(damage) - 3} more" if len(damage) > 3 else "")
    if METADATA_NAME not in metadata or SCENE_ATTACHMENT not in attachments:
        # (a byte changed near its start: repair was said to make it a recording, then refused it)
        lost = "its run's description" if METADATA_NAME not in metadata else "its scene"
        return where, f"it takes {lost} with it, so cosim repair cannot make it a recording"
    last = damage[-1]
    left_out = [d for d in damage if not d.mended]  # (a damaged header is written anew, not left out)
    it = "it" if len(left_out) == 1 else "them"
    if not last.resumed:
        upto = "it" if len(damage) == 1 else "the last (leaving the others out)"
        if not last.kept_before:
            return where, f"no whole message precedes {upto}, so cosim repair keeps nothing: {last.why_stopped}"
        return where, f"cosim repair keeps only the {last.kept_before} messages before {upto}: {last.why_stopped}"
    if not left_out:
        return where, "cosim repair makes it a valid recording, its header written anew"
    mended = ", its header written anew" if len(left_out) < len(damage) else ""
    return where, f"cosim repair makes what it holds a valid recording, leaving {it} out{mended}"


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
        if not self.path.is_file():
            raise RecordingError(f"{self.path}: not a recording (a folder or a device)")
        try:
            with open(self.path, "rb"):
                pass
        except OSError as exc:  # not a damaged file: one this process may not open (permission denied)
            raise RecordingError(f"{self.path}: cannot be read ({exc.strerror or exc})") from None
        try:
            check_integrity(self.path)
            with open(self.path, "rb") as f:
                reader = make_reader(f, validate_crcs=True)
                header = reader.get_header()
                summary = reader.get_summary()
                metadata = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
                attachments = {a.name: a.data for a in reader.iter_attachments()}
        except RecordingError:
            if being_written(str(self.path)):  # not cut short: a live run's private file, unfinished yet
                raise RecordingError(f"{self.path}: a run is writing it now; it is finished when that run ends") \
                    from None
            raise
        except Exception as exc:  # whatever a damaged file makes the reader raise
            raise RecordingError(f"{self.path}: not a readable MCAP recording (truncated or corrupt: "
                                 f"{type(exc).__name__}: {_short(exc)})") from None
        if summary is None or summary.statistics is None:
            raise RecordingError(f"{self.path}: the recording has no summary (truncated or not closed)")
        if METADATA_NAME not in metadata or SCENE_ATTACHMENT not in attachments:
            raise RecordingError(f"{self.path}: not a cosim recording (no '{METADATA_NAME}' metadata "
                                 f"or '{SCENE_ATTACHMENT}' attachment; written by {header.library!r})")
        self.library = header.library
        self.metadata = metadata[METADATA_NAME]
        self.scene_text = self._scene_text(attachments[SCENE_ATTACHMENT])
        self._scene: Scene | None = None  # the recorded scene once loaded (scene() without overrides)
        try:
            # the recorder has written it in every recording since the first ("[]" for none): one
            # without it was read as a run without overrides, and replay of a run made with --set
            # reported false divergences against its own scene
            if "overrides" not in self.metadata:
                raise ValueError("overrides, the run's changes to its scene (--set; [] for none), is missing")
            self.overrides: list[str] = json.loads(self.metadata["overrides"])
            if not isinstance(self.overrides, list) or not all(isinstance(o, str) for o in self.overrides):
                raise ValueError("overrides are not a list of strings")
            # the run's step (every recording has one: inspect shows it) and end: whole nanoseconds > 0
            # that an MCAP log time holds (the recorder writes them; a crafted value of 1e23 ns
            # was shown as dt = 1e+14 s)
            if "dt_ns" not in self.metadata:
                raise ValueError("dt_ns, the run's step, is missing")
            times = {key: _nanoseconds(key, self.metadata[key]) for key in ("dt_ns", "until_ns")
                     if key in self.metadata}
            self.dt_ns = times["dt_ns"]
        except ValueError as exc:
            raise RecordingError(f"{self.path}: not a cosim recording (its metadata cannot be read: {exc})") from None
        counts = summary.statistics.channel_message_counts
        self.channels = {}
        for cid, ch in summary.channels.items():
            schema = summary.schemas.get(ch.schema_id)
            self.channels[ch.topic] = ChannelInfo(
                ch.topic, schema.name if schema else "", ch.message_encoding, counts.get(cid, 0),
                schema.encoding if schema else "", schema.data if schema else b"")
        self.start_ns = summary.statistics.message_start_time
        self.end_ns = summary.statistics.message_end_time
        if max(self.start_ns, self.end_ns) > MAX_TIME_NS:
            self._refuse_beyond_time()
        # the checkpoint a restart began at [ns]; 0 for a run from t = 0 (and recordings before the mark)
        try:
            self.restart_ns = _nanoseconds("start_ns", self.metadata.get("start_ns", "0"), zero=True)
        except ValueError as exc:  # a crafted value was read as 0: a restart taken for a run from t = 0
            raise RecordingError(f"{self.path}: not a cosim recording (its metadata cannot be read: {exc})") from None

    def _refuse_beyond_time(self) -> None:
        """A RecordingError naming the channel and time of the first message logged later than a cosim
        recording's times hold (MCAP's log times go to 2^64 - 1 ns; the recorder's, int64 nanoseconds, to
        2^63 - 1): read as they were, such a time overflowed the int64 arrays of plot and render (an
        internal OverflowError) and inspect showed a span of 1.8e10 s. Found by reading the messages, as
        the statistics name no channel; statistics saying so of no message are refused all the same."""
        for _ in self.raw():  # raises at the first such message
            pass
        latest = max(self.start_ns, self.end_ns)
        raise RecordingError(f"{self.path}: its statistics say its messages reach {latest} ns, later than a cosim "
                             "recording's times reach (at most 2^63 - 1 ns, what int64 nanoseconds hold), though no "
                             "message is logged so late: the recording was edited")

    def _scene_text(self, attachment: bytes) -> str:
        """The scene attachment's text; a RecordingError naming it when it is not UTF-8 (it was taken
        for the metadata: "its metadata cannot be read: 'utf-8' codec ...")."""
        try:
            return attachment.decode()
        except UnicodeDecodeError as exc:
            bad = f"byte 0x{attachment[exc.start]:02x} at offset {exc.start}: {exc.reason}"
            raise RecordingError(f"{self.path}: its scene (the '{SCENE_ATTACHMENT}' attachment) cannot be read: it "
                                 f"is not UTF-8 text ({bad})") from None

    def scene(self, overrides: list[str] | None = None) -> Scene:
        """The recorded scene, with the recorded overrides and then ``overrides`` applied. Without
        ``overrides`` its step must be the run's (``dt_ns``): one file saying two steps was edited, and
        inspect (the metadata's) and replay (the scene's) would each believe another. Loaded once and
        kept (read it, do not change it): render asks for it for the body's step and the water's
        extent, replay once per component, 16 ms each for the reference skip."""
        if not overrides and self._scene is not None:
            return self._scene
        try:
            # (a scene without name: is named as its run named it, from its file: restarted, it was
            # named after the recording's attachment, 'c.mcap_scene')
            scene = loads(self.scene_text, source=f"{self.path}:{SCENE_ATTACHMENT}",
                          overrides=self.overrides + list(overrides or []), base_dir=self.metadata.get("base_dir"),
                          default_name=self.metadata.get("scene") or None)
        except ScenarioError:
            raise
        except Exception as exc:
            raise RecordingError(f"{self.path}: the recorded scene cannot be loaded ({exc})") from None
        if not overrides and scene.dt_ns != self.dt_ns:
            raise RecordingError(f"{self.path}: its run's step dt_ns = {self.dt_ns} ns is not its scene's dt = "
                                 f"{scene.dt_ns} ns (with its overrides): the recording was edited")
        if not overrides:
            self._scene = scene
        return scene

    def raw(self, topics: list[str] | None = None) -> Iterator[tuple[str, int, bytes]]:
        """(topic, log_time_ns, payload) in log-time order; errors become RecordingError."""
        try:
            with open(self.path, "rb") as f:
                reader = make_reader(f, validate_crcs=True)
                for _, channel, msg in reader.iter_messages(topics=topics, log_time_order=True):
                    if msg.log_time > MAX_TIME_NS:
                        raise RecordingError(_beyond_time(self.path, channel.topic, msg.log_time))
                    yield channel.topic, msg.log_time, msg.data
        except (RecordingError, GeneratorExit):
            raise
        except Exception as exc:  # a chunk whose CRC fails, data that does not decompress, ...
            raise RecordingError(f"{self.path}: corrupt data ({type(exc).__name__}: {_short(exc)})") from None

    def messages(self, topic: str, msg_type: type[Message]) -> list[tuple[int, Message]]:
        """Every message of one channel decoded as ``msg_type``, in time order."""
        return list(self.iter_messages(topic, msg_type))

    def iter_messages(self, topic: str, msg_type: type[Message]) -> Iterator[tuple[int, Message]]:
        """(log time [ns], message) of one channel decoded as ``msg_type``, in time order, one at a
        time (a water's fields need not all be held at once); a payload that cannot be decoded is a
        RecordingError naming the channel and its time. Read a recording's messages through this (or
        :meth:`messages`), not :meth:`decoder`: a decoder's own errors (a cut protobuf payload's
        ProtoError) escaped plot and render as internal errors."""
        decode = self.decoder(topic, msg_type)
        for _, stamp, data in self.raw([topic]):
            try:
                msg = decode(data)
            except Exception as exc:  # CodecError, or anything a damaged payload makes the decoder raise
                raise RecordingError(f"{self.path}: {topic} at {stamp} ns: {_short(exc)}") from None
            yield stamp, msg

    def decoder(self, topic: str, msg_type: type[Message]) -> Callable[[bytes], Message]:
        """The function decoding one channel's payloads as ``msg_type``: its JSON codec, or for a
        protobuf channel the type's protobuf codec reading the schema the recording holds."""
        channel = self.channels.get(topic)
        if channel is None or channel.message_encoding != PROTO_ENCODING:
            return codec_for(msg_type).decode
        proto = proto_codec_for(msg_type)
        if proto is None:
            raise RecordingError(f"{self.path}: {topic} is protobuf, which {msg_type.__name__} has no form for")
        try:
            return proto.decoder(channel.schema_data)
        except ProtoError as exc:
            raise RecordingError(f"{self.path}: {topic}: its schema cannot be read ({exc})") from None

    def status(self) -> RunStatus | None:
        found = self.messages(STATUS_TOPIC, RunStatus) if STATUS_TOPIC in self.channels else []
        return found[-1][1] if found else None

    def checkpoints(self) -> list[tuple[int, dict[str, Any]]]:
        """(time_ns, checkpoint) pairs, in time order."""
        return list(self._checkpoints())

    def checkpoint_at(self, time_ns: int) -> dict[str, Any] | None:
        """The checkpoint recorded at ``time_ns``, or None; only that one is decoded."""
        return next((cp for _, cp in self._checkpoints(time_ns)), None)

    def checkpoint_at_or_before(self, time_ns: int) -> tuple[list[int], int | None, dict[str, Any] | None]:
        """The times [ns] of the recording's checkpoints, in order, and the last one at or before
        ``time_ns`` with its checkpoint ((None, None) when there is none). The times are the records'
        log times: only the checkpoint chosen is decoded (decoding them all cost as much as reading
        the file), so one that cannot be decoded elsewhere in the file does not stop its use."""
        stamps: list[int] = []
        chosen: tuple[int, bytes] | None = None
        if CHECKPOINT_TOPIC in self.channels:
            for _, stamp, data in self.raw([CHECKPOINT_TOPIC]):
                stamps.append(stamp)
                if stamp <= time_ns:
                    chosen = (stamp, data)
        if chosen is None:
            return stamps, None, None
        return stamps, chosen[0], self._decoded_checkpoint(*chosen)

    def _checkpoints(self, only_ns: int | None = None) -> Iterator[tuple[int, dict[str, Any]]]:
        if CHECKPOINT_TOPIC not in self.channels:
            return
        for _, stamp, data in self.raw([CHECKPOINT_TOPIC]):
            if only_ns is None or stamp == only_ns:
                yield stamp, self._decoded_checkpoint(stamp, data)

    def _decoded_checkpoint(self, stamp: int, data: bytes) -> dict[str, Any]:
        """The checkpoint recorded at ``stamp`` [ns] as ``data``, or a RecordingError saying it cannot
        be read."""
        # protobuf (cosim.codec.state_proto); JSON in recordings made before it
        encoding = self.channels[CHECKPOINT_TOPIC].message_encoding
        decode = state_proto.decode_checkpoint if encoding == state_proto.ENCODING else decode_state
        try:
            checkpoint = decode(data)
        except Exception as exc:  # whatever a damaged payload makes the decoder raise
            raise RecordingError(f"{self.path}: the checkpoint at {stamp} ns cannot be read "
                                 f"({_short(exc)})") from None
        # a payload that decodes may still not be a checkpoint (a list, a text, components [1]):
        # said here, where it is read, rather than as a TypeError wherever a part of it is used
        problem = _checkpoint_problem(checkpoint, stamp)
        if problem is not None:
            raise RecordingError(f"{self.path}: cannot restart from the checkpoint at {stamp / 1e9:g} s: {problem}")
        return checkpoint


def _checkpoint_problem(checkpoint: Any, stamp: int) -> str | None:
    """What keeps ``checkpoint``, decoded from the record logged at ``stamp`` [ns], from having the
    form :meth:`cosim.scheduler.Simulation.checkpoint` gives it ("its components is [1], not a
    mapping ..."); None when it has it. What a component's own state holds, its ``set_state`` checks."""
    if not isinstance(checkpoint, dict):
        return f"it is {_shown_value(checkpoint)}, not a mapping of tick, dt_ns, components, slots and edges"
    missing = [key for key in ("tick", "dt_ns", "components", "slots", "edges") if key not in checkpoint]
    if missing:
        return f"it holds no {missing[0]!r} (a checkpoint holds tick, dt_ns, components, slots and edges)"
    tick, dt_ns = checkpoint["tick"], checkpoint["dt_ns"]
    if not _whole(tick):
        return f"its tick is {_shown_value(tick)}, not a whole number >= 0"
    if not _whole(dt_ns) or dt_ns == 0:
        return f"its dt_ns is {_shown_value(dt_ns)}, not a whole number of nanoseconds > 0"
    if tick * dt_ns != stamp:
        return (f"its time, tick {tick} x dt_ns {dt_ns} = {tick * dt_ns / 1e9:g} s, is not the time it was "
                f"recorded at, {stamp / 1e9:g} s")
    return (_components_problem(checkpoint["components"]) or _slots_problem(checkpoint["slots"])
            or _list_problem("edges", checkpoint["edges"], "a whole number (the stamp last delivered)", _is_int)
            or _list_problem("ahead", checkpoint.get("ahead", []), "[stamp, channel, payload]",
                             lambda entry: _entry(entry, (_is_int, _is_text, _is_text))))


def _components_problem(components: Any) -> str | None:
    """What is wrong with a checkpoint's ``components``: {name: {"state": ..., "step_count": n}}."""
    if not isinstance(components, dict):
        return f"its components is {_shown_value(components)}, not a mapping of component names to their states"
    for name, saved in components.items():
        where = f"its components[{name!r}]"
        if not isinstance(saved, dict) or "state" not in saved or "step_count" not in saved:
            return f"{where} is {_shown_value(saved)}, not a mapping of its state and step_count"
        if not isinstance(saved["state"], (dict, str, bytes)):  # (text or bytes: JSON, in older recordings)
            return f"{where}['state'] is {_shown_value(saved['state'])}, not a mapping"
        if not _whole(saved["step_count"]):
            return f"{where}['step_count'] is {_shown_value(saved['step_count'])}, not a whole number >= 0"
    return None


def _slots_problem(slots: Any) -> str | None:
    """What is wrong with a checkpoint's ``slots``: {"component.port": [[stamp, payload], ...]}."""
    if not isinstance(slots, dict):
        return f"its slots is {_shown_value(slots)}, not a mapping of outputs to their last messages"
    for name, entries in slots.items():
        problem = _list_problem(f"slots[{name!r}]", entries, "[stamp, payload]",
                                lambda entry: _entry(entry, (_is_int, _is_text)))
        if problem is not None:
            return problem
    return None


def _list_problem(name: str, value: Any, item: str, fits: Callable[[Any], bool]) -> str | None:
    """What is wrong with the checkpoint's list ``name`` whose every item ``fits``, as ``item`` says."""
    if not isinstance(value, list):
        return f"its {name} is {_shown_value(value)}, not a list"
    wrong = next((i for i, entry in enumerate(value) if not fits(entry)), None)
    if wrong is not None:
        return f"its {name}[{wrong}] is {_shown_value(value[wrong])}, not {item}"
    return None


def _entry(value: Any, fields: tuple[Callable[[Any], bool], ...]) -> bool:
    """Whether ``value`` is a list of as many items as ``fields``, each passing its field's check."""
    return (isinstance(value, list) and len(value) == len(fields)
            and all(fits(v) for fits, v in zip(fields, value, strict=True)))


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _is_text(value: Any) -> bool:
    return isinstance(value, str)


def _whole(value: Any) -> bool:
    """A whole number >= 0 (a tick, a count; not a bool)."""
    return _is_int(value) and value >= 0


_KINDS = {dict: "a mapping", list: "a list", str: "a text", bytes: "bytes", bool: "a flag", float: "a number",
          int: "a number", type(None): "nothing"}


def _shown_value(value: Any) -> str:
    """A decoded value for an error line: its kind and its repr, shortened ("a list [1]")."""
    return f"{_KINDS.get(type(value), type(value).__name__)} {shortened(repr(value), 40)}"


def _nanoseconds(key: str, value: str, zero: bool = False) -> int:
    """The time ``value`` of the metadata entry ``key`` [ns]: a whole number > 0 (>= 0 with
    ``zero``) that a recording's times hold (at most 2^63 - 1); a ValueError saying what it is
    otherwise."""
    digits = value.lstrip("0") if _DIGITS.fullmatch(value) else None
    if digits == "" and zero:
        return 0
    if not digits:
        raise ValueError(f"{key} is {_shown(value)}, not a whole number of nanoseconds {'>=' if zero else '>'} 0")
    if len(digits) > len(str(MAX_TIME_NS)) or int(digits) > MAX_TIME_NS:
        raise ValueError(f"{key} is {_shown(value)}, more nanoseconds than a recording's times hold (at most "
                         "2^63 - 1, about 292 years)")
    return int(digits)


def _beyond_time(path: Path, topic: str, log_time: int) -> str:
    """The error line of a message on ``topic`` logged at ``log_time`` [ns], later than a recording's
    times reach."""
    return (f"{path}: {topic}: a message logged at {log_time} ns ({log_time / 1e9:.6g} s), later than a cosim "
            f"recording's times reach (at most 2^63 - 1 = {MAX_TIME_NS} ns, about 292 years: what int64 "
            "nanoseconds hold)")


def _shown(value: str) -> str:
    """A metadata value quoted for an error line: its repr, a long one cut to its start and length."""
    return repr(value) if len(value) <= 40 else f"{value[:24]!r}... ({len(value)} characters)"


def _short(exc: BaseException) -> str:
    """An exception's message on one line, at most 200 characters."""
    return shortened(str(exc), 200)
