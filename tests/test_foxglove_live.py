"""`cosim run --live`: the Foxglove WebSocket server streams the run's channels to a real client.

The client below speaks just enough of RFC 6455 and the Foxglove WebSocket protocol: handshake,
``serverInfo`` and ``advertise`` (JSON text frames), ``subscribe``, then binary ``messageData``
frames (opcode 1, subscription id u32, log time u64, payload) and ``time`` frames (opcode 2).
"""

from __future__ import annotations

import base64
import json
import logging
import os
import re
import socket
import struct
import threading
import time
import types

import pytest

pytest.importorskip("foxglove", reason="the foxglove-sdk package is not installed")

from components.messages import BodyState, SkipRecord
from cosim.codec.json_codec import codec_for
from cosim.scenario import loads
from cosim.scheduler import Simulation
from cosim.view.live import LiveView, LiveViewError, parse_address
from tests.viewer_toys import SKIP_SCENE, record_skip

PROTOCOL = "foxglove.sdk.v1"


class WsClient:
    """A minimal WebSocket client: handshake with a subprotocol, read frames, send masked text."""

    def __init__(self, host: str, port: int, protocol: str = PROTOCOL, timeout: float = 10.0):
        self.sock = socket.create_connection((host, port), timeout=timeout)
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall((f"GET / HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
                           f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n"
                           f"Sec-WebSocket-Protocol: {protocol}\r\n\r\n").encode())
        self.buf = b""
        while b"\r\n\r\n" not in self.buf:
            self.buf += self.sock.recv(4096)
        head, self.buf = self.buf.split(b"\r\n\r\n", 1)
        self.status = head.split(b"\r\n", 1)[0].decode()

    def _read(self, n: int) -> bytes:
        while len(self.buf) < n:
            chunk = self.sock.recv(65536)
            if not chunk:
                raise ConnectionError("closed by the server")
            self.buf += chunk
        out, self.buf = self.buf[:n], self.buf[n:]
        return out

    def recv(self) -> tuple[int, bytes]:
        b0, b1 = self._read(2)
        n = b1 & 0x7F
        if n == 126:
            n = struct.unpack(">H", self._read(2))[0]
        elif n == 127:
            n = struct.unpack(">Q", self._read(8))[0]
        return b0 & 0x0F, self._read(n)

    def send_json(self, obj: dict) -> None:
        data = json.dumps(obj).encode()
        mask = os.urandom(4)
        if len(data) < 126:
            head = bytes([0x81, 0x80 | len(data)])
        else:
            head = bytes([0x81, 0x80 | 126]) + struct.pack(">H", len(data))
        self.sock.sendall(head + mask + bytes(b ^ mask[i % 4] for i, b in enumerate(data)))

    def close(self) -> None:
        self.sock.close()


def test_addresses_parse_to_host_and_port():
    """--live takes PORT, HOST:PORT or HOST; loopback and 8765 are the defaults."""
    assert parse_address("9000") == ("127.0.0.1", 9000)
    assert parse_address("0.0.0.0:1234") == ("0.0.0.0", 1234)
    assert parse_address("localhost") == ("localhost", 8765)
    with pytest.raises(LiveViewError, match=r"port in 0\.\.65535"):
        parse_address("host:99999")


def test_the_server_starts_on_a_loopback_port_and_stops():
    """The live view listens on loopback (port 0: any free one) and refuses connections once closed."""
    view = LiveView(loads(SKIP_SCENE), "127.0.0.1:0", announce=False)
    try:
        assert view.host == "127.0.0.1" and view.port > 0 and view.url == f"ws://127.0.0.1:{view.port}"
        client = WsClient("127.0.0.1", view.port)
        assert client.status.endswith("101 Switching Protocols")
        op, data = client.recv()
        info = json.loads(data)
        assert op == 1 and info["op"] == "serverInfo" and "time" in info["capabilities"]
        client.close()
    finally:
        view.close()
    assert refused("127.0.0.1", view.port)


def refused(host: str, port: int, within: float = 5.0) -> bool:
    """True once connecting is refused (a server's shutdown completes asynchronously)."""
    deadline = time.monotonic() + within
    while time.monotonic() < deadline:
        try:
            socket.create_connection((host, port), timeout=1).close()
        except OSError:
            return True
        time.sleep(0.05)
    return False


def stream(scene, wanted: set[str], last: tuple[str, int] | None = None
           ) -> tuple[dict[str, dict], dict[str, list[tuple[int, bytes]]], list[int]]:
    """Run ``scene`` live (paced at real time) with a client subscribed to ``wanted`` topics; return
    the advertised channels by topic, the (log time, payload) pairs received per topic, and the
    clock broadcasts. Received until the clock has reached the scene's end and, with ``last`` =
    (topic, log time), that topic a message of that time (the server's clock and a channel's
    messages reach a client by separate queues: either can come first)."""
    sim = Simulation(scene)
    view = LiveView(scene, "127.0.0.1:0", speed=1.0, components=sim.components, announce=False)
    client = WsClient("127.0.0.1", view.port)
    channels: dict[str, dict] = {}
    topics: dict[int, str] = {}  # subscription id -> topic
    got: dict[str, list[tuple[int, bytes]]] = {}
    clock: list[int] = []
    sim.observers.append(view)
    runner = threading.Thread(target=sim.run)

    def subscribe(topic: str) -> None:
        sub_id = next((k for k, t in topics.items() if t == topic), len(topics) + 1)
        topics[sub_id] = topic
        subscription = {"id": sub_id, "channelId": channels[topic]["id"]}
        client.send_json({"op": "subscribe", "subscriptions": [subscription]})

    try:
        runner.start()
        def done() -> bool:
            if runner.is_alive() or not clock or clock[-1] != scene.until_ns:
                return False
            return last is None or any(t == last[1] for t, _ in got.get(last[0], []))

        while not done():
            try:
                op, data = client.recv()
            except (TimeoutError, ConnectionError):
                break
            if op == 1:
                msg = json.loads(data)
                if msg["op"] == "advertise":
                    for ch in msg["channels"]:
                        channels[ch["topic"]] = ch
                        if ch["topic"] in wanted:
                            subscribe(ch["topic"])
                elif msg["op"] == "status" and msg["message"].startswith("Unknown channel ID"):
                    # a subscription sent right after an advertisement can reach the server before it
                    # has finished registering that channel: ask again
                    channel_id = int(msg["message"].rsplit(" ", 1)[1])
                    time.sleep(0.01)
                    subscribe(next(t for t, ch in channels.items() if ch["id"] == channel_id))
            elif op == 2 and data[0] == 1:  # messageData
                sub_id, log_time = struct.unpack("<IQ", data[1:13])
                got.setdefault(topics[sub_id], []).append((log_time, data[13:]))
            elif op == 2 and data[0] == 2:  # time
                clock.append(struct.unpack("<Q", data[1:9])[0])
    finally:
        runner.join(timeout=30)
        client.close()
        view.close()
    return channels, got, clock


def test_a_client_receives_the_physics_and_viewer_channels_with_sim_time():
    """A subscribed client gets /stone/state as JSON and /tf as foxglove.FrameTransforms, each with
    log time = simulation time, and the server's clock follows the simulation to its end."""
    from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms

    scene = loads(SKIP_SCENE, overrides=["until=0.3"])
    channels, got, clock = stream(scene, {"/stone/state", "/tf"})
    described = {t: (ch["schemaName"], ch["encoding"]) for t, ch in channels.items()}
    assert described["/tf"] == ("foxglove.FrameTransforms", "protobuf")
    assert described["/stone/state"] == ("cosim.BodyState", "json")
    states = [(t, codec_for(BodyState).decode(d)) for t, d in got["/stone/state"]]
    assert len(states) > 50 and all(t % 1_000_000 == 0 for t, _ in states)
    assert all(abs(s.position[0] - 4.0 * t / 1e9) < 1e-9 for t, s in states)  # x = speed * t
    tfs = [(t, FrameTransforms.FromString(d)) for t, d in got["/tf"]]
    assert len(tfs) >= 3
    for t, msg in tfs:
        tf = msg.transforms[0]
        assert tf.timestamp.seconds * 1_000_000_000 + tf.timestamp.nanos == t
        assert abs(tf.translation.x - 4.0 * t / 1e9) < 1e-9
    assert clock == sorted(clock) and clock[-1] == 300_000_000


def test_the_run_s_end_is_streamed_whatever_the_frame_rate():
    """The run's last message of a port that came after the port's last frame is drawn as the run
    ends, as a recording draws it: at 30 frames a second a run ending at 0.31 s streams /tf at 0.31 s
    (it stopped at the 0.3 s frame, and a viewer saw the stone where it was a frame before the end)."""
    from foxglove_schemas_protobuf.FrameTransforms_pb2 import FrameTransforms

    scene = loads(SKIP_SCENE, overrides=["until=0.31"])
    _, got, clock = stream(scene, {"/stone/state", "/tf"}, last=("/tf", 310_000_000))
    last_state = codec_for(BodyState).decode(got["/stone/state"][-1][1])
    last_time, last_tf = got["/tf"][-1]
    tf = FrameTransforms.FromString(last_tf).transforms[0]
    assert got["/stone/state"][-1][0] == last_time == clock[-1] == 310_000_000
    assert [tf.translation.x, tf.translation.y, tf.translation.z] == list(last_state.position)
    assert sorted(t for t, _ in got["/tf"])[-2] == 300_000_000  # the frames before it as they were


def test_a_live_run_records_the_same_physics(tmp_path):
    """Streaming live (unpaced) leaves the recorded physics channels identical."""
    from tests.test_foxglove_recording import physics

    record_skip(tmp_path / "live.mcap", live="127.0.0.1:0", live_speed=0.0)
    record_skip(tmp_path / "plain.mcap")
    assert physics(tmp_path / "live.mcap") == physics(tmp_path / "plain.mcap")


def test_cosim_run_live_serves_while_running(tmp_path, capsys):
    """`cosim run --live HOST:PORT` announces the WebSocket address and finishes normally."""
    from cosim.cli import main

    scene = tmp_path / "skip.yaml"
    scene.write_text(SKIP_SCENE)
    assert main(["run", str(scene), "--no-record", "-q", "--live", "127.0.0.1:0", "--live-speed", "0",
                 "--live-linger", "0"]) == 0
    out = capsys.readouterr()
    assert "live view: ws://127.0.0.1:" in out.err and "toy_skip: ok" in out.out


def test_without_the_sdk_live_fails_with_a_hint(tmp_path, capsys, monkeypatch):
    """Without foxglove-sdk, --live exits 2 (a missing extra is bad input, as for plot and render; it
    was 1) naming what to install, and writes no recording."""
    from cosim.cli import main

    monkeypatch.setitem(__import__("sys").modules, "foxglove", None)
    scene = tmp_path / "skip.yaml"
    scene.write_text(SKIP_SCENE)
    assert main(["run", str(scene), "-o", str(tmp_path / "r.mcap"), "-q", "--live"]) == 2
    assert "pip install foxglove-sdk" in capsys.readouterr().err
    assert list(tmp_path.glob("r.mcap*")) == []


def advertised(client: WsClient, wanted: set[str], within: float = 2.0) -> dict[str, dict]:
    """The channels the server advertises to ``client`` (by topic), read until ``wanted`` are all
    there or ``within`` seconds have passed."""
    channels: dict[str, dict] = {}
    deadline = time.monotonic() + within
    client.sock.settimeout(0.2)
    while not wanted <= channels.keys() and time.monotonic() < deadline:
        try:
            op, data = client.recv()
        except TimeoutError:
            continue
        if op == 1 and (msg := json.loads(data))["op"] == "advertise":
            channels.update((ch["topic"], ch) for ch in msg["channels"])
    return channels


def test_a_run_late_after_a_stall_is_paced_on_from_there_not_played_flat_out(monkeypatch):
    """Paced at 0.5x, a run whose first step took 50 s (its kernels compiling) played its next 25 s
    of simulation as fast as it could, catching up with the clock of its start: the first skips, as
    a user watches, at 0.94x real time. Now a step a quarter second late or more starts the pacing
    again from itself; a step less late (jitter) is made up, so the pace holds on average."""
    import cosim.view.live as live

    clock = {"now": 100.0}
    slept: list[float] = []
    monkeypatch.setattr(live.time, "perf_counter", lambda: clock["now"])
    monkeypatch.setattr(live.time, "sleep", lambda s: (slept.append(s), clock.update(now=clock["now"] + s)))
    scene = loads(SKIP_SCENE)
    view = LiveView(scene, "127.0.0.1:0", speed=0.5, components=Simulation(scene).components, announce=False)
    sim = types.SimpleNamespace(time_ns=0, interrupt_reason=None)  # the run's clock and whether it was asked to stop
    try:
        view.on_initialized(sim)
        sim.time_ns = 10_000_000  # 10 ms of simulation ...
        clock["now"] += 50.0  # ... done after 50 s of compiling: late, no sleep
        view.on_step_complete(sim)
        assert slept == []
        sim.time_ns = 20_000_000  # the next 10 ms, done at once: paced at 0.5x, 20 ms of wall time
        view.on_step_complete(sim)
        assert slept == [pytest.approx(0.02)]
        # jitter is made up: a step 10 ms late, then one on time, keep the pace of 0.5x on average
        sim.time_ns = 30_000_000
        clock["now"] += 0.03  # due 20 ms after the last, done 30 ms after: 10 ms late, no sleep
        view.on_step_complete(sim)
        sim.time_ns = 40_000_000
        view.on_step_complete(sim)  # due 20 ms on: 10 ms of it already spent
        assert slept == [pytest.approx(0.02), pytest.approx(0.01)]
    finally:
        view.close()


def test_a_slow_pace_sleeps_in_slices_that_end_when_the_run_is_asked_to_stop(monkeypatch):
    """Paced at 1e-5 of real time, a 1 ms step waits 100 s: in sleeps of at most PACE_SLICE_S, which
    stop once a signal has asked the run to stop (one sleep of 100 s sat out Ctrl-C and SIGTERM)."""
    import cosim.view.live as live

    clock = {"now": 100.0}
    slept: list[float] = []
    sim = types.SimpleNamespace(time_ns=0, interrupt_reason=None)

    def sleep(s: float) -> None:
        slept.append(s)
        clock["now"] += s
        if len(slept) == 3:
            sim.interrupt_reason = "interrupted by SIGTERM"  # what the run's signal handler does

    monkeypatch.setattr(live.time, "perf_counter", lambda: clock["now"])
    monkeypatch.setattr(live.time, "sleep", sleep)
    scene = loads(SKIP_SCENE)
    view = LiveView(scene, "127.0.0.1:0", speed=1e-5, components=Simulation(scene).components, announce=False)
    try:
        view.on_initialized(sim)
        sim.time_ns = 1_000_000
        view.on_step_complete(sim)
        assert slept == [live.PACE_SLICE_S] * 3
    finally:
        view.close()

def test_every_channel_is_advertised_before_the_first_step():
    """As it starts, the live view makes every channel the run is known to publish on: each output
    port (the stage monitor's /stages/skip too, first published at the first skip) and the viewer
    topics their looks give. A viewer connected before the first step knows them all. Made at each
    topic's first message instead, a channel advertised mid-run could be lost by the SDK to a viewer
    subscribing at once ('Unknown channel ID: 16' for /stages/skip, 2 runs in 4 of held_skip)."""
    scene = loads(SKIP_SCENE)
    sim = Simulation(scene)
    view = LiveView(scene, "127.0.0.1:0", speed=0.0, components=sim.components, announce=False)
    ports = {f"/{name}/{port}" for name, cfg in scene.components.items() for port in cfg.cls.outputs}
    viewer = {"/tf": "foxglove.FrameTransforms", "/log": "foxglove.Log", "/scene/stone": "foxglove.SceneUpdate",
              "/scene/stone/trail": "foxglove.SceneUpdate", "/scene/stone/velocity": "foxglove.SceneUpdate",
              "/scene/pond": "foxglove.SceneUpdate"}
    try:
        client = WsClient("127.0.0.1", view.port)
        try:
            channels = advertised(client, ports | viewer.keys())
        finally:
            client.close()
    finally:
        view.close()
    assert sim.tick == 0  # nothing has run
    assert "/stages/skip" in ports and ports | viewer.keys() <= channels.keys()
    skip = channels["/stages/skip"]
    assert (skip["schemaName"], skip["encoding"]) == ("cosim.SkipRecord", "json")
    assert {topic: channels[topic]["schemaName"] for topic in viewer} == viewer
    assert all(channels[topic]["encoding"] == "protobuf" for topic in viewer)


def test_a_live_run_sends_a_channel_made_up_front_its_first_message_and_its_latest():
    """A channel advertised before its first message works as one made at it: a viewer subscribed
    early gets the messages, and subscribing before any message is sent nothing (no error)."""
    scene = loads(SKIP_SCENE, overrides=["until=0.35"])  # the first skip is at 0.12 s
    channels, got, clock = stream(scene, {"/stages/skip", "/log"})
    assert channels["/stages/skip"]["schemaName"] == "cosim.SkipRecord"
    skips = [codec_for(SkipRecord).decode(data) for _, data in got["/stages/skip"]]
    assert skips and skips[0].index == 1
    assert got["/log"] and clock[-1] == 350_000_000


class _RootRecords(logging.Handler):
    """The records that reach the root logger's handlers: what an application's logging is given
    (pytest's caplog is no such test: from pytest 9.1 it also listens to every logger that does not
    propagate, as the SDK's logger here does not)."""

    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


def test_a_viewer_that_drops_is_said_once_not_logged_per_message(capsys):
    """A viewer gone without closing the connection is one line on stderr ('live view: viewer ADDR
    disconnected'), however many messages the server then fails to send it; the SDK's records stay
    out of the application's logging. Before, each failed send was a line of its own through
    Python's last-resort handler (40 to 57 lines for one viewer)."""
    import foxglove

    root = _RootRecords()
    logging.getLogger().addHandler(root)
    view = LiveView(loads(SKIP_SCENE), "127.0.0.1:0", announce=False)
    channel = foxglove.Channel("/noise", schema=foxglove.Schema(name="noise", encoding="jsonschema", data=b"{}"),
                               message_encoding="json", context=view.context)
    try:
        client = WsClient("127.0.0.1", view.port)
        host, port = client.sock.getsockname()[:2]
        address = f"{host}:{port}"
        noise = advertised(client, {"/noise"})["/noise"]
        client.send_json({"op": "subscribe", "subscriptions": [{"id": 1, "channelId": noise["id"]}]})
        deadline = time.monotonic() + 5
        while channel.has_sinks() is False and time.monotonic() < deadline:
            time.sleep(0.01)
        # gone without a close frame: a reset, as a viewer killed or cut off leaves it
        client.sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        client.close()
        err = ""
        while address not in err and time.monotonic() < deadline:
            for _ in range(50):
                channel.log(b"{}" + b" " * 10_000)
            time.sleep(0.02)
            err += capsys.readouterr().err
    finally:
        view.close()
    time.sleep(0.2)  # a failed send still on its way to being logged
    logging.getLogger().removeHandler(root)
    err += capsys.readouterr().err
    # this viewer said once; a line about another one can only be an earlier test's server letting
    # its own connections go (the SDK's records are the process's), said once each all the same
    lines = err.splitlines()
    assert [line for line in lines if address in line] == [f"live view: viewer {address} disconnected"]
    assert all(re.fullmatch(r"live view: viewer \S+ disconnected", line) for line in lines)
    assert len(lines) == len(set(lines))
    assert [r for r in root.records if r.name.startswith("foxglove")] == []


def handshake_line(capsys, request: bytes) -> tuple[str, str, int, bytes]:
    """The one line a live view says of a connection that sends ``request`` and fails its
    handshake, with the connection's host and port and the server's reply."""
    view = LiveView(loads(SKIP_SCENE), "127.0.0.1:0", announce=False)
    try:
        sock = socket.create_connection(("127.0.0.1", view.port), timeout=5)
        host, port = sock.getsockname()[:2]
        sock.sendall(request)
        reply = sock.recv(4096)
        sock.close()
        err, deadline = "", time.monotonic() + 5
        while "dropped" not in err and time.monotonic() < deadline:
            time.sleep(0.02)
            err += capsys.readouterr().err
    finally:
        view.close()
    (line,) = err.splitlines()
    return line, host, port, reply


def test_a_viewer_speaking_only_the_older_protocol_is_told_dropped_at_its_handshake_not_disconnected(capsys):
    """The SDK's server speaks foxglove.sdk.v1 only: a viewer offering only foxglove.websocket.v1 (older
    Foxglove Studio and Lichtblick releases) gets a 400 at its handshake, which the run said as
    'viewer ADDR disconnected'; it is said to be dropped at its handshake, and why, in one line."""
    line, host, port, reply = handshake_line(
        capsys, b"GET / HTTP/1.1\r\nHost: localhost\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
                b"Sec-WebSocket-Protocol: foxglove.websocket.v1\r\n\r\n")
    assert reply.startswith(b"HTTP/1.1 400")
    assert line.startswith(f"live view: connection {host}:{port} dropped: its WebSocket handshake failed (this "
                           "server speaks the foxglove.sdk.v1 subprotocol only: a viewer offering only "
                           "foxglove.websocket.v1")


def test_a_request_that_is_no_websocket_is_said_dropped_naming_the_other_causes_too(capsys):
    """The server's record of a failed handshake is the same for a plain HTTP request (a browser page,
    curl) or a connection that sends nothing as for a viewer offering the older subprotocol: the line
    said the request had offered that subprotocol; it names the others too."""
    line, host, port, _ = handshake_line(capsys, b"GET / HTTP/1.1\r\nHost: localhost\r\n\r\n")
    assert line.startswith(f"live view: connection {host}:{port} dropped: its WebSocket handshake failed (")
    assert line.endswith("a browser page, curl, or a connection that sent nothing ends the same way)")


def test_closing_does_not_wait_for_a_viewer_that_never_answers(capsys):
    """The SDK's server.stop() waits until every connection is closed: a connection that never
    finished its handshake (a tab hung on the port) held Ctrl-C and --live-linger's end until it
    dropped (40 s). Closing now returns while that connection is still open: the client here closes
    only once close() has returned, or after a minute if it never does. Its end, logged by the
    server still letting it go, is not said once the view is closed."""
    view = LiveView(loads(SKIP_SCENE), "127.0.0.1:0", announce=False)
    sock = socket.create_connection(("127.0.0.1", view.port), timeout=5)
    time.sleep(0.2)  # the server has taken the connection in
    released = threading.Event()
    fallback = threading.Timer(60.0, lambda: (released.set(), sock.close()))
    fallback.start()
    try:
        view.close()
        closed_by_fallback = released.is_set()
    finally:
        fallback.cancel()
        sock.close()
    assert not closed_by_fallback
    time.sleep(0.5)  # the server's record of the connection's end on its way
    assert capsys.readouterr().err == ""
