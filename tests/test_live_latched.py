"""`cosim run --live` latches every channel: a client that subscribes gets the channel's latest
message (from each port publishing on it) with its original log time, whether it subscribed after
the channel's first message went out or after the run ended.

The client is tornado's WebSocket client speaking the Foxglove WebSocket protocol: ``advertise``
(JSON) is answered with ``subscribe``; binary frames are ``messageData`` (opcode 1: subscription id
u32, log time u64, payload) and ``time`` (opcode 2: u64).
"""

from __future__ import annotations

import asyncio
import gc
import json
import signal
import struct
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("foxglove", reason="the foxglove-sdk package is not installed")
pytest.importorskip("tornado", reason="the client of these tests is tornado's")

from tornado import websocket
from tornado.websocket import WebSocketClosedError

from components.messages import SkipRecord, Stage, StageId
from cosim.codec.json_codec import codec_for
from cosim.record.recorder import physics_topics
from cosim.scenario import load, loads
from cosim.scheduler import BaseObserver, Simulation
from cosim.view.foxglove import visual_deriver
from cosim.view.live import DEFAULT_RATE, LiveView
from tests.viewer_toys import SKIP_SCENE

PROTOCOL = "foxglove.sdk.v1"
AGAIN = 100_000  # added to a subscription id: the id of the second subscribe to the same channel
WAIT_S = 20.0  # [s of wall time] bound on every wait of these tests (a failure, not a measurement)


@pytest.fixture(autouse=True)
def sockets_closed_here():
    """Collect garbage after each test: a client socket left open would be warned of (an error under
    the suite's filterwarnings) here, naming this file, not in whatever later test collects it."""
    yield
    gc.collect()


@dataclass
class Received:
    """What the client saw: channels by topic, (log time, payload) per topic, clock broadcasts."""

    channels: dict[str, dict] = field(default_factory=dict)
    got: dict[str, list[tuple[int, bytes]]] = field(default_factory=dict)
    clock: list[int] = field(default_factory=list)


async def watch(port: int, seen: Received, done: Callable[[Received], bool], *,
                opened: Callable[[], None] = lambda: None,
                confirmed: Callable[[str], None] = lambda topic: None) -> None:
    """Connect (then call ``opened``), subscribe to every channel advertised, and collect until
    ``done`` (or for at most WAIT_S).

    Each subscribe is followed by a second one to the same channel: the server answers that with a
    warning, which says the first was processed (the SDK handles a client's messages in order and
    calls the server listener's ``on_subscribe`` within the first); ``confirmed`` is then called.
    """
    ws = await websocket.websocket_connect(f"ws://127.0.0.1:{port}", subprotocols=[PROTOCOL])
    opened()
    topics: dict[int, str] = {}  # subscription id -> topic
    by_id: dict[int, str] = {}  # channel id -> topic

    async def subscribe(topic: str) -> None:
        sub_id = next((k for k, t in topics.items() if t == topic), len(topics) + 1)
        # the second id: the server warns, "already subscribed" (or, if the first came too early
        # for a new channel, that one is the subscription)
        for each in (sub_id, sub_id + AGAIN):
            topics[each] = topic
            subscription = {"id": each, "channelId": seen.channels[topic]["id"]}
            await ws.write_message(json.dumps({"op": "subscribe", "subscriptions": [subscription]}))

    deadline = time.monotonic() + WAIT_S
    try:
        while not done(seen) and (left := deadline - time.monotonic()) > 0:
            try:
                frame = await asyncio.wait_for(ws.read_message(), timeout=left)
            except TimeoutError:
                break
            if frame is None:
                break
            if isinstance(frame, str):
                msg = json.loads(frame)
                text = msg.get("message", "")
                if msg["op"] == "advertise":
                    for ch in msg["channels"]:
                        seen.channels[ch["topic"]] = ch
                        by_id[ch["id"]] = ch["topic"]
                        await subscribe(ch["topic"])
                elif msg["op"] == "status" and text.startswith("Unknown channel ID"):
                    # a subscribe sent right after an advertisement can reach the server before it
                    # has registered that channel: ask again
                    await asyncio.sleep(0.01)
                    await subscribe(by_id[int(text.rsplit(" ", 1)[1])])
                elif msg["op"] == "status" and text.startswith("Client is already subscribed to channel: "):
                    topic = by_id[int(text.split(": ", 1)[1].split(";", 1)[0])]
                    confirmed(topic)
            elif frame[0] == 1:
                sub_id, log_time = struct.unpack_from("<IQ", frame, 1)
                seen.got.setdefault(topics[sub_id], []).append((log_time, bytes(frame[13:])))
            elif frame[0] == 2:
                seen.clock.append(struct.unpack_from("<Q", frame, 1)[0])
    finally:
        await _close(ws)


async def _close(ws) -> None:
    """Close the client and wait (bounded) until its socket is: tornado closes it only once the
    server answers the close, after ``close()`` has returned; a socket still open when the test's
    event loop ends is warned of (ResourceWarning) wherever the garbage collector finds it, in
    whatever test runs then."""
    ws.close()
    deadline = time.monotonic() + WAIT_S
    while (left := deadline - time.monotonic()) > 0:
        try:
            if await asyncio.wait_for(ws.read_message(), timeout=left) is None:
                break
        except (TimeoutError, WebSocketClosedError):
            break
    stream = getattr(getattr(ws, "protocol", None), "stream", None)
    if stream is not None and not stream.closed():  # the server never answered: closed here
        stream.close()


class Latest(BaseObserver):
    """The latest message on every channel from each port publishing on it, as the live view
    should latch them: physics channels JSON-encoded, viewer channels from a deriver of its own
    (the deriver is deterministic: the same exchanges give the same bytes); of a SceneUpdate channel,
    whose messages hold only the entities that changed, the latest message carrying each entity."""

    def __init__(self, sim: Simulation):
        scene = sim.scene
        self.deriver = visual_deriver(scene.record.visual_rate or DEFAULT_RATE, physics_topics(scene))
        self.deriver.bind(sim.components)
        self.latest: dict[str, dict[tuple, tuple[int, bytes]]] = {}

    def on_exchange(self, time_ns: int, component: str, port: str, msg: Any) -> None:
        from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

        encoded = codec_for(type(msg)).encode(msg)
        self.latest.setdefault(f"/{component}/{port}", {})[component, port] = (time_ns, encoded)
        for extra in self.deriver(time_ns, component, port, msg):
            held = self.latest.setdefault(extra.topic, {})
            if extra.schema_name == "foxglove.SceneUpdate":
                for entity in SceneUpdate.FromString(extra.data).entities:
                    held[component, port, entity.id] = (time_ns, extra.data)
            else:
                held[component, port] = (time_ns, extra.data)

    def wanted(self) -> dict[str, list[tuple[int, bytes]]]:
        """By channel, the messages a late viewer gets, each once, in order."""
        return {topic: sorted(set(by_source.values())) for topic, by_source in self.latest.items()}


def test_a_viewer_connecting_after_the_run_gets_every_channels_latest_message():
    """While the finished run lingers, a client that connects and subscribes receives, on every
    channel, exactly the latest message of each port publishing on it, with its original log time
    (before: only clock broadcasts)."""
    scene = loads(SKIP_SCENE)
    sim = Simulation(scene)
    view = LiveView(scene, "127.0.0.1:0", speed=0.0, components=sim.components, announce=False)
    expected = Latest(sim)
    sim.observers += [view, expected]
    sim.run()
    want = expected.wanted()
    seen = Received()
    main = threading.main_thread().ident
    assert main is not None

    def client() -> None:
        try:
            asyncio.run(watch(view.port, seen, lambda s: bool(s.clock) and set(s.channels) == set(want)
                              and all(len(s.got.get(t, ())) >= len(w) for t, w in want.items())))
        finally:
            # anything received came from linger's loop, so linger is running: end it as Ctrl-C
            # does (with nothing received it ends after its own bound)
            if seen.got:
                signal.pthread_kill(main, signal.SIGINT)

    runner = threading.Thread(target=client)
    runner.start()
    try:
        view.linger(2 * WAIT_S, say=False)  # longer than the client's bound: its signal lands in here
    finally:
        runner.join(timeout=WAIT_S)
        view.close()
    assert set(seen.channels) == set(want)
    assert {"/stages/stage", "/stages/skip", "/scene/stone", "/tf", "/stone/state"} <= set(want)
    assert {topic: sorted(got) for topic, got in seen.got.items()} == want
    assert seen.clock and seen.clock[-1] == scene.until_ns
    stage = codec_for(Stage).decode(seen.got["/stages/stage"][0][1])
    skip = codec_for(SkipRecord).decode(seen.got["/stages/skip"][0][1])
    assert (stage.label, skip.index) == ("approach", 3)  # the run's last stage and last skip


class Gate(BaseObserver):
    """Holds the run at the end of the step in which a watched topic's first message was published,
    until the client has subscribed to it. ``topics`` maps each watched topic to the channel whose
    exchange publishes it first (a viewer channel: the physics channel it is derived from).
    Observers run in order: placed before the live view, it holds the run before the live view's
    end-of-step work sends what was subscribed to."""

    def __init__(self, topics: dict[str, str]):
        self.triggers = dict(topics)
        self.subscribed = {topic: threading.Event() for topic in topics}
        self.fresh: set[str] = set()

    def on_exchange(self, time_ns: int, component: str, port: str, msg: Any) -> None:
        for topic, source in list(self.triggers.items()):
            if source == f"/{component}/{port}":
                del self.triggers[topic]
                self.fresh.add(topic)

    def on_step_complete(self, sim: Simulation) -> None:
        for topic in sorted(self.fresh):
            if not self.subscribed[topic].wait(WAIT_S):
                raise AssertionError(f"the client did not subscribe to {topic} within {WAIT_S} s")
        self.fresh.clear()


def test_a_viewer_connected_from_the_start_gets_each_channels_first_message():
    """A channel is created (and advertised) with its first message, before any client can have
    subscribed to it: the first stage ("approach"), the first skip and the 3D stone (re-sent only
    once a second) still reach a client connected from the start, the stages once each and in
    order with the rest (before: all three were lost)."""
    scene = loads(SKIP_SCENE)
    sim = Simulation(scene)
    view = LiveView(scene, "127.0.0.1:0", speed=0.0, components=sim.components, announce=False)
    gate = Gate({"/stages/stage": "/stages/stage", "/stages/skip": "/stages/skip", "/scene/stone": "/stone/state"})
    published: dict[str, list[tuple[int, bytes]]] = {}

    class Published(BaseObserver):
        def on_exchange(self, time_ns: int, component: str, port: str, msg: Any) -> None:
            if component == "stages":
                encoded = codec_for(type(msg)).encode(msg)
                published.setdefault(f"/{component}/{port}", []).append((time_ns, encoded))

    sim.observers += [gate, view, Published()]
    runner = threading.Thread(target=sim.run)
    seen = Received()

    def confirmed(topic: str) -> None:
        if topic in gate.subscribed:
            gate.subscribed[topic].set()

    def finished(s: Received) -> bool:
        # the clock and the messages reach the client in queues of their own: wait for both
        return (not runner.is_alive() and bool(s.clock) and s.clock[-1] == scene.until_ns
                and all(len(s.got.get(topic, ())) >= len(sent) for topic, sent in published.items()))

    try:
        asyncio.run(watch(view.port, seen, finished, opened=runner.start, confirmed=confirmed))
    finally:
        if runner.ident is not None:
            runner.join(timeout=WAIT_S)
        view.close()
    assert not runner.is_alive() and seen.clock[-1] == scene.until_ns
    assert seen.got["/stages/stage"] == published["/stages/stage"]
    assert seen.got["/stages/skip"] == published["/stages/skip"]
    first_stage = codec_for(Stage).decode(seen.got["/stages/stage"][0][1])
    first_skip = codec_for(SkipRecord).decode(seen.got["/stages/skip"][0][1])
    assert (first_stage.stage, first_skip.index) == (StageId.APPROACH, 1)
    assert seen.got["/scene/stone"][0][0] == 0  # the stone from the start, not a second later


class _RegisteredChannel:
    """A channel as the SDK holds it between registering a new subscription and telling the listener
    of it: it has a sink (has_sinks), and what is logged reaches that subscriber."""

    def __init__(self) -> None:
        self.logged: list[tuple[bytes, int]] = []

    def has_sinks(self) -> bool:
        return True

    def log(self, data: bytes, *, log_time: int) -> None:
        self.logged.append((data, log_time))


class _Told:
    topic = "/stages/stage"


def test_a_message_logged_before_the_listener_hears_of_its_subscriber_reaches_it_once():
    """The SDK registers a subscription, and logs to it, before it calls the listener's on_subscribe
    (which waits for the GIL): a stage logged in between went out live, and again as the latest once
    the subscription was noted (a viewer got the run's first stage twice on a loaded machine). Live
    messages go only to subscriptions noted: the first stage reaches the viewer once, as the latest,
    and the next ones live."""
    scene = loads(SKIP_SCENE)
    view = LiveView(scene, "127.0.0.1:0", speed=0.0, announce=False)
    try:
        channel = view._channels["/stages/stage"] = _RegisteredChannel()
        first = Stage(StageId.APPROACH, "approach", 0, 0.3, 0.0, 0.0)
        view.on_exchange(1_000_000, "stages", "stage", first)  # subscription registered, not yet noted
        view._subscriptions.on_subscribe(None, _Told())
        view._send_latest()
        hit = Stage(StageId.HIT, "hit", 0, 0.9, 0.0, 0.06)
        view.on_exchange(60_000_000, "stages", "stage", hit)
        view._send_latest()
        encode = codec_for(Stage).encode
        assert channel.logged == [(encode(first), 1_000_000), (encode(hit), 60_000_000)]
    finally:
        view.close()


def test_a_viewer_that_comes_after_the_run_gets_the_whole_trail():
    """A SceneUpdate holds only the entities that changed: the held skip's trail sends its path about
    once a second and its tip every frame, so the latest message alone, latched, drew a viewer that
    came after the run the stone's last three points. The latest message carrying each entity is
    latched: the path (its 59 points before the tip) and the tip."""
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

    from cosim.runner import run_scene

    scene = load(Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml", ["until=2.0"])
    view = run_scene(scene, None, live="127.0.0.1:0", live_speed=0, keep_live=True, progress=False).live
    try:
        topic = "/scene/stone/trail"
        channel = view._channels[topic] = _RegisteredChannel()

        class Subscribed:
            pass

        Subscribed.topic = topic
        view._subscriptions.on_subscribe(None, Subscribed())
        view._send_latest()
        entities = {e.id: sum(len(line.points) for line in e.lines)
                    for data, _ in channel.logged for e in SceneUpdate.FromString(data).entities}
        assert entities.keys() == {"trail", "trail-tip"} and entities["trail"] >= 50
        assert [t for _, t in channel.logged] == sorted(t for _, t in channel.logged)
    finally:
        view.close()
