"""The two ways a recording is written give the same bytes: the writer process (ProcessSink, fed
packed records through the ring) and the in-process sink (InProcessSink).

The scene::

    src.out --> g.x --> g.out --> acc.x          paint.frame (every field kind; a grid larger than
                                                  a whole batch every 10th step, float32 every 7th)

is recorded both ways, with checkpoints and a deriver's extra channel; every channel must hold the
same (log time, sequence, bytes), and each physics payload must be the codec's bytes of the message
published (and of the message decoded from it).
"""

from __future__ import annotations

import dataclasses
import enum
from pathlib import Path
from typing import Annotated

import numpy as np
from hypothesis import event, given, settings
from hypothesis import strategies as st
from mcap.reader import make_reader

from cosim.codec.json_codec import codec_for
from cosim.codec.jsontext import renderer
from cosim.codec.records import HEADER, MESSAGE
from cosim.component import Component, Port
from cosim.messages import Array, Message, Vec3, first_difference, message
from cosim.record import writer
from cosim.record.recorder import DerivedMessage, Recorder, wire_codec
from cosim.record.writer import InProcessSink, ProcessSink
from cosim.scenario import loads
from cosim.scheduler import BaseObserver, Simulation
from tests.test_codec import Everything, everything, floats
from tests.toys import Force, Scalar

LARGE = (400, 400)  # grid shape every 10th step: 1.28 MB
SMALL_STAGE = 1 << 20  # a stage smaller than a large grid's record: those go in batches of their own


class Sea(enum.IntEnum):
    CALM = 0
    ROUGH = 1


@message
class Frame(Message):
    """One field of each kind: time t [s], step k, a flag, a label, a sea state, a velocity v [m/s]
    (3,), and a height grid [m] of free shape (rows, cols)."""

    t: float
    k: int
    rough: bool
    label: str
    sea: Sea
    v: Vec3
    grid: Annotated[np.ndarray, Array("float64", (None, None))]


class Painter(Component):
    """Publishes a Frame every step; its grid is large every 10th step and float32 every 7th (which
    the codec's packed record refuses, so the recorder writes that message's bytes itself)."""

    outputs = {"frame": Port(Frame)}

    def setup(self) -> None:
        self.k = 0
        self.grid = np.zeros((2, 3))

    def _step_impl(self, t, dt, inputs):
        self.k += 1
        k = self.k
        shape = LARGE if k % 10 == 0 else (2 + k % 3, 3)
        self.grid = np.sin(np.arange(shape[0] * shape[1]) * 0.1 + t).reshape(shape)
        grid = self.grid.astype(np.float32) if k % 7 == 0 else self.grid
        return {"frame": Frame(t + dt, k, k % 2 == 0, f'step "{k}" é', Sea(k % 2),
                               np.array([t, -0.0, 1e-300 * k]), grid)}

    def get_state(self):
        return {"k": self.k, "grid": self.grid}

    def set_state(self, state):
        self.k, self.grid = state["k"], state["grid"]


SCENE = """
name: paths
dt: 0.001
until: 0.06
components:
  src: {type: "tests.toys:Source", rate: 3}
  g: {type: "tests.toys:Gain", gain: 0.7}
  acc: {type: "tests.toys:Accumulator"}
  paint: {type: "tests.test_recording_paths:Painter"}
connections:
  - src.out -> g.x
  - g.out -> acc.x
record: {checkpoint_every: 0.02}
"""

PHYSICS_TYPES = {"cosim.Scalar": Scalar, "cosim.Force": Force, "cosim.Frame": Frame}


def every_fifth_frame(time_ns, component, port, msg):
    """A deriver: an extra channel of raw bytes (the sinks' "m" records) for every fifth frame."""
    if port == "frame" and msg.k % 5 == 0:
        yield DerivedMessage("/extra/k", "demo.K", "jsonschema", b"{}", "json", b'{"k":%d}' % msg.k)


class Published(BaseObserver):
    """Every message published, per topic, in order."""

    def __init__(self) -> None:
        self.messages: dict[str, list[tuple[int, Message]]] = {}

    def on_exchange(self, time_ns, component, port, msg):
        self.messages.setdefault(f"/{component}/{port}", []).append((time_ns, msg))


def record(path: Path, background: bool) -> Published:
    """Run the scene recording to ``path``, in a writer process or in this one."""
    scene = loads(SCENE)
    sim = Simulation(scene)
    recorder = Recorder(path, scene, derivers=[every_fifth_frame], background=background)
    assert isinstance(recorder.sink, ProcessSink if background else InProcessSink)
    published = Published()
    sim.observers.extend([recorder, published])
    try:
        result = sim.run(scene.until_ns)
    finally:
        recorder.close()
    assert result.status == "ok"
    return published


def contents(path: Path) -> dict:
    """Every channel's (log time, publish time, sequence, bytes), its schema, the metadata and attachments."""
    channels: dict[str, list] = {}
    schemas: dict[str, tuple] = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        for schema, channel, msg in reader.iter_messages():
            channels.setdefault(channel.topic, []).append((msg.log_time, msg.publish_time, msg.sequence, msg.data))
            schemas[channel.topic] = (schema.name, schema.encoding, schema.data, channel.message_encoding)
        f.seek(0)
        reader = make_reader(f)
        metadata = [(m.name, m.metadata) for m in reader.iter_metadata()]
        f.seek(0)
        attachments = [(a.name, a.log_time, a.media_type, a.data) for a in make_reader(f).iter_attachments()]
    return {"channels": channels, "schemas": schemas, "metadata": metadata, "attachments": attachments}


def test_writer_process_and_in_process_sink_write_the_same_bytes(tmp_path, monkeypatch):
    """Recorded in a writer process and in this process, the scene gives identical channels (times,
    sequences and bytes of every message, the checkpoints and the deriver's channel included), schemas,
    metadata and attachments. The stage is made smaller than the large grids, so those go alone."""
    monkeypatch.setattr(writer, "STAGE_BYTES", SMALL_STAGE)
    record(tmp_path / "process.mcap", background=True)
    record(tmp_path / "inproc.mcap", background=False)
    a, b = contents(tmp_path / "process.mcap"), contents(tmp_path / "inproc.mcap")
    assert set(a["channels"]) == {"/src/out", "/src/force", "/g/out", "/acc/total", "/paint/frame", "/extra/k",
                                  "/cosim/checkpoint", "/cosim/status"}
    for topic in a["channels"]:
        assert a["channels"][topic] == b["channels"][topic], topic
    assert a == b
    frames = [data for *_, data in a["channels"]["/paint/frame"]]
    assert len(frames) == 60 and max(map(len, frames)) > SMALL_STAGE  # large grids went in batches of their own


def test_recorded_payloads_are_the_codecs_bytes_of_the_published_messages(tmp_path):
    """Through the writer process, each physics payload is the recorded form's ``encode`` of the
    message published at that time (protobuf for the types that have it, JSON for the frame, which
    has a label), and re-encoding the message decoded from it gives the same bytes; the scene has
    messages on both the fast (packed) and the slow (float32 grid) path."""
    published = record(tmp_path / "run.mcap", background=True)
    frame = codec_for(Frame)
    assert frame.write(published.messages["/paint/frame"][6][1], memoryview(b""), 0, 0, 0) == -1  # step 7: slow
    assert frame.write(published.messages["/paint/frame"][9][1], memoryview(b""), 0, 0, 0) < -1  # 10: packed
    recorded = contents(tmp_path / "run.mcap")
    checked = 0
    for topic, sent in published.messages.items():
        codec = wire_codec(PHYSICS_TYPES[recorded["schemas"][topic][0]])
        assert recorded["schemas"][topic][3] == ("json" if topic == "/paint/frame" else "protobuf"), topic
        rows = recorded["channels"][topic]
        assert [(t, seq) for t, _, seq, _ in rows] == [(t, i + 1) for i, (t, _) in enumerate(sent)], topic
        for (_, _, _, data), (_, msg) in zip(rows, sent, strict=True):
            assert data == codec.encode(msg), topic
            back = codec.decode(data)
            assert codec.encode(back) == data, topic
            if not (type(msg) is Frame and msg.grid.dtype == np.float32):  # float32 comes back as float64
                assert first_difference(back, msg) is None, topic
            checked += 1
    assert checked == 5 * 60 + 1  # five ports, 60 steps, and the accumulator's initial output


def large_grid(draw, msg: Everything) -> Everything:
    """``msg`` with a grid of over 64 KiB, seeded values plus a few NaN, infinities and signed zeros,
    sometimes transposed (not C-contiguous)."""
    rows, cols = draw(st.integers(91, 130)), draw(st.integers(91, 130))
    grid = np.random.default_rng(draw(st.integers(0, 2**32 - 1))).normal(size=(rows, cols))
    for i, j, x in draw(st.lists(st.tuples(st.integers(0, rows - 1), st.integers(0, cols - 1), floats), max_size=5)):
        grid[i, j] = x
    return dataclasses.replace(msg, grid=grid.T if draw(st.booleans()) else grid)


@st.composite
def messages(draw) -> Everything:
    """Any all-kinds message, with a small grid or a large one."""
    msg = draw(everything)
    return large_grid(draw, msg) if draw(st.booleans()) else msg


@settings(max_examples=60, deadline=None)
@given(st.lists(messages(), min_size=1, max_size=4), st.integers(0, 7))
def test_packed_records_render_the_same_bytes_from_a_copy_of_the_batch(msgs, gap):
    """Messages packed one after another into a batch (from an odd offset, non-finite floats and
    transposed grids included), read back from a copy of the batch as the writer process reads it
    from the ring, render to exactly ``codec.encode`` of each, and each record ends where the next
    begins."""
    codec = codec_for(Everything)
    batch = memoryview(bytearray(gap + sum(-codec.write(m, memoryview(b""), 0, 0, 0) for m in msgs)))
    offset = gap
    for k, msg in enumerate(msgs):
        offset = codec.write(msg, batch, offset, 3, 1000 + k)
        assert offset > 0
    assert offset == len(batch)
    copy = memoryview(bytes(batch))  # the writer's view into the ring
    render, offset = renderer(codec.layout), gap
    for k, msg in enumerate(msgs):
        assert HEADER.unpack_from(copy, offset) == (MESSAGE, 3, 1000 + k)
        text, offset = render(copy, offset + HEADER.size)
        assert text == codec.encode(msg) == codec._slow_encode(msg)
    assert offset == len(copy)
    event("non-finite floats" if not all(np.isfinite([m.x, *m.v, *m.grid.ravel()]).all() for m in msgs)
          else "finite")


def test_the_writer_writes_into_the_private_file_as_it_was_created(tmp_path):
    """The private file the simulating process created (and locked) is written as it is, not
    truncated on opening: on ext4 closing a file truncated to nothing waits for its blocks to be
    allocated, which every recorded run would wait for at its end. The finished file is a whole
    recording under the target's name."""
    part, target = tmp_path / "run.mcap.x.part", tmp_path / "run.mcap"
    part.write_bytes(b"\0" * 4096)  # stands for what a truncation would drop
    out = writer._Apply(str(part), str(target))
    try:
        assert part.stat().st_size == 4096
    finally:
        out.finish()
    assert not part.exists()
    with open(target, "rb") as f:
        assert list(make_reader(f).iter_messages()) == []
