"""``cosim run --live``: stream a run to Foxglove (or Lichtblick) over WebSocket while it simulates.

An observer, imported only when ``--live`` is given, built on the ``foxglove-sdk`` package (which
also writes every recording). It publishes the same channels as a recording: every exchange on
``/<component>/<port>`` as JSON with its ``cosim.<Type>`` JSON schema, and the viewer channels of a
:class:`cosim.view.items.VisualDeriver` (its own instance, at the scene's visual rate or
:data:`DEFAULT_RATE`) as Foxglove protobufs, each with log time = simulation time. The server
announces the simulation clock (the ``time`` capability), and the run is paced at ``speed`` times
real time so it can be watched (``speed`` 0: as fast as it goes). Like the recorder, it only reads
messages: the physics is the same with or without it. The exchanges are encoded only for channels a
client subscribes to; the viewer channels (the transforms, the stone's looks and trail, the water's
mesh) are made at every frame, subscribed to or not. The channels are made as the server starts,
before the run (every output port and the viewer topics its looks give), so a viewer is told of all
of them at once; a topic not foreseen is made at its first message. The SDK's own warnings and
errors are not passed to the application's logging: a viewer that drops is one line on stderr, not
one per message it missed.

Every channel is latched: it keeps its latest message from each port that publishes on it (``/tf``
carries every body's transform, each from its own body's state), and a client that subscribes is
sent those with their original log times, so a viewer sees the current stage, the last skip and the
stone at once, whether it subscribed before a channel's first message went out or after the run ended.

When the run ends, :meth:`LiveView.linger` keeps the server up with the finished run's last clock
(``cosim run --live`` does so until Ctrl-C, or for ``--live-linger`` seconds), so a viewer can still
connect after a run that lasted two seconds; Ctrl-C or SIGTERM then end it cleanly.
"""

from __future__ import annotations

import logging
import math
import re
import signal
import sys
import threading
import time
from typing import Any

from cosim.codec.json_codec import MESSAGE_ENCODING, SCHEMA_ENCODING, codec_for
from cosim.errors import CosimError
from cosim.messages import Message
from cosim.record.recorder import physics_topics
from cosim.scenario import Scene
from cosim.scheduler import BaseObserver, RunResult, Simulation
from cosim.timebase import NS_PER_S

DEFAULT_ADDRESS = "127.0.0.1:8765"
DEFAULT_RATE = 30.0  # [frames/s] of viewer channels when the scene records none
CLOCK_PERIOD_S = 1 / 60  # [s of wall time] between clock broadcasts
MIN_SLEEP_S = 0.002  # [s] pacing sleeps shorter than this are skipped (timer resolution)
STALL_S = 0.25  # [s] a step this late is a stall: the pacing starts again from it instead of catching up
PACE_SLICE_S = 0.1  # [s] the longest a pacing sleep lasts before it looks whether the run was asked to stop
LINGER_TICK_S = 0.25  # [s of wall time] between checks (and clock broadcasts) while lingering
# [s of wall time] how long closing waits for the viewers to close their connections: the SDK's
# server.stop() waits for every one, and a viewer that never answers (a tab hung on the port, a laptop
# asleep, a connection that never finished its handshake) held Ctrl-C and --live-linger's end until
# it dropped, 40 s and more; past this the process ends and its connections with it
STOP_WAIT_S = 2.0


class LiveViewError(CosimError):
    """The live view cannot start (package missing, bad address, port in use): the --live given
    cannot be used, so bad input (exit 2)."""

    exit_code = 2


def parse_address(address: str) -> tuple[str, int]:
    """``PORT``, ``HOST:PORT`` or ``HOST`` -> (host, port); the default host is loopback."""
    default_host, default_port = DEFAULT_ADDRESS.rsplit(":", 1)
    text = address.strip()
    host, sep, port_text = text.rpartition(":")
    if not sep:
        host, port_text = (default_host, text) if text.isdigit() else (text, default_port)
    host = host or default_host
    if not port_text.isdigit() or not 0 <= int(port_text) <= 65535:
        raise LiveViewError(f"--live {address!r}: expected PORT or HOST:PORT with a port in 0..65535")
    return host, int(port_text)


SDK_LOGGER = "foxglove"  # the logger whose children carry the SDK's records into Python's logging
# a client's address in the SDK's records ("Error sending message to client 127.0.0.1:5170: ...")
SUBPROTOCOL = "foxglove.sdk.v1"  # the WebSocket subprotocol the SDK's server (0.30) accepts
CLIENT_ADDRESS = re.compile(r"\bclient (\[[^\]]*\]:\d+|[^\s:]+:\d+)", re.IGNORECASE)


_OPEN_VIEWS = 0  # live views open in this process: the SDK's records are said only while one is


class _ViewerNotes(logging.Handler):
    """Where the SDK's warnings and errors go instead of the application's logging: one line on
    stderr per viewer its errors are about, saying the viewer has gone, and each other text once.

    A viewer that drops without closing the connection (a browser tab closed, a laptop asleep) made
    the SDK log an error for every message it could then not send, 40 to 57 lines for one viewer,
    through Python's last-resort handler onto the run's output: all of them about one event."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self._said: set[str] = set()  # the clients and texts said so far

    def emit(self, record: logging.LogRecord) -> None:
        if not _OPEN_VIEWS:  # a server closed, still letting its last connections go: nothing to say
            return
        text = " ".join(record.getMessage().split())
        found = CLIENT_ADDRESS.search(text)
        # the SDK's errors about a client are failures to talk to it (sending, receiving, its
        # handshake): after the first, the connection is gone
        gone = found is not None and record.levelno >= logging.ERROR
        key = found.group(1) if gone and found else text
        if key in self._said:
            return
        self._said.add(key)
        if gone and "handshake failed" in text:
            # it never connected: the SDK's server speaks foxglove.sdk.v1 only, and answered a viewer
            # offering the older foxglove.websocket.v1 with a 400, said as "disconnected"; its record
            # is the same for anything else that never completes the handshake (a browser page, curl,
            # a connection that sends nothing), so the line names the likely cause among the others
            line = (f"live view: connection {key} dropped: its WebSocket handshake failed (this server speaks the "
                    f"{SUBPROTOCOL} subprotocol only: a viewer offering only foxglove.websocket.v1, as older "
                    "Foxglove Studio and Lichtblick releases do, cannot connect and can open the recording "
                    "instead; a browser page, curl, or a connection that sent nothing ends the same way)")
        elif gone:
            line = f"live view: viewer {key} disconnected"
        else:
            line = f"live view: foxglove-sdk: {text}"
        try:
            # sys.stderr looked up now, not when made: it may have been replaced since (tests, a caller)
            print(line, file=sys.stderr, flush=True)
        except (OSError, ValueError):  # stderr closed or gone: nothing to tell it with
            pass


def _stop_server(server: Any) -> None:
    """Stop the SDK's ``server`` of an open live view, which is no longer counted open (what the
    server still logs of its connections is not said), waiting at most STOP_WAIT_S for its viewers
    to close their connections, or less if interrupted (a Ctrl-C then ends the wait, not the
    command's own ending): the stop goes on in a daemon thread, which the process's exit ends."""
    global _OPEN_VIEWS
    _OPEN_VIEWS -= 1
    stopping = threading.Thread(target=server.stop, name="live-view-stop", daemon=True)
    stopping.start()
    try:
        stopping.join(STOP_WAIT_S)
    except KeyboardInterrupt:
        pass


def _quiet_sdk_logs() -> None:
    """Route the SDK's log records to :class:`_ViewerNotes` only (once per process), before a server
    starts: the SDK forwards them to Python's logging, where with no handler configured Python's
    last-resort handler printed every one on stderr."""
    logger = logging.getLogger(SDK_LOGGER)
    if not any(isinstance(h, _ViewerNotes) for h in logger.handlers):
        logger.addHandler(_ViewerNotes())
        logger.setLevel(logging.WARNING)  # its debug and info records are never even formatted
        logger.propagate = False


SCENE_UPDATE = "foxglove.SceneUpdate"  # the schema of viewer channels whose messages hold entities


def _entity_ids(data: bytes) -> list[str]:
    """The ids of the entities a SceneUpdate's bytes hold."""
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

    return [entity.id for entity in SceneUpdate.FromString(data).entities]


class _Subscriptions:
    """The server's listener: notes the topics clients subscribe to, for the main thread to send
    their latest messages (the SDK calls it on a server thread, where logging can deadlock)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._topics: set[str] = set()
        self._subscribers: dict[str, int] = {}  # by topic, the subscriptions noted and not ended

    def on_subscribe(self, client: Any, channel: Any) -> None:
        with self._lock:
            self._topics.add(channel.topic)
            self._subscribers[channel.topic] = self._subscribers.get(channel.topic, 0) + 1

    def on_unsubscribe(self, client: Any, channel: Any) -> None:
        """A subscription ended (also each of a client's when it leaves; a channel's latest messages
        are kept for the next subscriber)."""
        with self._lock:
            left = self._subscribers.get(channel.topic, 0) - 1
            if left > 0:
                self._subscribers[channel.topic] = left
            else:
                self._subscribers.pop(channel.topic, None)

    def noted(self, topic: str) -> bool:
        """Whether a subscription to ``topic`` has been noted (:meth:`on_subscribe`) and not ended:
        what is logged live, rather than the channel's own ``has_sinks()``. The SDK registers a
        subscription, and logs to it, before it calls :meth:`on_subscribe` (which waits for the
        GIL): a message logged in between reached the new client live, :meth:`served` found nothing
        to take back, and the latest was sent again once the subscription was noted (a viewer got
        the run's first stage twice on a loaded machine). (A dictionary read: no lock.)"""
        return topic in self._subscribers

    def served(self, topic: str) -> None:
        """The latest message of ``topic``'s only source was just logged: every subscriber noted so
        far has it, so sending it again would only repeat it."""
        with self._lock:
            self._topics.discard(topic)

    def take(self) -> list[str]:
        """The topics subscribed to since the last call, sorted (a fixed order of sending)."""
        with self._lock:
            topics, self._topics = sorted(self._topics), set()
        return topics


class LiveView(BaseObserver):
    """Streams exchanges and viewer channels to a Foxglove WebSocket server; call :meth:`close`."""

    def __init__(self, scene: Scene, address: str = DEFAULT_ADDRESS, *, speed: float = 1.0,
                 components: dict[str, Any] | None = None, announce: bool = True):
        try:
            import foxglove
        except ImportError:
            raise LiveViewError("--live needs the foxglove-sdk package (a dependency of cosim): "
                               "pip install foxglove-sdk") from None
        from cosim.view.foxglove import visual_deriver

        if not speed >= 0:
            raise LiveViewError(f"live speed must be >= 0 (got {speed})")
        host, port = parse_address(address)
        self._foxglove = foxglove
        self.context = foxglove.Context()
        self._subscriptions = _Subscriptions()
        _quiet_sdk_logs()
        global _OPEN_VIEWS
        try:
            self.server = foxglove.start_server(
                name=f"cosim: {scene.name}", host=host, port=port, context=self.context,
                capabilities=[foxglove.Capability.Time], server_listener=self._subscriptions)
        except Exception as exc:  # the SDK reports bind failures as plain runtime errors
            raise LiveViewError(f"--live {address}: cannot start the WebSocket server ({exc})") from None
        _OPEN_VIEWS += 1
        self.host, self.port = host, self.server.port
        self.speed = speed
        self.deriver = visual_deriver(scene.record.visual_rate or DEFAULT_RATE, physics_topics(scene))
        if components:
            self.deriver.bind(components)
        self._channels: dict[str, Any] = {}
        try:
            self._advertise(scene)
        except BaseException:  # a server left running would keep the process alive
            _stop_server(self.server)
            raise
        # per topic, the latest message from each (component, port) publishing on it, with its log
        # time [ns]: a physics Message (encoded only when a client subscribes) or a viewer
        # channel's bytes; a viewer channel such as /tf or /log has several sources, and the latest
        # of just one of them would leave the others' frames unknown to a late viewer
        self._latest: dict[str, dict[tuple[str, str], tuple[Message | bytes, int]]] = {}
        # per SceneUpdate topic instead, the latest message that carried each entity, by (component,
        # port, entity id): a SceneUpdate holds only the entities that changed (a trail's path is sent again
        # about once a second, its tip every frame), so its latest message alone drew a late viewer
        # the stone with no path
        self._entities: dict[str, dict[tuple[str, str, str], tuple[bytes, int]]] = {}
        self._wall0 = 0.0
        self._sim0 = 0
        self._last_clock = 0.0
        self._closed = False
        self._sim_end: int | None = None  # the finished run's simulation time [ns]
        # per (component, port), its last message when it came after the port's last frame: drawn as
        # the run ends, as a recording draws it (the viewer showed the stone up to a frame short of its
        # end, where the recording of the same run showed where it ended)
        self._undrawn: dict[tuple[str, str], tuple[int, Message]] = {}
        if announce:
            print(f"live view: {self.url} (Foxglove: Open connection > Foxglove WebSocket)", file=sys.stderr)

    @property
    def url(self) -> str:
        """The address a Foxglove client opens (an IPv6 host in brackets)."""
        host = f"[{self.host}]" if ":" in self.host and not self.host.startswith("[") else self.host
        return f"ws://{host}:{self.port}"

    def _advertise(self, scene: Scene) -> None:
        """Make now, before the run, every channel it is known to publish on: each component's output
        ports, and the viewer topics their looks give (:meth:`VisualDeriver.foreseen`). The SDK's
        server can lose a channel made mid-run: advertised to a connected client while this thread
        holds the GIL, a subscription that follows at once may be answered "Unknown channel ID", and
        the viewer then never gets that channel (the stage monitor's /stages/skip, first published
        at the first skip). A topic not foreseen is still made at its first message."""
        from cosim.view.foxglove import MESSAGE_ENCODING as VIEWER_ENCODING
        from cosim.view.foxglove import SCHEMA_ENCODING as VIEWER_SCHEMA_ENCODING
        from cosim.view.foxglove import item_schema, schema_data

        ports = [(name, port, spec.type) for name, cfg in scene.components.items()
                 for port, spec in cfg.cls.outputs.items()]
        for name, port, message_type in ports:
            codec = codec_for(message_type)
            self._channel(f"/{name}/{port}", codec.schema_name, SCHEMA_ENCODING, codec.schema_bytes(),
                          MESSAGE_ENCODING)
        for name, port, message_type in ports:
            for item in self.deriver.foreseen(name, port, message_type):
                cls = item_schema(item)
                self._channel(item.topic, cls.DESCRIPTOR.full_name, VIEWER_SCHEMA_ENCODING, schema_data(cls),
                              VIEWER_ENCODING)

    def _channel(self, topic: str, schema_name: str, schema_encoding: str, schema_data: bytes,
                 message_encoding: str) -> Any:
        channel = self._channels.get(topic)
        if channel is None:
            fg = self._foxglove
            channel = self._channels[topic] = fg.Channel(
                topic, schema=fg.Schema(name=schema_name, encoding=schema_encoding, data=schema_data),
                message_encoding=message_encoding, context=self.context)
        return channel

    # --- observer interface ---------------------------------------------------------------------

    def on_initialized(self, sim: Simulation) -> None:
        self._wall0 = time.perf_counter()
        self._sim0 = sim.time_ns
        self.server.broadcast_time(sim.time_ns)

    def on_exchange(self, time_ns: int, component: str, port: str, msg: Message) -> None:
        topic = f"/{component}/{port}"
        channel = self._channels.get(topic)
        if channel is None:
            codec = codec_for(type(msg))
            channel = self._channel(topic, codec.schema_name, SCHEMA_ENCODING, codec.schema_bytes(),
                                    MESSAGE_ENCODING)
        self._latest.setdefault(topic, {})[component, port] = (msg, time_ns)
        noted = self._subscriptions.noted
        if noted(topic):
            channel.log(codec_for(type(msg)).encode(msg), log_time=time_ns)
            self._subscriptions.served(topic)
        if time_ns < self.deriver.due_ns(component, port):
            self._undrawn[component, port] = (time_ns, msg)
        else:
            self._undrawn.pop((component, port), None)
        self._publish(time_ns, component, port, self.deriver(time_ns, component, port, msg))

    def _publish(self, time_ns: int, component: str, port: str, extras: Any) -> None:
        """Send the viewer items ``extras`` the deriver made of ``component``'s ``port`` at ``time_ns``,
        and keep each as the latest of its topic (or entity) for a viewer that subscribes later."""
        noted = self._subscriptions.noted
        for extra in extras:
            scene = extra.schema_name == SCENE_UPDATE
            if scene:
                held = self._entities.setdefault(extra.topic, {})
                for entity in _entity_ids(extra.data):
                    held[component, port, entity] = (extra.data, time_ns)
            else:
                self._latest.setdefault(extra.topic, {})[component, port] = (extra.data, time_ns)
            derived = self._channel(extra.topic, extra.schema_name, extra.schema_encoding, extra.schema_data,
                                    extra.message_encoding)
            if noted(extra.topic):
                derived.log(extra.data, log_time=time_ns)
                # else a new subscriber still lacks the other sources' messages, or the entities
                # earlier messages of this one carried
                if not scene and len(self._latest[extra.topic]) == 1:
                    self._subscriptions.served(extra.topic)

    def _send_latest(self) -> None:
        """Send each newly subscribed channel its latest messages, with their original log times.

        The SDK cannot address one client from Python (``Channel.log``'s ``sink_id`` names a sink,
        and the Python ``Client`` gives only its client id, not its sink id), so they go to the
        channel: a client subscribed earlier gets them once more, with the same log times.
        """
        for topic in self._subscriptions.take():
            # oldest first (a stable sort: sources with equal times keep their first-publish order)
            # (a channel made before the run may have none yet: its first message goes to it as usual);
            # a SceneUpdate topic's messages that carry the latest of each entity, each once, the later
            # replacing what the earlier drew of the same entities
            if topic in self._entities:
                latest = list({id(data): (data, t) for data, t in self._entities[topic].values()}.values())
            else:
                latest = list(self._latest.get(topic, {}).values())
            for data, log_time in sorted(latest, key=lambda message: message[1]):
                if not isinstance(data, bytes):
                    data = codec_for(type(data)).encode(data)
                self._channels[topic].log(data, log_time=log_time)

    def on_step_complete(self, sim: Simulation) -> None:
        now = time.perf_counter()
        if self.speed > 0:
            due = self._wall0 + (sim.time_ns - self._sim0) / NS_PER_S / self.speed
            if due - now > MIN_SLEEP_S:
                # in short sleeps, each ended by a signal's request to stop (a signal's handler only
                # asks: one long sleep sat out Ctrl-C and SIGTERM for as long as the pace had it wait)
                while due - now > MIN_SLEEP_S and sim.interrupt_reason is None:
                    time.sleep(min(due - now, PACE_SLICE_S))
                    now = time.perf_counter()
            elif now - due > STALL_S:
                # stalled (kernels compiling, a stopped process): paced on from here, not run flat out
                # until the time lost is made up (after 50 s of compiling, a 0.5x run played its first
                # 2.2 s, the skips, at 0.94x real time); a late step short of that, the jitter of a slow
                # frame or a collection, is made up as before, so the pace holds on average
                self._wall0, self._sim0 = now, sim.time_ns
        if now - self._last_clock >= CLOCK_PERIOD_S:
            self._last_clock = now
            self.server.broadcast_time(sim.time_ns)
        self._send_latest()

    def on_finished(self, sim: Simulation, result: RunResult) -> None:
        # the end is drawn whatever the frame rate: each port's last message after its last frame
        undrawn, self._undrawn = self._undrawn, {}
        for (component, port), (time_ns, msg) in undrawn.items():
            self._publish(time_ns, component, port, self.deriver(time_ns, component, port, msg, final=True))
        self._sim_end = sim.time_ns
        self.server.broadcast_time(sim.time_ns)
        self._send_latest()

    def linger(self, seconds: float = math.inf, *, say: bool = True) -> None:
        """Keep serving after the run for ``seconds`` of wall time (inf: until Ctrl-C or SIGTERM),
        saying so in one line; returns normally on Ctrl-C or SIGTERM and then closes the server."""
        clock = self._sim_end

        def stop(signum: int, frame: Any) -> None:
            raise KeyboardInterrupt

        old = None
        # everything from here on inside the try: a Ctrl-C that lands anywhere, even before the
        # loop starts, still ends in close() (a server left open would keep the process alive)
        try:
            try:
                old = signal.signal(signal.SIGTERM, stop)
            except ValueError:  # not the main thread: Ctrl-C and SIGTERM are the main thread's to handle
                old = None
            if say:
                until = "Ctrl-C to stop" if math.isinf(seconds) else f"for {seconds:g} s (Ctrl-C to stop sooner)"
                print(f"run finished; still serving on {self.url}; {until}", file=sys.stderr, flush=True)
            deadline = time.monotonic() + seconds
            while (left := deadline - time.monotonic()) > 0:
                time.sleep(min(LINGER_TICK_S, left))
                if clock is not None:  # a client that connects now learns where the run ended
                    self.server.broadcast_time(clock)
                self._send_latest()  # and what each channel it subscribes to showed last
        except KeyboardInterrupt:
            pass
        finally:
            if old is not None:
                signal.signal(signal.SIGTERM, old)
            self.close()

    def close(self) -> None:
        """Stop the server (safe to call twice)."""
        if not self._closed:
            self._closed = True
            # The server is stopped without closing its channels one by one first: Channel.close
            # waits for a lock of the SDK while holding the GIL, and a server thread that holds that
            # lock while it waits for the GIL (as when a viewer has just disconnected) then waits for
            # ever (seen as a hang on Ctrl-C). Stopping the server ends every channel's subscribers.
            _stop_server(self.server)
