"""Recording to MCAP: every exchange, determinism, survival of failures, and reading back."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mcap.reader import make_reader

from cosim.errors import RecordingError
from cosim.record.reader import Recording
from cosim.runner import run_scene
from cosim.scenario import loads

ROOT = Path(__file__).resolve().parents[1]

LOOP = """
name: loop
dt: 0.001
until: 0.2
components:
  src: {type: "tests.toys:Source", rate: 3}
  g: {type: "tests.toys:Gain", gain: 0.7}
  acc: {type: "tests.toys:Accumulator", every: 4}
connections:
  - src.out -> g.x
  - g.out -> acc.x
record: {checkpoint_every: 0.05}
"""


def _part_bigger_than(out: Path, size: int) -> bool:
    """True once the private file a recording of ``out`` is written to holds more than ``size`` bytes."""
    return any(p.stat().st_size > size for p in out.parent.glob(out.name + ".*.part"))


def physics_messages(path: Path) -> dict[str, list[tuple[int, int, bytes]]]:
    out: dict[str, list] = {}
    with open(path, "rb") as f:
        for _, channel, msg in make_reader(f).iter_messages():
            if not channel.topic.startswith(("/cosim/", "/perf/")):
                out.setdefault(channel.topic, []).append((msg.log_time, msg.sequence, msg.data))
    return out


def test_every_exchange_is_recorded_on_its_source_port_channel(tmp_path):
    """Each output port gets a channel /<component>/<port> with one message per step at sim time."""
    outcome = run_scene(loads(LOOP), tmp_path / "run.mcap", progress=False)
    rec = Recording(outcome.recording)
    assert rec.channels["/src/out"].count == 200
    assert rec.channels["/g/out"].count == 200
    assert rec.channels["/acc/total"].count == 51  # initial output + 50 steps of 4 ms
    assert rec.channels["/src/out"].schema_name == "cosim.Scalar"
    stamps = [t for t, _ in rec.messages("/src/out", __import__("tests.toys", fromlist=["Scalar"]).Scalar)]
    assert stamps[:3] == [1_000_000, 2_000_000, 3_000_000]
    status = rec.status()
    assert status.status == "ok" and status.tick == 200
    assert rec.metadata["scene"] == "loop" and "src:" in rec.scene_text
    with open(outcome.recording, "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary.chunk_indexes and all(ci.compression == "zstd" for ci in summary.chunk_indexes)
        seqs = [m.sequence for _, ch, m in reader.iter_messages(topics=["/g/out"])]
        assert seqs == list(range(1, 201))


def test_same_scene_twice_gives_byte_identical_physics_channels(tmp_path):
    """Two runs of one scene write identical physics channels (times, sequences and bytes)."""
    a = run_scene(loads(LOOP), tmp_path / "a.mcap", progress=False).recording
    b = run_scene(loads(LOOP), tmp_path / "b.mcap", progress=False).recording
    assert physics_messages(a) == physics_messages(b)


def test_record_selection_never_changes_the_physics(tmp_path):
    """Recording only some channels, decimated, writes a subset of the full run's messages."""
    full = physics_messages(run_scene(loads(LOOP), tmp_path / "a.mcap", progress=False).recording)
    scene = loads(LOOP, overrides=["record.channels=['/g/*']", "record.every=10"])
    part = physics_messages(run_scene(scene, tmp_path / "b.mcap", progress=False).recording)
    assert set(part) == {"/g/out"}
    assert [m[2] for m in part["/g/out"]] == [m[2] for m in full["/g/out"]][::10]


def test_failing_run_leaves_valid_recording_with_status(tmp_path):
    """A component failure mid-run still closes a valid MCAP holding everything up to it and a
    final 'failed' status naming the component and time."""
    scene = loads("""
dt: 0.001
until: 1.0
components:
  src: {type: "tests.toys:Source"}
  bad: {type: "tests.toys:Faulty", fail_at: 0.0105}
""")
    outcome = run_scene(scene, tmp_path / "fail.mcap", progress=False)
    assert outcome.failed
    rec = Recording(tmp_path / "fail.mcap")
    # tick 11 (t = 11 ms): src ran and published before bad failed
    assert rec.channels["/src/out"].count == 12
    assert rec.channels["/bad/out"].count == 11
    status = rec.status()
    assert status.status == "failed" and "'bad' failed at t = 0.011 s: RuntimeError: boom" in status.reason
    assert not list(tmp_path.glob("fail.mcap*.part"))


def test_sigterm_mid_run_leaves_valid_recording(tmp_path):
    """SIGTERM during `cosim run` ends the run after the current tick with a complete recording and
    an 'interrupted' status."""
    scene = tmp_path / "long.yaml"
    scene.write_text(LOOP.replace("until: 0.2", "until: 10000"))
    out = tmp_path / "long.mcap"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "run", str(scene), "-o", str(out), "-q"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 60
    while not _part_bigger_than(out, 50_000) and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1, err
    assert "interrupted by SIGTERM" in err
    rec = Recording(out)
    status = rec.status()
    assert status.status == "interrupted" and status.tick > 0
    assert rec.channels["/g/out"].count == status.tick


def test_truncated_and_corrupt_recordings_get_clear_errors(tmp_path):
    """A truncated file, a non-MCAP file and a missing file each raise one clear RecordingError."""
    good = run_scene(loads(LOOP), tmp_path / "good.mcap", progress=False).recording
    data = good.read_bytes()
    (tmp_path / "trunc.mcap").write_bytes(data[: len(data) // 2])
    (tmp_path / "junk.mcap").write_bytes(b"not an mcap file at all" * 10)
    with pytest.raises(RecordingError, match=r"trunc\.mcap: not a readable MCAP recording \(truncated or corrupt"):
        Recording(tmp_path / "trunc.mcap")
    with pytest.raises(RecordingError, match=r"junk\.mcap: not a readable MCAP recording"):
        Recording(tmp_path / "junk.mcap")
    with pytest.raises(RecordingError, match=r"missing\.mcap: no such file"):
        Recording(tmp_path / "missing.mcap")


def test_record_selection_applies_to_viewer_channels(tmp_path):
    """record.channels patterns select viewer channels too: none are written unless they match."""
    from cosim.record.recorder import DerivedMessage

    def deriver(time_ns, component, port, msg):
        yield DerivedMessage("/scene/x", "demo.X", "jsonschema", b"{}", "json", b"{}")

    scene = loads(LOOP, overrides=["record.channels=['/g/*']"])
    path = run_scene(scene, tmp_path / "sel.mcap", progress=False, derivers=[deriver]).recording
    assert "/scene/x" not in Recording(path).channels
    path = run_scene(loads(LOOP), tmp_path / "all.mcap", progress=False, derivers=[deriver]).recording
    assert Recording(path).channels["/scene/x"].count > 0


def test_a_deriver_sees_only_the_ports_it_watches(tmp_path):
    """A deriver with ``watches`` is shown the messages of the ports it watches and no others (and is
    asked once per port); one without ``watches`` sees every exchange."""
    from cosim.record.recorder import DerivedMessage

    class Picky:
        def __init__(self):
            self.asked, self.seen = [], set()

        def watches(self, component, port, message_type):
            self.asked.append((component, port))
            return component == "g"

        def __call__(self, time_ns, component, port, msg):
            self.seen.add((component, port))
            yield DerivedMessage("/scene/g", "demo.G", "jsonschema", b"{}", "json", b"{}")

    seen_by_all = set()

    def everything(time_ns, component, port, msg):
        seen_by_all.add((component, port))
        return ()

    picky = Picky()
    path = run_scene(loads(LOOP), tmp_path / "picky.mcap", progress=False, derivers=[picky, everything]).recording
    ports = {(c, p) for c, p in seen_by_all}
    assert {c for c, _ in ports} > {"g"} and sorted(picky.asked) == sorted(ports)
    assert picky.seen == {(c, p) for c, p in ports if c == "g"}
    assert Recording(path).channels["/scene/g"].count > 0


def test_a_deriver_is_shown_a_port_only_from_the_time_it_is_due(tmp_path):
    """A deriver with ``due_ns`` is shown a port's messages from its next due time on, not before;
    the same recording made by a deriver shown every message holds the same viewer messages."""
    from cosim.record.recorder import DerivedMessage

    class Framed:
        """One message every 10 ms of a port's messages (a frame rate), naming the time."""

        def __init__(self, with_due: bool):
            self.due, self.shown = {}, []
            if with_due:
                self.due_ns = lambda component, port: self.due.get((component, port), 0)

        def __call__(self, time_ns, component, port, msg):
            self.shown.append(time_ns)
            if time_ns >= self.due.get((component, port), 0):
                self.due[(component, port)] = time_ns + 10_000_000
                yield DerivedMessage(f"/scene/{component}", "demo.F", "jsonschema", b"{}", "json", b"%d" % time_ns)

    framed, plain = Framed(True), Framed(False)
    a = run_scene(loads(LOOP), tmp_path / "a.mcap", progress=False, derivers=[framed]).recording
    b = run_scene(loads(LOOP), tmp_path / "b.mcap", progress=False, derivers=[plain]).recording
    views = [[(t, d) for t, topic, d in ((t, topic, d) for topic, t, d in Recording(path).raw())
              if topic.startswith("/scene/")] for path in (a, b)]
    assert views[0] == views[1] and len(views[0]) > 40
    assert len(framed.shown) == len(views[0]) < len(plain.shown) / 5


def test_killed_run_still_leaves_a_complete_file(tmp_path):
    """Even SIGKILL of the simulating process leaves a valid, indexed recording: the writer process
    sees its pipe close and finishes the file (only the final status record is missing)."""
    scene = tmp_path / "long.yaml"
    scene.write_text(LOOP.replace("until: 0.2", "until: 10000"))
    out = tmp_path / "killed.mcap"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "run", str(scene), "-o", str(out), "-q"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while not _part_bigger_than(out, 50_000) and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.kill()
    proc.wait(30)
    while not out.exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    rec = Recording(out)
    assert rec.status() is None
    assert rec.channels["/g/out"].count > 100




@pytest.mark.skipif(not hasattr(os, "sched_setaffinity") or len(os.sched_getaffinity(0)) < 2
                    or not Path("/proc/self/stat").exists(), reason="needs two cores and /proc")
def test_the_writer_keeps_off_the_simulations_core_until_the_simulation_waits():
    """A writer's placement: every core it may use but the one this process last ran on, then,
    once told this process only waits, every core again."""
    from cosim.record.writer import WriterPlacement

    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(30)"])
    try:
        allowed = os.sched_getaffinity(child.pid)
        placement = WriterPlacement(child.pid)
        placement.avoid_mine()
        assert placement.avoided in allowed and os.sched_getaffinity(child.pid) == allowed - {placement.avoided}
        placement.anywhere()
        assert os.sched_getaffinity(child.pid) == allowed and placement.avoided == -1
    finally:
        child.kill()
        child.wait()
    placement.avoid_mine()  # the writer gone: nothing to place, no error


def test_thinning_keeps_every_event_so_the_history_stays_true(tmp_path):
    """--record-every 7 thins the states and forces, not the stage changes and skips (event outputs):
    the thinned recording holds the same stage and skip messages as the whole one (it kept one stage
    in seven, and inspect and plot then told a false history)."""
    from components.messages import SkipRecord, Stage
    from cosim.cli import main
    from cosim.record.reader import Recording

    skip = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    whole, thin = tmp_path / "whole.mcap", tmp_path / "thin.mcap"
    assert main(["run", str(skip), "--until", "0.6", "-o", str(whole), "-q"]) == 0
    assert main(["run", str(skip), "--until", "0.6", "-o", str(thin), "-q", "--record-every", "7"]) == 0
    a, b = Recording(whole), Recording(thin)
    for topic, kind in (("/stages/stage", Stage), ("/stages/skip", SkipRecord)):
        assert [t for t, _ in a.messages(topic, kind)] == [t for t, _ in b.messages(topic, kind)], topic
    assert b.channels["/stone/state"].count < a.channels["/stone/state"].count / 6


@pytest.mark.parametrize(("ticks", "samples"), [(10, [10]), (250, [100, 100, 50]), (200, [100, 100])])
def test_perf_samples_cover_every_tick_of_the_run(tmp_path, ticks, samples):
    """--perf records /perf/tick every 100 ticks and the run's last ones: a run of 10 ticks recorded
    none before, with no word."""
    from cosim.record.recorder import PERF_TOPIC, PerfSample

    outcome = run_scene(loads(LOOP), tmp_path / "run.mcap", until_ns=ticks * 1_000_000, progress=False, perf=True)
    rec = Recording(outcome.recording)
    assert [m.ticks for _, m in rec.messages(PERF_TOPIC, PerfSample)] == samples
