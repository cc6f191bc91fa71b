"""Nothing recorded is lost when one of a run's two processes dies (cosim.record.salvage, the ring's
mark and tallies):

    simulating process  --records, in batches-->  writer process  -->  NAME.<random>.part  -->  NAME
      (Recorder, ProcessSink)   (shared-memory ring)     (writer_main)

- the writer dies: the simulating process rebuilds the recording from the writer's part file, the
  batches the ring still holds and its own copy of the schemas, channels, metadata and attachments;
  the run ends with one line saying so, and the recording ends with a ``failed`` status;
- the simulating process dies (SIGSEGV): the writer also writes the steps it had completed but not
  yet sent (marked in the ring), and finishes the file.

Each recording is compared with an uninterrupted run's, message for message.
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.component import Component, Port
from cosim.params import param
from cosim.record.reader import Recording
from cosim.record.recorder import STATUS_TOPIC, Recorder, physics_topics
from cosim.record.ring import RingConsumer, RingProducer
from cosim.record.salvage import resume_point
from cosim.record.writer import SinkError
from cosim.replay import replay_component
from cosim.runner import run_scene
from cosim.scenario import loads
from cosim.scheduler import BaseObserver, Simulation
from tests.toys import Scalar

ROOT = Path(__file__).resolve().parents[1]
WAIT_S = 60  # longest wait for another process to get somewhere (never a measured time)

SCENE = """
name: demo
dt: 0.001
until: 100
components:
  src: {type: "tests.toys:Source"}
  g: {type: "tests.toys:Gain"}
connections:
  - src.out -> g.x
record: {checkpoint_every: 1.0}
"""
KILL_TICK = 3000  # the writer is killed here: a few batches (and chunks on disk) into the run
ON_DISK = 100_000  # bytes the writer's part file holds before it is killed (some chunks complete)


def wait_until(done, what: str) -> None:
    deadline = time.monotonic() + WAIT_S
    while not done():
        if time.monotonic() > deadline:
            raise AssertionError(f"waited {WAIT_S} s for {what}")
        time.sleep(0.01)


class KillWriter(BaseObserver):
    """Kills the run's recording writer with SIGKILL at ``tick`` (0: as the run starts), once its part
    file holds ``on_disk`` bytes; the run goes on until the simulating process finds it gone."""

    def __init__(self, tick: int, on_disk: int = 0):
        self.tick, self.on_disk = tick, on_disk

    def _kill(self, sim: Simulation) -> None:
        (recorder,) = [o for o in sim.observers if isinstance(o, Recorder)]
        sink = recorder.sink
        sink.flush()
        part = sink.claim.part
        wait_until(lambda: part.stat().st_size >= self.on_disk, f"{part} to grow to {self.on_disk} bytes")
        os.kill(sink.writer_pid, signal.SIGKILL)

    def on_initialized(self, sim: Simulation) -> None:
        if self.tick == 0:
            self._kill(sim)

    def on_step_complete(self, sim: Simulation) -> None:
        if sim.tick == self.tick:
            self._kill(sim)


def messages(path: Path) -> dict[str, list[tuple[int, bytes]]]:
    """Every physics channel's (log time, payload) pairs, in order (checkpoints too; not the status)."""
    rec = Recording(path)
    out: dict[str, list[tuple[int, bytes]]] = {}
    for topic, stamp, data in rec.raw(sorted(set(rec.channels) & physics_topics(rec.scene()) - {STATUS_TOPIC})):
        out.setdefault(topic, []).append((stamp, data))
    return out


def reference(tmp_path: Path, until_ns: int) -> dict[str, list[tuple[int, bytes]]]:
    """An uninterrupted run's messages up to ``until_ns``."""
    scene = loads(SCENE, overrides=[f"until={until_ns / 1e9}"])
    out = run_scene(scene, tmp_path / "reference.mcap", progress=False).recording
    return messages(out)


def assert_a_prefix_of_the_reference(got: dict, want: dict, until_ns: int) -> None:
    """``got`` holds exactly the reference's messages up to ``until_ns`` (and at most the step in
    progress after it, whose messages match the reference's too)."""
    for topic, pairs in want.items():
        upto = [p for p in pairs if p[0] <= until_ns]
        assert got.get(topic, [])[:len(upto)] == upto, topic
        assert len(got.get(topic, [])) - len(upto) <= 1, topic


def kill_the_writer(tmp_path: Path, killer: KillWriter) -> tuple[Path, str]:
    out = tmp_path / "k.mcap"
    scene = loads(SCENE)
    with pytest.raises(SinkError) as failure:
        run_scene(scene, out, progress=False, simulation=Simulation(scene, observers=[killer]))
    assert not list(tmp_path.glob("k.mcap.*.part"))
    return out, str(failure.value)


def test_the_writer_killed_mid_run_leaves_everything_recorded_up_to_the_failure(tmp_path, capsys):
    """SIGKILL of the writer after it has written some chunks: the error names the signal and says
    the recording was salvaged up to t = ... into the output; the recording is the uninterrupted
    run's up to the failure, ends with a `failed` status naming the writer, and replays bit for bit."""
    out, line = kill_the_writer(tmp_path, KillWriter(KILL_TICK, ON_DISK))
    rec = Recording(out)
    status = rec.status()
    assert status.status == "failed" and status.tick >= KILL_TICK
    assert status.reason.startswith("the recording writer was killed (SIGKILL) at t = ")
    assert status.reason.endswith("the recording holds all the run had recorded")
    end = f"t = {rec.end_ns / 1e9:g} s"
    assert line == (f"{out}: the recording writer was killed (SIGKILL); the recording was salvaged up to {end}, "
                    f"all the run had recorded (its {sum(c.count for c in rec.channels.values()) - 1} messages), "
                    f"into {out}")
    status_ns = status.tick * 1_000_000
    assert rec.end_ns - status_ns <= 1_000_000  # the step in progress at the failure, at most
    assert_a_prefix_of_the_reference(messages(out), reference(tmp_path, status_ns), status_ns)
    stamps = [stamp for stamp, _ in rec.checkpoints()]
    assert stamps == [i * 10**9 for i in range(len(stamps))] and len(stamps) >= status.tick // 1000
    for name in ("src", "g"):
        report = replay_component(rec, name)
        assert report.ok and report.steps == status.tick, report
    assert main(["inspect", str(out)]) == 0
    assert f"status: failed at t = {status.time:g} s ({status.tick} steps) - the recording writer was killed" \
        in capsys.readouterr().out


def test_a_writer_killed_before_it_wrote_anything_still_leaves_the_recording(tmp_path):
    """SIGKILL of the writer as the run starts: everything comes from the ring, scene and metadata
    included."""
    out, line = kill_the_writer(tmp_path, KillWriter(0))
    assert "the recording writer was killed (SIGKILL); the recording was salvaged up to t = " in line
    rec = Recording(out)
    status = rec.status()
    assert status.status == "failed" and status.tick > 0
    assert rec.scene().name == "demo" and rec.metadata["dt_ns"] == "1000000"
    status_ns = status.tick * 1_000_000
    assert_a_prefix_of_the_reference(messages(out), reference(tmp_path, status_ns), status_ns)


def test_a_ring_that_no_longer_reaches_back_leaves_the_file_and_says_what_was_lost(tmp_path, monkeypatch):
    """When the ring holds none of what the writer had not put on disk (as after a record larger
    than the ring), the recording holds the writer's complete chunks, says the rest was lost, and its
    status stands at a tick that is whole in it."""
    monkeypatch.setattr(RingProducer, "held", lambda self: [])
    out, line = kill_the_writer(tmp_path, KillWriter(KILL_TICK, ON_DISK))
    rec = Recording(out)
    assert rec.end_ns > 0  # some chunks were on disk
    end = f"t = {rec.end_ns / 1e9:g} s"
    assert line.startswith(f"{out}: the recording writer was killed (SIGKILL); the recording was salvaged up to "
                           f"{end} (")
    assert line.endswith(f"into {out}; what the run recorded after that was lost")
    status = rec.status()
    assert status.status == "failed" and "what the run recorded after that was lost" in status.reason
    assert status.tick == rec.end_ns // 1_000_000 - 1  # every component steps every tick
    got = messages(out)
    want = reference(tmp_path, rec.end_ns)
    for topic, pairs in got.items():
        assert pairs == want[topic][:len(pairs)], topic
    for name in ("src", "g"):
        assert replay_component(rec, name).ok


def test_the_ring_continues_the_file_from_the_batch_the_writer_had_reached():
    """resume_point: the latest batch held whose tally (messages written before it) is at most the
    file's messages; none when the ring no longer reaches back that far."""
    held = [(n, memoryview(b"")) for n in (5, 6, 7)]
    tallies = {0: 0, 5: 100, 6: 180, 7: 260}
    assert resume_point(held, tallies, 200) == (1, 20)
    assert resume_point(held, tallies, 180) == (1, 0)
    assert resume_point(held, tallies, 999) == (2, 739)
    assert resume_point(held, tallies, 99) is None
    assert resume_point(held, {0: 0, 7: 260}, 200) is None  # batches 5 and 6 were never tallied
    assert resume_point([(0, memoryview(b""))], {0: 0}, 0) == (0, 0)


def ring(size: int = 4096) -> tuple[RingProducer, RingConsumer]:
    """A ring whose two ends are both in this process (the consumer's a generator, run by hand)."""
    producer = RingProducer(size)
    control_r, control_w = os.pipe()
    ack_r, ack_w = os.pipe()
    producer.connect(control_w, ack_r)
    return producer, RingConsumer(producer.fd, size, control_r, ack_w)


def shut(producer: RingProducer, consumer: RingConsumer) -> None:
    """Close both ends (the consumer's first: a producer hanging up reads its acknowledgements until
    the consumer's end closes)."""
    consumer.finish()
    os.close(consumer.control_fd)
    producer.hang_up()
    producer.close()


def test_the_ring_holds_each_batch_until_it_is_written_over_with_the_consumers_tallies():
    """RingProducer.held gives every batch sent, read or not, until later ones take its bytes; the
    consumer's tallies are read back by batch number."""
    producer, consumer = ring()
    batches = consumer.batches()
    for i in range(6):
        producer.put([bytes([i]) * 1000])
        assert bytes(next(batches)[0]) == bytes([i]) * 1000
        consumer.tally(10 * (i + 1))
    # batch 4 did not fit before the ring's end: it went to the start, over batch 0; batch 5 over batch 1
    assert [(n, bytes(b)) for n, b in producer.held()] == [(n, bytes([n]) * 1000) for n in (2, 3, 4, 5)]
    assert producer.tallies() == {n: 10 * n for n in range(7)}
    shut(producer, consumer)


def test_a_producer_that_dies_leaves_its_marked_records_to_the_consumer():
    """Records gathered in reserved space and marked are read by the consumer once the producer's
    pipe closes without a hang-up (it died); what follows the mark is not; a hang-up clears it."""
    producer, consumer = ring()
    space = producer.reserve(1000)
    space[:3] = b"abc"
    producer.commit(3)
    space = producer.reserve(1000)
    space[:8] = b"whole..."
    producer.mark(5)
    os.close(producer.control_fd)  # as the process dying closes it
    producer.control_fd = -1
    assert [bytes(b[0]) for b in consumer.batches()] == [b"abc"]
    assert bytes(consumer.unsent()) == b"whole"
    del space
    shut(producer, consumer)

    producer, consumer = ring()
    producer.reserve(1000)[:5] = b"whole"
    producer.mark(5)
    consumer.finish()
    producer.hang_up()
    assert list(consumer.batches()) == [] and consumer.unsent() is None
    os.close(consumer.control_fd)
    producer.close()


class Segfault(Component):
    """Passes its input on until t >= ``at``: then its process dies of a segmentation fault (as a
    crash in compiled code would end it)."""

    @dataclass(frozen=True)
    class Params:
        at: float = param(0.0, unit="s")

    inputs = {"x": Port(Scalar, required=True)}
    outputs = {"out": Port(Scalar)}

    def _step_impl(self, t, dt, inputs):
        if t >= self.params.at:
            os.kill(os.getpid(), signal.SIGSEGV)
        return {"out": inputs["x"]}


CRASH = """
name: demo
dt: 0.001
until: 100
components:
  src: {type: "tests.toys:Source"}
  crash: {type: "tests.test_reliability_salvage:Segfault", at: AT}
connections:
  - src.out -> crash.x
record: {checkpoint_every: 1.0}
"""


def _no_core_file() -> None:
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))


@pytest.mark.parametrize(("at", "steps"), [(0.0305, 31), (2.0005, 2001)])
def test_a_simulating_process_that_segfaults_leaves_every_step_it_completed(tmp_path, at, steps):
    """SIGSEGV of `cosim run` early (nothing sent to the writer yet) and later (a batch sent, the
    rest not): the writer writes every step the run completed, marked in the ring, and finishes a
    valid recording without a status; the partial step of the crash is left out."""
    scene = tmp_path / "crash.yaml"
    scene.write_text(CRASH.replace("AT", str(at)))
    out = tmp_path / "crash.mcap"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.run([sys.executable, "-m", "cosim.cli", "run", str(scene), "-o", str(out), "-q"],
                          env=env, capture_output=True, timeout=WAIT_S, preexec_fn=_no_core_file)
    assert proc.returncode == -signal.SIGSEGV
    wait_until(out.exists, f"the writer to finish {out}")  # the writer outlives the run
    rec = Recording(out)
    assert rec.status() is None
    assert {t: c.count for t, c in rec.channels.items()} == {
        "/src/out": steps, "/src/force": steps, "/crash/out": steps, "/cosim/checkpoint": 1 + steps // 1000}
    assert rec.end_ns == steps * 1_000_000
    want = reference(tmp_path, rec.end_ns)
    got = messages(out)
    assert got["/src/out"] == want["/src/out"] and got["/src/force"] == want["/src/force"]
    assert got["/crash/out"] == want["/src/out"]  # passed on as it came
