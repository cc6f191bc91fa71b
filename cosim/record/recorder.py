"""The MCAP recorder: an observer that writes every exchange, so a run can be watched and replayed.

Layout of a recording:

- ``/<component>/<port>``: every message published on that output port, under a schema named
  ``cosim.<Type>``: protobuf (:mod:`cosim.codec.proto_codec`) for every type that has that form,
  JSON with a ``jsonschema`` schema for the others (a ``str`` field: stages, events, the status);
  log_time = publish_time = simulation time [ns]; a per-channel sequence number.
- ``/cosim/events``: framework events (substepping switched on, ...), ``cosim.Event``.
- ``/cosim/checkpoint``: full restart states every ``record.checkpoint_every`` seconds, as protobuf
  ``cosim.Checkpoint`` (:mod:`cosim.codec.state_proto`: each array's raw bytes).
- ``/cosim/status``: the final status record (ok, stopped, failed, interrupted), always written.
- metadata ``cosim`` (version, scene name, source, overrides, command line, dt) and the scene YAML
  as the attachment ``scene.yaml``, so a recording is self-describing and replayable.
- extra channels from *derivers* (viewer channels, computed from the exchanged messages and never
  fed back into the physics; made by the writer process from the recorded messages where it can,
  :mod:`cosim.record.derive`) and opt-in ``/perf/...`` wall-clock channels.

The output path is checked first (:func:`cosim.record.output.check_output`: never the scene, a folder,
a device or a file that is not a recording); the file is written to a private ``NAME.<random>.part``
beside it and moved into place when closed, so a finished path always holds a complete, indexed
file; every ending (error, Ctrl-C, SIGTERM) goes through :meth:`Recorder.close`. The MCAP writing
itself happens in a writer process (:mod:`cosim.record.writer`), which finishes the file even if the
simulating process dies, with every step it completed (the recorder marks each one,
:meth:`cosim.record.writer.ProcessSink.mark`). If the writer dies instead, the run ends with a
:class:`cosim.record.writer.SinkError` and the recording is salvaged up to the failure
(:mod:`cosim.record.salvage`), ending with a ``failed`` status saying so (:meth:`Recorder.epitaph`);
one whose writes fail (the disk full) leaves no partial file.
"""

from __future__ import annotations

import fnmatch
import json
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from cosim.codec import state_proto
from cosim.codec.json_codec import MESSAGE_ENCODING, SCHEMA_ENCODING, codec_for, plain_state
from cosim.codec.jsontext import RecordLayout
from cosim.codec.proto_codec import MESSAGE_ENCODING as PROTO_ENCODING
from cosim.codec.proto_codec import proto_codec_for
from cosim.codec.wire import wire_codec
from cosim.errors import NO_ROOM, RecordingError, SimulationError
from cosim.messages import Message, message
from cosim.record.derive import DerivedMessage
from cosim.record.output import METADATA_NAME, check_output, nearest_existing
from cosim.record.writer import SinkError, open_sink
from cosim.scenario import Scene
from cosim.scheduler import BaseObserver, RunResult, Simulation

STATUS_TOPIC = "/cosim/status"
EVENTS_TOPIC = "/cosim/events"
CHECKPOINT_TOPIC = "/cosim/checkpoint"
PERF_TOPIC = "/perf/tick"
PERF_EVERY = 100  # ticks a /perf/tick sample covers (the run's last one also ends a sample)
SCENE_ATTACHMENT = "scene.yaml"



@message
class Event(Message):
    """A framework event: which component, what kind (e.g. ``substep``), and a sentence."""

    component: str
    kind: str
    detail: str


@message
class RunStatus(Message):
    """How the run ended: status (ok | stopped | failed | interrupted), the reason, the last tick and
    its time [s], and component steps taken."""

    status: str
    reason: str
    tick: int
    time: float
    component_steps: int


@message
class PerfSample(Message):
    """Wall-clock cost of the last ``ticks`` ticks [s] and the real-time factor (non-deterministic)."""

    ticks: int
    wall: float
    real_time_factor: float


def topic_of(component: str, port: str) -> str:
    """Channel name of an output port."""
    return f"/{component}/{port}"


def component_of(topic: str) -> str:
    """The component whose output a channel ``/component/port`` carries (:func:`topic_of`'s inverse)."""
    return topic.strip("/").split("/")[0]


Deriver = Callable[[int, str, str, Message], Iterable[DerivedMessage]]
"""Called with (time_ns, component, port, msg) for every exchange; yields extra messages to write.
A deriver may also have ``watches(component, port, message_type) -> bool``: False when it never
derives anything from that port's messages, which are then not shown to it at all; and
``due_ns(component, port) -> int``: the time [ns] before which it derives nothing more from that
port (its next frame), so that the messages before it are not shown to it either. One that the
writer can stand in for has ``writer_recipe`` (``(module, function, args)``: the writer's own copy
is ``module.function(*args)``) and ``in_writer(component, port, message_type) -> bool``: whether
the copy can derive that port's channels from its recorded messages (:mod:`cosim.record.derive`)."""


class Recorder(BaseObserver):
    """Writes a run to MCAP. Use as an observer of a :class:`Simulation`; always call :meth:`close`."""

    def __init__(self, path: str | Path, scene: Scene, *, command_line: str = "", perf: bool = False,
                 derivers: list[Any] | None = None, version: str = "", background: bool = True,
                 inputs: tuple[str | Path, ...] = (), start_ns: int = 0):
        """``inputs``: files the run reads besides the scene (never overwritten by the recording);
        ``start_ns``: the time [ns] of the checkpoint a restart begins at (0: a run from t = 0)."""
        from cosim import __version__

        self.path = check_output(path, (scene.source, *inputs))
        self.scene = scene
        self.start_ns = start_ns
        self.perf = perf
        self.derivers = list(derivers or [])
        self.patterns = scene.record.channels
        self.every = scene.record.every
        self.checkpoint_ticks = (round(scene.record.checkpoint_every * 1e9 / scene.dt_ns)
                                 if scene.record.checkpoint_every > 0 else 0)
        # the folders this run makes for the recording, the deepest first: removed again (when empty)
        # should it leave no file (a full disk said "no file was left" and left them, empty)
        # (none through a '..': 'new/../keep' is no path until 'new' exists, so the user's 'keep' was
        # listed as made here, and removed)
        self._made_folders = ([] if ".." in self.path.parent.parts else
                              [f for f in (self.path.parent, *self.path.parent.parents) if not f.exists()])
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            self._remove_made_folders()  # (those made before the one that failed)
            # a file where a folder of the path should be is named (it said "File exists", naming neither)
            blocking = nearest_existing(self.path.parent)
            if blocking is not None and not blocking.is_dir():
                raise RecordingError(f"{self.path}: cannot create its folder: {blocking} is a file, not a "
                                     "folder") from None
            raise RecordingError(f"{self.path}: cannot create its folder ({exc.strerror or exc})") from None
        # the modules a writer process imports as it starts, for the viewer channels it will derive
        preloads = tuple(dict.fromkeys(d.writer_recipe[0] for d in self.derivers
                                       if getattr(d, "writer_recipe", None) is not None))
        try:
            self.sink = open_sink(self.path, background, preloads)
        except OSError as exc:  # an output path that cannot be written is bad input, said plainly...
            self._remove_made_folders()
            reason = exc.strerror or str(exc)
            if exc.errno in NO_ROOM:  # ...but no room for even an empty file (its inodes used up) is a full disk
                raise SinkError(f"{self.path}: the recording could not be written: {reason}; no file was left") \
                    from None
            raise RecordingError(f"{self.path}: cannot write the recording ({reason})") from None
        # schema name -> (its id, encoding, data): one name is never given to a second schema
        self._schemas: dict[str, tuple[int, str, bytes]] = {}
        self._channels: dict[str, int] = {}
        self._routes: dict[tuple[str, str], list] = {}
        self._wanted: dict[str, bool] = {}
        self._in_writer: dict[int, str] = {}  # id of a deriver the writer makes channels for -> its name there
        self._closed = False
        self._sim: Simulation | None = None  # the run, once it has started
        self._steps0 = 0  # its component steps when it started
        self._finished = False  # the final status has been written
        self.sink.epitaph = self.epitaph
        self.sink.start_ns = start_ns  # a recording cut short before its first message ends where the run began
        self._mark = self.sink.mark
        self._perf_wall = time.perf_counter()
        self._perf_tick = 0
        meta = {"version": version or __version__, "scene": scene.name, "source": _utf8(scene.source),
                "overrides": json.dumps(scene.overrides), "command_line": _utf8(command_line),
                "dt_ns": str(scene.dt_ns), "until_ns": str(scene.until_ns),
                "base_dir": _utf8(scene.base_dir)}  # where the scene's relative file names (an FMU) start
        if start_ns:  # a restart: replay and inspect begin where it began
            meta["start_ns"] = str(start_ns)
        self.sink.add_metadata(METADATA_NAME, meta)
        self.sink.add_attachment(SCENE_ATTACHMENT, 0, "application/yaml", scene.text.encode())

    # --- channels ------------------------------------------------------------------------------------

    def _channel(self, topic: str, schema_name: str, schema_encoding: str, schema_data: bytes,
                 message_encoding: str, layout: RecordLayout | None = None) -> int:
        channel = self._channels.get(topic)
        if channel is None:
            schema = self._schema(topic, schema_name, schema_encoding, schema_data)
            channel = self._channels[topic] = self.sink.register_channel(
                topic, message_encoding, schema, layout)
        return channel

    def _schema(self, topic: str, schema_name: str, schema_encoding: str, schema_data: bytes) -> int:
        """The id of the schema ``schema_name``, registered the first time it is asked for. Asked for
        another schema under a name it has (two message types of one class name: the scene refuses
        them as it loads), a RecordingError: the channel would be tied to the other type's schema,
        and the recording could not be read back."""
        known = self._schemas.get(schema_name)
        if known is None:
            schema_id = self.sink.register_schema(schema_name, schema_encoding, schema_data)
            self._schemas[schema_name] = (schema_id, schema_encoding, schema_data)
            return schema_id
        if known[1:] != (schema_encoding, schema_data):
            raise RecordingError(f"{topic}: its schema {schema_name} ({schema_encoding}) differs from the one "
                                 f"this recording already holds under that name ({known[1]}): two message "
                                 "types of one class name cannot be recorded together; rename one of them")
        return known[0]

    def _message_channel(self, topic: str, msg_type: type[Message]) -> int:
        channel = self._channels.get(topic)
        if channel is None:
            proto = proto_codec_for(msg_type)
            if proto is not None:  # the writer copies these records as they are
                return self._channel(topic, proto.schema_name, PROTO_ENCODING, proto.schema_bytes(), PROTO_ENCODING)
            codec = codec_for(msg_type)
            channel = self._channel(topic, codec.schema_name, SCHEMA_ENCODING, codec.schema_bytes(),
                                    MESSAGE_ENCODING, codec.layout)
        return channel

    def write_message(self, topic: str, time_ns: int, msg: Message) -> None:
        self.sink.add_message(self._message_channel(topic, type(msg)), time_ns, wire_codec(type(msg)).encode(msg))

    def wanted(self, topic: str) -> bool:
        ok = self._wanted.get(topic)
        if ok is None:
            ok = self._wanted[topic] = selected(topic, self.patterns)
        return ok

    # --- observer interface ----------------------------------------------------------------------------

    def _route(self, component: str, port: str, msg: Message) -> list:
        """[channel (None when not recorded), write, count, encode, the derivers watching here, the
        time the next of them is due [ns], the share of its messages kept (1 in ``every``)] of an
        output port. A deriver that the writer can stand in
        for derives there instead, from this port's recorded messages (:mod:`cosim.record.derive`)."""
        topic = f"/{component}/{port}"
        msg_type = type(msg)
        codec = wire_codec(msg_type)
        channel = self._message_channel(topic, msg_type) if self.wanted(topic) else None
        watching = []
        # the writer sees only what is recorded: with every exchange recorded in full it may derive,
        # else every viewer channel is made here (a topic such as /tf is never made in both processes)
        in_full = self.patterns is None and self.every == 1
        for d in self.derivers:
            if (in_full and getattr(d, "writer_recipe", None) is not None
                    and d.in_writer(component, port, msg_type)):
                self._derive_in_writer(d, channel, component, port, msg_type)
            elif getattr(d, "watches", None) is None or d.watches(component, port, msg_type):
                watching.append(d)
        cfg = self.scene.components.get(component)
        spec = cfg.cls.outputs.get(port) if cfg is not None else None
        # an event output (a stage change, a skip) is kept whole: thinned, it would tell a false history
        every = 1 if spec is not None and spec.event else self.every
        # (the last: the port's last message passed over since its last frame, for the final frame)
        return [channel, codec.write, 0, codec.encode, tuple(watching), 0, every, None]

    def _derive_in_writer(self, deriver: Any, channel: int, component: str, port: str, msg_type: type) -> None:
        """Have the writer derive from ``channel``'s messages (those of ``/component/port``) as
        ``deriver`` would here."""
        name = self._in_writer.get(id(deriver))
        if name is None:
            name = self._in_writer[id(deriver)] = f"d{len(self._in_writer)}"
            self.sink.add_derivation(("deriver", name, deriver.writer_recipe))
        type_path = (msg_type.__module__, msg_type.__qualname__)
        self.sink.add_derivation(("derive", name, channel, component, port, type_path))

    def on_exchange(self, time_ns: int, component: str, port: str, msg: Message) -> None:
        # one dict lookup per exchange: the port's channel, codec and derivers are resolved once;
        # the message is packed into the sink's batch, and its JSON text written by the writer process
        route = self._routes.get((component, port))
        if route is None:
            route = self._routes[(component, port)] = self._route(component, port, msg)
        if route[0] is not None:
            n = route[2]
            route[2] = n + 1
            if n % route[6] == 0 and not self.sink.add_message_record(route[1], route[0], time_ns, msg):
                # an odd field (a list for an array, another dtype): the exact slow path, here
                self.sink.add_message(route[0], time_ns, route[3](msg))
        if route[4]:  # the viewer channels only at their frames
            if time_ns >= route[5]:
                route[7] = None
                self._derive(route, time_ns, component, port, msg)
            else:
                route[7] = (time_ns, msg)

    def _derive(self, route: list, time_ns: int, component: str, port: str, msg: Message,
                final: bool = False) -> None:
        due = None
        for deriver in route[4]:
            if final and not getattr(deriver, "draws_final", False):
                continue
            for extra in (deriver(time_ns, component, port, msg, final=True) if final
                          else deriver(time_ns, component, port, msg)):
                if not self.wanted(extra.topic):
                    continue
                channel = self._channel(extra.topic, extra.schema_name, extra.schema_encoding,
                                        extra.schema_data, extra.message_encoding)
                self.sink.add_message(channel, time_ns, extra.data)
            next_ns = deriver.due_ns(component, port) if hasattr(deriver, "due_ns") else time_ns
            due = next_ns if due is None else min(due, next_ns)
        route[5] = due

    def on_event(self, time_ns: int, component: str, kind: str, detail: str) -> None:
        self.write_message(EVENTS_TOPIC, time_ns, Event(component, kind, detail))

    def on_initialized(self, sim: Simulation) -> None:
        self._sim, self._steps0 = sim, sim.component_steps()
        if self.checkpoint_ticks:
            self.write_checkpoint(sim)
        self._mark()

    def on_step_complete(self, sim: Simulation) -> None:
        if self.checkpoint_ticks and sim.tick % self.checkpoint_ticks == 0:
            self.write_checkpoint(sim)
        if self.perf and sim.tick % PERF_EVERY == 0:
            self._perf_sample(sim)
        self._mark()  # the step's records are whole: the writer keeps them should this process die

    def _perf_sample(self, sim: Simulation) -> None:
        """A /perf/tick sample of the ticks since the last one."""
        now = time.perf_counter()
        wall = now - self._perf_wall
        ticks = sim.tick - self._perf_tick
        rtf = ticks * sim.dt_ns / 1e9 / wall if wall > 0 else 0.0
        self.write_message(PERF_TOPIC, sim.time_ns, PerfSample(ticks, wall, rtf))
        self._perf_wall, self._perf_tick = now, sim.tick

    def write_checkpoint(self, sim: Simulation) -> None:
        channel = self._channel(CHECKPOINT_TOPIC, state_proto.SCHEMA_NAME, state_proto.ENCODING,
                                state_proto.SCHEMA, state_proto.ENCODING)
        checkpoint = sim.checkpoint()
        try:
            state = plain_state(checkpoint)
        except TypeError:
            for name, saved in checkpoint["components"].items():  # whose state it is, named
                try:
                    plain_state(saved)
                except TypeError as exc:
                    sim.components[name].status = "failed"
                    raise SimulationError(name, sim.time_ns, f"its state for a checkpoint: {exc}") from None
            raise
        self.sink.add_state(channel, sim.time_ns, state)

    def on_finished(self, sim: Simulation, result: RunResult) -> None:
        if self.perf and sim.tick > self._perf_tick:  # the ticks since the last sample, however few
            self._perf_sample(sim)
        self.write_message(STATUS_TOPIC, sim.time_ns, RunStatus(
            result.status, result.reason, result.tick, sim.time_ns / 1e9, result.component_steps))
        # the viewer's final frame, of each port's last message after its last frame (derived here,
        # after the status, where the writer draws its own: cosim.record.derive.Derivation.finish)
        for (component, port), route in self._routes.items():
            if route[7] is not None:
                (time_ns, msg), route[7] = route[7], None
                self._derive(route, time_ns, component, port, msg, final=True)
        self._finished = True

    def epitaph(self, fate: str, end_ns: int, complete: bool, kept: str = "salvaged up to"
                ) -> tuple[int, DerivedMessage] | None:
        """The status a recording salvaged after its writer died ends with (``fate``: how the writer
        ended; ``end_ns``: the latest time salvaged; ``complete``: whether all the run sent is there;
        ``kept``: how what is there was kept, "salvaged up to" or, for a file closed where its disk
        filled, "closed where it stopped, at"), as (log time [ns], message); None when the run's own
        status is there.

        ``failed``, with the run's tick and time when everything was salvaged (as a run failing there
        would have it: replay goes up to it). Otherwise only what the writer had put on disk is there,
        and the status stands at the last tick certainly whole in it: records go out in tick order,
        and none of a tick's is stamped later than its end plus the slowest component's step.
        """
        if complete and self._finished:
            return None
        sim, dt_ns = self._sim, self.scene.dt_ns
        if complete:
            tick, steps = (sim.tick, sim.component_steps() - self._steps0) if sim is not None else (0, 0)
            reason = f"{fate} at t = {tick * dt_ns / 1e9:g} s; the recording holds all the run had recorded"
        else:
            slowest = max((c.every for c in self.scene.components.values()), default=1)
            # (never before a restart's own start: the state it began from is whole there)
            tick, steps = max(self.start_ns // dt_ns, end_ns // dt_ns - slowest), 0
            reason = (f"{fate}; the recording was {kept} t = {end_ns / 1e9:g} s, and what the run "
                      f"recorded after that was lost")
        codec = codec_for(RunStatus)  # JSON, as write_message has it: a status has text fields
        status = RunStatus("failed", reason, tick, tick * dt_ns / 1e9, steps)
        return tick * dt_ns, DerivedMessage(STATUS_TOPIC, codec.schema_name, SCHEMA_ENCODING, codec.schema_bytes(),
                                            MESSAGE_ENCODING, codec.encode(status))

    def interrupted(self) -> None:
        """The run was asked to stop (called from its signal handler): a writer process that stops
        answering is given up on instead of waited for without end (``ProcessSink.interrupted``)."""
        told = getattr(self.sink, "interrupted", None)
        if told is not None:
            told()

    def close(self) -> Path:
        """Finish the file (summary, indexes) under its final name. Safe to call twice."""
        if not self._closed:
            self._closed = True
            try:
                self.sink.close()
            except BaseException:  # a recording that could not be kept: no empty folder left for it either
                self._remove_made_folders()
                raise
        return self.path

    def discard(self) -> None:
        """Drop the file entirely (used when nothing was run), and the folders made for it."""
        if not self._closed:
            self._closed = True
            try:
                self.sink.discard()
            finally:
                self._remove_made_folders()

    def _remove_made_folders(self) -> None:
        """Remove the folders this run made for its recording, the deepest first, each only while it is
        empty: one holding anything (the recording, a file kept beside it, a writer's private file, a
        file someone put there meanwhile) stays, and so do those above it. Never raises: the error
        being reported matters more than a folder left."""
        for folder in self._made_folders:
            try:
                folder.rmdir()
            except FileNotFoundError:
                continue  # never made (a mkdir failing below its parent), or gone already
            except OSError:
                break  # not empty, or not ours to remove: nor are the folders above it
        self._made_folders = []


def _utf8(text: str) -> str:
    """``text`` as MCAP's metadata can hold it, UTF-8: a file name that is not (a byte the file system
    took, which Python carries as a lone surrogate) has that byte written as its escape (\\xff). It
    failed every recording of a scene in such a folder, blamed on the writer."""
    try:
        raw = text.encode("utf-8", "surrogateescape")
    except UnicodeEncodeError:  # a surrogate no file system byte stands for
        return text.encode("utf-8", "backslashreplace").decode("utf-8")
    return raw.decode("utf-8", "backslashreplace")


def selected(topic: str, patterns: list[str] | None) -> bool:
    """Whether a recording of ``record.channels`` ``patterns`` (None: every channel) keeps ``topic``."""
    return patterns is None or any(fnmatch.fnmatchcase(topic, p) for p in patterns)


def physics_topics(scene: Scene) -> frozenset[str]:
    """Every channel the physics writes (``/<component>/<port>``) plus the framework's own."""
    topics = {f"/{name}/{port}" for name, cfg in scene.components.items() for port in cfg.cls.outputs}
    return frozenset(topics | {STATUS_TOPIC, EVENTS_TOPIC, CHECKPOINT_TOPIC, PERF_TOPIC})
