"""The viewer channels of a recording made in its writer process (cosim.record.derive,
cosim.view.channels): the same file, byte for byte, as when the simulating process makes them; a
simulating process that never imports the viewer modules; a salvage that makes them again; warnings
that reach the user; and the writer started ahead of the run (cosim.record.writer.prestart).
"""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

from components.rigid_body import RigidBody
from cosim.record import ring as ring_module
from cosim.record import writer
from cosim.record.derive import DerivedMessage, relayed_warnings
from cosim.record.reader import Recording
from cosim.record.recorder import Recorder, physics_topics
from cosim.record.ring import RingConsumer, RingProducer
from cosim.record.writer import SinkError
from cosim.runner import default_derivers, run_scene
from cosim.scenario import load, loads
from cosim.scheduler import Simulation
from cosim.view.items import LOG_TOPIC, LogLine, VisualsWarning
from tests.test_reliability_salvage import KillWriter

pytest.importorskip("foxglove_schemas_protobuf", reason="the viewer channels need the [viz] extra")

ROOT = Path(__file__).resolve().parents[1]
SKIP = ROOT / "scenarios" / "skip.yaml"
WAIT_S = 60  # longest wait for another process to get somewhere (never a measured time)
VIEWER_MODULES = ("cosim.view.foxglove", "cosim.view.items", "components.visuals", "foxglove_schemas_protobuf",
                  "google.protobuf")

FALL = """
name: fall
dt: 0.001
until: 30
components:
  ball: {type: RigidBody, shape: sphere, radius: 0.05, position: [0, 0, 1], velocity: [1, 0.5, 3]}
record: {visual_rate: 60, checkpoint_every: 0}
"""


def record(path: Path, scene, derivers: list) -> Recorder:
    """Run ``scene`` recording to ``path`` with ``derivers``; the recorder (closed)."""
    sim = Simulation(scene)
    recorder = Recorder(path, scene, derivers=derivers)
    for deriver in derivers:
        deriver.bind(sim.components)
    sim.observers.append(recorder)
    try:
        assert sim.run(scene.until_ns).status in ("ok", "stopped")
    finally:
        recorder.close()
    return recorder


def test_viewer_channels_made_by_the_writer_are_the_bytes_made_here(tmp_path):
    """The reference skip's first 0.25 s (the stone, the water's fields, the stage log): recorded
    with the default viewer channels, which the writer derives from the recorded stone states, water
    fields and stages, and with the same deriver called in the simulating process: one file, byte
    for byte (a message decoded from its record is the one published, and each frame is written
    right after the message it came from either way)."""
    from cosim.view.foxglove import visual_deriver

    scene = load(SKIP, overrides=["until=0.25"])
    there = record(tmp_path / "there.mcap", scene, default_derivers(scene))
    derived = sorted((r[3], r[4]) for r in there.sink.directory if r[0] == "derive")
    assert derived == [("pond", "field"), ("stages", "skip"), ("stages", "stage"), ("stone", "state")]
    here = record(tmp_path / "here.mcap", scene, [visual_deriver(scene.record.visual_rate, physics_topics(scene))])
    assert not [r for r in here.sink.directory if r[0] in ("deriver", "derive")]
    rec = Recording(tmp_path / "there.mcap")
    assert {"/tf", "/scene/stone", "/scene/stone/trail", "/scene/pond", "/log"} <= set(rec.channels)
    assert rec.channels["/scene/pond"].count > 0 and rec.channels["/tf"].count > 5
    assert (tmp_path / "there.mcap").read_bytes() == (tmp_path / "here.mcap").read_bytes()


def test_the_ports_the_writer_cannot_derive_are_derived_here(tmp_path):
    """A port recorded one message in every few (``record.every``) and one not recorded at all
    (``record.channels``) keep their viewer channels, made in the simulating process: the same frames
    as with every message recorded."""
    full = loads(FALL, overrides=["until=0.5"])
    every = loads(FALL, overrides=["until=0.5", "record.every=3"])
    unrecorded = loads(FALL, overrides=["until=0.5", "record.channels=['/tf', '/scene/*']"])
    frames = {}
    for name, scene in (("full", full), ("every", every), ("unrecorded", unrecorded)):
        recorder = record(tmp_path / f"{name}.mcap", scene, default_derivers(scene))
        in_writer = [r for r in recorder.sink.directory if r[0] == "derive"]
        assert bool(in_writer) == (name == "full"), name
        rec = Recording(tmp_path / f"{name}.mcap")
        frames[name] = list(rec.raw(["/tf", "/scene/ball", "/scene/ball/trail"]))
    assert len(frames["full"]) > 2 * 30  # 60 frames/s for 0.5 s on /tf and the trail (the ball itself once)
    assert frames["every"] == frames["full"] and frames["unrecorded"] == frames["full"]
    assert "/ball/state" not in Recording(tmp_path / "unrecorded.mcap").channels


def test_a_recorded_run_never_imports_the_viewer_modules_here(tmp_path):
    """The simulating process of a run recorded with viewer channels imports none of the viewer
    modules (the writer makes the frames), and the recording holds the frames."""
    out = tmp_path / "fall.mcap"
    code = ("import sys\n"
            "from cosim.runner import run_scene\n"
            "from cosim.scenario import loads\n"
            f"run_scene(loads({FALL!r}, overrides=['until=0.2']), {str(out)!r}, progress=False)\n"
            f"print(sorted(m for m in sys.modules if m.startswith({VIEWER_MODULES!r})))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=WAIT_S, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"
    assert Recording(out).channels["/scene/ball/trail"].count >= 12  # 60 frames/s for 0.2 s


def test_a_salvaged_recording_has_its_viewer_channels_made_again(tmp_path):
    """The writer killed mid-run, in its second recording (kept from the first): the salvaged
    recording's viewer channels, made again from the salvaged messages (the writer's own, on channels
    the simulating process never knew, are not copied), are the uninterrupted run's up to where it
    ends."""
    first = record(tmp_path / "first.mcap", loads(FALL, overrides=["until=0.05"]), [])
    assert writer._spare is not None and writer._spare.proc.pid == first.sink.writer_pid
    scene = loads(FALL)
    out = tmp_path / "k.mcap"
    with pytest.raises(SinkError):
        run_scene(scene, out, progress=False, simulation=Simulation(scene, observers=[KillWriter(5000, 100_000)]))
    rec = Recording(out)
    assert rec.status().status == "failed"
    end_ns = rec.end_ns
    reference = run_scene(loads(FALL, overrides=[f"until={end_ns / 1e9}"]), tmp_path / "ref.mcap", progress=False)
    want = Recording(reference.recording)
    for topic in ("/tf", "/scene/ball/trail", "/scene/ball/velocity"):
        got = list(rec.raw([topic]))
        expected = [m for m in want.raw([topic]) if m[1] <= end_ns]
        assert got == expected[:len(got)] and len(expected) - len(got) <= 1, topic
        assert len(got) > 60 * 4  # the salvage reaches past 4 s at 60 frames/s


class Complaining:
    """A deriver the writer makes (``writer_recipe``): warns once, and writes one message per
    message of ``/ball/state``."""

    def __init__(self) -> None:
        self.writer_recipe = ("tests.test_recorded_visuals", "Complaining", ())
        self._warned = False

    def bind(self, components) -> None:
        pass

    def in_writer(self, component, port, message_type) -> bool:
        return port == "state"

    def watches(self, component, port, message_type) -> bool:
        return False

    def __call__(self, time_ns, component, port, msg):
        if not self._warned:
            self._warned = True
            warnings.warn("visuals of /ball/state failed and are switched off: a test", VisualsWarning, stacklevel=2)
        yield DerivedMessage("/complaints", "demo.C", "jsonschema", b"{}", "json", b"{}")


def test_a_warning_in_the_writer_reaches_the_user(tmp_path):
    """A deriver's warning in the writer process is given again in the simulating process when the
    recording closes, and what it derived is recorded."""
    scene = loads(FALL, overrides=["until=0.05", "record.visual_rate=0"])
    with pytest.warns(VisualsWarning, match="visuals of /ball/state failed and are switched off: a test"):
        record(tmp_path / "c.mcap", scene, [Complaining()])
    assert Recording(tmp_path / "c.mcap").channels["/complaints"].count == 51  # the first state and 50 steps
    assert relayed_warnings("noise\ncosim-warning\tcosim.view.items:VisualsWarning\ta\tb\n"
                            "cosim-warning\tno.such:Thing\tc\n") == [
        (VisualsWarning, "a\tb"), (RuntimeWarning, "the recording writer: no.such:Thing: c")]


class KillWriterOnceItWarned(KillWriter):
    """Kills the recording writer (SIGKILL) at ``tick`` once it has relayed a warning."""

    def _kill(self, sim: Simulation) -> None:
        (recorder,) = [o for o in sim.observers if isinstance(o, Recorder)]
        recorder.sink.flush()
        errors = recorder.sink._writer.errors
        deadline = time.monotonic() + WAIT_S
        while b"cosim-warning" not in os.pread(errors.fileno(), 1 << 20, 0):
            assert time.monotonic() < deadline, "the writer relayed no warning"
            time.sleep(0.01)
        super()._kill(sim)


def test_a_warning_in_the_writer_reaches_the_user_when_the_recording_fails(tmp_path):
    """The writer relayed a deriver's warning and was then killed: its recording is salvaged, whole
    (the run had sent everything, its status too), so the run stands, the writer's death said in a
    warning, and the deriver's warning is given once (the salvage, deriving again, meets it too).
    Under an "error" warnings filter the recording's failure, not the deriver's warning, is what is
    raised, and the warning met again while salvaging does not end the salvage: the recording is
    kept with its viewer channels."""
    for action in ("default", "error"):
        scene = loads(FALL, overrides=["until=0.05", "record.visual_rate=0"])
        sim = Simulation(scene, observers=[KillWriterOnceItWarned(30)])
        out = tmp_path / f"{action}.mcap"
        recorder = Recorder(out, scene, derivers=[Complaining()])
        sim.observers.append(recorder)
        with warnings.catch_warnings(record=True) as given:
            warnings.simplefilter(action)
            failure = pytest.raises(SinkError, match="the recording writer was killed") if action == "error" else \
                contextlib.nullcontext()
            with failure:
                try:
                    sim.run(scene.until_ns)
                finally:
                    recorder.close()
        texts = [str(w.message) for w in given if issubclass(w.category, VisualsWarning)]
        assert texts == ([] if action == "error" else ["visuals of /ball/state failed and are switched off: a test"])
        if action == "default":
            (whole,) = [str(w.message) for w in given if "the recording writer was killed" in str(w.message)]
            assert "all the run had recorded" in whole
        rec = Recording(out)
        assert rec.status().status == "ok" and rec.channels["/complaints"].count == 51  # all salvaged


def test_a_writer_started_ahead_is_the_one_the_recording_uses_and_is_kept(tmp_path):
    """prestart(): the next recording is written by that process, which is then kept for the next
    one (each file whole and closed as it ends); one never used ends with the process that started
    it, leaving nothing behind."""
    spare, writer._spare = writer._spare, None  # the writer this process kept, if any, is let go:
    if spare is not None:  # the next one is started here
        spare.close()
    writer.prestart(())
    started = writer._spare
    first = record(tmp_path / "a.mcap", loads(FALL, overrides=["until=0.01"]), [])
    assert first.sink.writer_pid == started.proc.pid and writer._spare is started
    assert Recording(tmp_path / "a.mcap").status().status == "ok"  # whole, under its name, as it closed
    second = record(tmp_path / "b.mcap", loads(FALL, overrides=["until=0.02"]), default_derivers(loads(FALL)))
    assert second.sink.writer_pid == started.proc.pid and writer._spare is started
    rec = Recording(tmp_path / "b.mcap")
    assert rec.status().status == "ok" and rec.channels["/ball/state"].count == 21
    assert rec.channels["/scene/ball/trail"].count == 3  # frames at 0 and 1/60 s, and the run's end
    code = "from cosim.record import writer\nwriter.prestart(('cosim.view.foxglove',))\nprint(writer._spare.proc.pid)\n"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=WAIT_S, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    pid = int(done.stdout)
    deadline = time.monotonic() + WAIT_S
    while _alive(pid):
        assert time.monotonic() < deadline, "the unused writer is still running"
        time.sleep(0.01)
    assert sorted(os.listdir(tmp_path)) == ["a.mcap", "b.mcap"]


def _alive(pid: int) -> bool:
    """Whether a process (not a zombie) of that id exists."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(") ")[-1][0] != "Z"
    except FileNotFoundError:
        return False


def test_a_kept_writer_writes_relative_paths_where_the_run_is(tmp_path, monkeypatch):
    """A writer kept from a recording made in one folder writes the next one, named relative to the
    folder the process has moved to since, there."""
    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    monkeypatch.chdir(tmp_path / "one")
    first = record(Path("a.mcap"), loads(FALL, overrides=["until=0.01"]), [])
    monkeypatch.chdir(tmp_path / "two")
    second = record(Path("runs") / "b.mcap", loads(FALL, overrides=["until=0.01"]), [])
    assert second.sink.writer_pid == first.sink.writer_pid
    assert (tmp_path / "one" / "a.mcap").is_file()
    assert Recording(tmp_path / "two" / "runs" / "b.mcap").status().status == "ok"
    assert sorted(p.name for p in (tmp_path / "two").rglob("*")) == ["b.mcap", "runs"]


class Failing(Complaining):
    """A deriver the writer makes that raises at its 20th message."""

    def __init__(self) -> None:
        super().__init__()
        self.writer_recipe = ("tests.test_recorded_visuals", "Failing", ())
        self.calls = 0

    def __call__(self, time_ns, component, port, msg):
        self.calls += 1
        if self.calls == 20:
            raise ValueError("cannot draw this")
        return [DerivedMessage("/drawn", "demo.D", "jsonschema", b"{}", "json", b"{}")]


def test_a_deriver_failing_in_the_writer_leaves_the_recording_whole(tmp_path):
    """A deriver that fails in the writer process switches its port off with a warning given to the
    user; the writer goes on, and the recording holds every exchange and its status."""
    scene = loads(FALL, overrides=["until=0.05", "record.visual_rate=0"])
    with pytest.warns(RuntimeWarning, match=r"viewer channels of /ball/state are not made from t = 0.019 s: "
                                            r"ValueError: cannot draw this"):
        record(tmp_path / "f.mcap", scene, [Failing()])
    rec = Recording(tmp_path / "f.mcap")
    assert rec.status().status == "ok" and rec.channels["/ball/state"].count == 51
    assert rec.channels["/drawn"].count == 19


class DrawnBall(RigidBody):
    """A body that draws itself (a log line per frame): its looks need the component itself."""

    def visuals(self, port, msg):
        return [LogLine(LOG_TOPIC, "info", "drawn", f"at {float(msg.position[2]):.3f} m")]


def test_a_component_that_draws_itself_has_every_viewer_channel_made_here(tmp_path):
    """One component drawing itself: every viewer channel of the run is made in the simulating
    process (none split between the two processes), the installed looks of the other body too."""
    scene = loads(FALL.replace("components:\n", "components:\n  drawn: {type: \"tests.test_recorded_visuals:"
                               "DrawnBall\", shape: sphere, radius: 0.05}\n"), overrides=["until=0.2"])
    recorder = record(tmp_path / "d.mcap", scene, default_derivers(scene))
    assert not [r for r in recorder.sink.directory if r[0] in ("deriver", "derive")]
    rec = Recording(tmp_path / "d.mcap")
    assert rec.channels["/scene/ball/trail"].count == 13 and rec.channels["/log"].count == 13


def test_a_stream_ended_on_the_ring_starts_the_next_count_over():
    """end_stream: the producer notes a count of 0 before the next stream's first batch, so that a
    salvage of that stream finds where to start even if the consumer died before it noted it."""
    producer = RingProducer(1 << 16)
    consumer = RingConsumer(producer.fd, producer.size, -1, -1)
    control_r, control_w = os.pipe()
    ack_r, ack_w = os.pipe()
    producer.connect(control_w, ack_r)
    consumer = RingConsumer(producer.fd, producer.size, control_r, ack_w)
    try:
        for _ in range(3):
            producer.put([b"x" * 100])
        batches = consumer.batches()
        for count, _batch in enumerate(batches, start=1):
            consumer.tally(count * 10)
            if count == 3:
                break
        os.write(ack_w, (2**64 - 1).to_bytes(8, "little"))  # FINISHED, as the consumer answers END
        assert producer.end_stream()
        assert producer.tallies()[3] == 0 and producer.held() == []
    finally:
        producer.close()
        for fd in (control_r, ack_r, ack_w):
            os.close(fd)


def test_ctrl_c_while_closing_ends_the_writer_and_does_not_hang(tmp_path, monkeypatch):
    """Ctrl-C as the recording closes, once the stream's end is sent: close() raises it at once,
    and the writer ends (it is neither waited for forever nor kept)."""
    scene = loads(FALL, overrides=["until=0.05"])
    sim = Simulation(scene)
    recorder = Recorder(tmp_path / "c.mcap", scene, derivers=[])
    sim.observers.append(recorder)
    sim.run(scene.until_ns)

    def interrupted(self):
        ring_module._write_all(self.control_fd, ring_module._HEAD.pack(ring_module.END, 0))
        raise KeyboardInterrupt

    monkeypatch.setattr(RingProducer, "end_stream", interrupted)
    signal.alarm(WAIT_S)  # a hang fails the test instead of stalling the run
    try:
        with pytest.raises(KeyboardInterrupt):
            recorder.close()
        proc = recorder.sink._writer.proc
        assert proc.wait(WAIT_S) is not None and writer._spare is not recorder.sink._writer
    finally:
        signal.alarm(0)


def test_a_process_with_a_kept_writer_exits_while_a_forked_child_lives(tmp_path):
    """A process that recorded (its writer kept) and then forked a child still exits while the
    child lives: the child forgets the writer, and the parent stops it as it exits (it used to wait
    for the writer, which waited for the child's copy of its socket to close)."""
    code = ("import os, sys, time\n"
            "from cosim.runner import run_scene\n"
            "from cosim.scenario import loads\n"
            f"run_scene(loads({FALL!r}, overrides=['until=0.01']), {str(tmp_path / 'p.mcap')!r}, progress=False)\n"
            "child = os.fork()\n"
            "if child == 0:\n"
            "    os.close(1); os.close(2)\n"
            "    time.sleep(1000)\n"
            "    os._exit(0)\n"
            "print(child, flush=True)\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=WAIT_S, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    child = int(done.stdout)
    try:
        assert _alive(child)  # the parent ended first
    finally:
        os.kill(child, signal.SIGKILL)


def test_a_ground_is_drawn_from_its_first_message_that_has_a_body_to_draw_under(tmp_path):
    """A ground's slab spans the path of the body it holds, which it is told of only as the run's first
    step begins: at t = 0 it has nothing to draw, and that frame counted as drawn, so the floor
    appeared a frame (33 ms) after the bodies above it. Its next message draws it: at the first step,
    while the bodies are drawn from t = 0."""
    from mcap.reader import make_reader

    scene = load(Path(__file__).resolve().parents[1] / "scenarios" / "ground_bounce.yaml", ["until=0.05"])
    out = tmp_path / "g.mcap"
    run_scene(scene, out, progress=False)
    first: dict[str, int] = {}
    with open(out, "rb") as f:
        for _, channel, message in make_reader(f).iter_messages(topics=["/scene/floor_flat", "/scene/disk_flat"]):
            first.setdefault(channel.topic, message.log_time)
    assert first["/scene/disk_flat"] == 0
    assert first["/scene/floor_flat"] == scene.dt_ns
