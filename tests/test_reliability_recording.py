"""Damaged recordings are one line and exit 2 from every command that reads them (inspect, replay,
plot, render): every CRC is checked, so a flipped byte is an error and never a wrong value. A run
killed with SIGKILL leaves a valid recording without a status, which inspect calls incomplete.

A recording whose writing fails keeps everything up to the failure, and the run says so in one
line: a writer process stopped (or stuck) is given up on, killed and its recording salvaged; a
recording whose folder is replaced by a file during the run is rescued elsewhere; a disk that fills
as the file's summary is written leaves the recording whole (a warning, exit 0); a restart onto a
disk with room for nothing ends where it began; no room for even the private file is a full disk,
not bad input."""

from __future__ import annotations

import contextlib
import errno
import os
import resource
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from cosim.cli import main, report
from cosim.errors import RecordingError
from cosim.record import ring, writer
from cosim.record.reader import Recording
from cosim.record.recorder import Recorder
from cosim.record.writer import SinkError
from cosim.replay import replay_component
from cosim.runner import run_scene
from cosim.scenario import loads
from cosim.scheduler import BaseObserver, Simulation

ROOT = Path(__file__).resolve().parents[1]

SCENE = """
name: demo
dt: 0.001
until: 0.3
components:
  src: {type: "tests.toys:Source"}
  g: {type: "tests.toys:Gain"}
connections:
  - src.out -> g.x
record: {checkpoint_every: 0.1}
"""


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> bytes:
    out = tmp_path_factory.mktemp("good") / "good.mcap"
    run_scene(loads(SCENE), out, progress=False)
    return out.read_bytes()


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "Traceback" not in err
    return lines[0]


def data_positions(data: bytes) -> list[int]:
    """Byte positions spread over the whole file: header, chunks, attachments, summary, footer."""
    return sorted({8, 20, len(data) // 7, len(data) // 3, len(data) // 2, 2 * len(data) // 3,
                   len(data) - 200, len(data) - 40, len(data) - 12})


def test_every_flipped_byte_is_found(good, tmp_path):
    """A single bit flipped anywhere is a RecordingError on open or while reading, never a value."""
    bad = tmp_path / "bad.mcap"
    for pos in data_positions(good):
        data = bytearray(good)
        data[pos] ^= 0x10
        bad.write_bytes(bytes(data))
        with pytest.raises(RecordingError):
            rec = Recording(bad)
            for name in ("src", "g"):
                replay_component(rec, name)


def test_a_flipped_byte_in_a_chunk_is_a_crc_error(good, tmp_path):
    """A byte changed inside the compressed data: 'the CRC of its data does not match'."""
    data = bytearray(good)
    data[len(data) // 3] ^= 0x01
    bad = tmp_path / "flip.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises(RecordingError, match=r"flip\.mcap: corrupt: the CRC of its data does not match"):
        Recording(bad)


def _foreign(path: Path) -> None:
    from mcap.writer import Writer

    with open(path, "wb") as f:
        writer = Writer(f)
        writer.start(profile="", library="someone else")
        schema = writer.register_schema("x", "jsonschema", b"{}")
        channel = writer.register_channel("/x", "json", schema)
        writer.add_message(channel, 1, b"{}", 1)
        writer.finish()


def damaged_files(good: bytes, folder: Path) -> dict[str, Path]:
    files = {"flipped": bytearray(good), "truncated": good[: len(good) // 2], "header_only": good[:40],
             "magic_only": good[:8], "empty": b""}
    files["flipped"][len(good) // 2] ^= 0x04
    paths = {}
    for name, data in files.items():
        paths[name] = folder / f"{name}.mcap"
        paths[name].write_bytes(bytes(data))
    paths["foreign"] = folder / "foreign.mcap"
    _foreign(paths["foreign"])
    return paths


@pytest.mark.parametrize("command", ["inspect", "replay"])
def test_damaged_recordings_are_one_line_from_inspect_and_replay(good, tmp_path, capsys, command):
    """Byte-flipped, truncated, header-only, empty and foreign MCAP files: exit 2, one line each."""
    for name, path in damaged_files(good, tmp_path).items():
        assert main([command, str(path)]) == 2, name
        line = one_error_line(capsys.readouterr().err)
        assert line.startswith(f"error: {path}: "), line


def test_damaged_recordings_are_one_line_from_plot_and_render(good, tmp_path):
    """plot and render (registered through entry points) say the same one line, exit 2."""
    paths = damaged_files(good, tmp_path)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    for name in ("flipped", "truncated", "foreign"):
        for args in (["plot", str(paths[name])], ["render", str(paths[name]), "-o", str(tmp_path / "f.png")]):
            proc = subprocess.run([sys.executable, "-m", "cosim.cli", *args], cwd=tmp_path, env=env,
                                  capture_output=True, text=True, timeout=120)
            assert proc.returncode == 2, (name, args, proc.stderr)
            assert one_error_line(proc.stderr).startswith(f"error: {paths[name]}: ")


def test_a_run_killed_with_sigkill_leaves_a_valid_prefix_that_inspect_calls_incomplete(tmp_path, capsys):
    """SIGKILL of `cosim run`: the writer still finishes a valid file, without a status; inspect
    says it is incomplete and where it ends."""
    scene = tmp_path / "long.yaml"
    scene.write_text(SCENE.replace("until: 0.3", "until: 100000"))
    out = tmp_path / "killed.mcap"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "run", str(scene), "-o", str(out), "-q"],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not any(
            p.stat().st_size > 50_000 for p in tmp_path.glob("killed.mcap.*.part")):
        time.sleep(0.02)
    proc.kill()
    proc.wait(30)
    while not out.exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    rec = Recording(out)
    assert rec.status() is None
    assert main(["inspect", str(out)]) == 0
    text = capsys.readouterr().out
    end = rec.end_ns / 1e9
    assert ("status: missing - the recording is incomplete: the run was cut off (killed?) and it ends at "
            f"t = {end:g} s") in text


def test_a_recording_that_may_not_be_read_says_so_not_that_it_is_damaged(good, tmp_path, monkeypatch):
    """A recording this process may not open (its permissions: as root the test stands the refusal
    in for them): "cannot be read (Permission denied)", not "truncated or corrupt"."""
    import builtins
    import errno

    import cosim.record.reader as reader

    locked = tmp_path / "locked.mcap"
    locked.write_bytes(good)

    def refused(path, *args, **kwargs):
        if Path(path) == locked:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(path))
        return builtins.open(path, *args, **kwargs)

    monkeypatch.setattr(reader, "open", refused, raising=False)
    with pytest.raises(RecordingError) as info:
        Recording(locked)
    assert str(info.value) == f"{locked}: cannot be read (Permission denied)"


# --- a recording whose writing fails keeps everything up to the failure ------------------------------------

WAIT_S = 60  # longest wait for another process to get somewhere (never a measured time)
STOPPED_S = 0.3  # a writer found stopped this long is given up on (ring.STOPPED_S, shortened)


@pytest.fixture
def fresh_writer(monkeypatch):
    """The run starts its own writer process (not a spare an earlier test kept: this one starts in
    this test's working folder and is watched with this test's constants); the one it keeps is let
    go of afterwards."""
    monkeypatch.setattr(writer, "_spare", None)
    yield
    kept, writer._spare = writer._spare, None
    if kept is not None:
        kept.close()


def _kill_quietly(pid: int) -> None:
    with contextlib.suppress(OSError):
        os.kill(pid, signal.SIGKILL)


class StopWriter(BaseObserver):
    """Stops the run's recording writer (SIGSTOP) once ``tick`` is complete, as a debugger or a
    stuck file system would hold it; should the run never give up on it, a watchdog kills it after
    WAIT_S (the test then fails, rather than hangs)."""

    def __init__(self, tick: int):
        self.tick = tick
        self.pid = 0
        self.watchdog: threading.Timer | None = None

    def on_step_complete(self, sim: Simulation) -> None:
        if sim.tick == self.tick:
            (recorder,) = [o for o in sim.observers if isinstance(o, Recorder)]
            recorder.sink.flush()
            self.pid = recorder.sink.writer_pid
            os.kill(self.pid, signal.SIGSTOP)
            self.watchdog = threading.Timer(WAIT_S, _kill_quietly, (self.pid,))
            self.watchdog.start()


@pytest.mark.parametrize("when", ["mid-run", "at-the-end"])
def test_a_writer_that_stops_responding_is_killed_and_its_recording_salvaged(tmp_path, monkeypatch,
                                                                            fresh_writer, when):
    """The writer process stopped (SIGSTOP), mid-run (the ring fills up behind it) or as the run
    ends (the file is to be finished): found stopped for STOPPED_S, without any Ctrl-C, it is killed
    and the recording salvaged as for a writer killed; one line saying so (it waited for ever,
    without a word)."""
    monkeypatch.setattr(ring, "STOPPED_S", STOPPED_S)
    monkeypatch.setattr(ring, "WAIT_SLICE_S", 0.05)
    if when == "mid-run":  # a ring of 1 MiB, which the toy scene fills in a few thousand steps
        monkeypatch.setattr(writer, "_ring", lambda: ring.RingProducer(writer.SMALLEST_RING_BYTES))
        scene, stopper = loads(SCENE.replace("until: 0.3", "until: 100")), StopWriter(500)
    else:
        scene, stopper = loads(SCENE), StopWriter(300)
    out = tmp_path / "stopped.mcap"
    try:
        with pytest.raises(SinkError) as failure:
            run_scene(scene, out, progress=False, simulation=Simulation(scene, observers=[stopper]))
    finally:
        if stopper.watchdog is not None:
            stopper.watchdog.cancel()
        _kill_quietly(stopper.pid)
    rec = Recording(out)
    line = str(failure.value)
    assert line.startswith(f"{out}: the recording writer (process {stopper.pid}) stopped responding (its process "
                           f"has been stopped for {STOPPED_S:g} s), so it was killed; the recording was salvaged up "
                           f"to t = {rec.end_ns / 1e9:g} s, all the run had recorded ("), line
    assert line.endswith(f"into {out}")
    assert not Path(f"/proc/{stopper.pid}").exists()  # killed, and reaped
    assert not list(tmp_path.glob("stopped.mcap.*.part"))
    status = rec.status()
    if when == "mid-run":
        assert status.status == "failed" and status.tick >= 500
        assert status.reason.startswith(f"the recording writer (process {stopper.pid}) stopped responding")
    else:  # everything was sent, the run's own status too: all of it salvaged
        assert status.status == "ok" and rec.end_ns == scene.until_ns


class ReplaceTheFolder(BaseObserver):
    """At ``tick``, removes the folder ``folder`` (the recording's private file with it) and puts a
    file where it was: ``rm -rf DIR; touch DIR``."""

    def __init__(self, folder: Path, tick: int):
        self.folder, self.tick = folder, tick

    def on_step_complete(self, sim: Simulation) -> None:
        if sim.tick == self.tick:
            shutil.rmtree(self.folder)
            self.folder.touch()


def test_a_recording_whose_folder_is_replaced_by_a_file_is_rescued_into_the_working_folder(
        tmp_path, monkeypatch, fresh_writer, good):
    good_path = tmp_path / "good.mcap"
    good_path.write_bytes(good)
    """`-o DIR/d/x.mcap` and DIR replaced by a file during the run: the whole recording is rescued
    into the working folder as x.rescued.mcap, and the run fails in one line naming it (the recording
    was lost, and `cosim run` said "DIR/d/x.mcap: Not a directory", exit 2)."""
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)  # the writer starts here
    folder = tmp_path / "DIR"
    out = folder / "d" / "x.mcap"
    scene = loads(SCENE)
    with pytest.raises(SinkError) as failure:
        run_scene(scene, out, progress=False, simulation=Simulation(scene, observers=[ReplaceTheFolder(folder, 100)]))
    rescued = work / "x.rescued.mcap"
    assert str(failure.value) == (f"{out}: the finished recording could not be put there (Not a directory; its "
                                  "folder was removed or replaced during the run); the whole recording was rescued "
                                  f"into {rescued}")
    rec, whole = Recording(rescued), Recording(good_path)  # the whole run, as recorded with nothing in its way
    assert rec.status().status == "ok"
    assert list(rec.raw(sorted(rec.channels))) == list(whole.raw(sorted(whole.channels)))
    assert report(failure.value, "run") == 1  # a run that failed, its recording kept: not bad input


PAINT = """
name: paint
dt: 0.001
until: 0.05
components:
  p: {type: "tests.test_recording_paths:Painter"}
record: {visual_rate: 0%s}
"""


def _cosim(*args: str, cwd: Path, limit: int | None = None) -> subprocess.CompletedProcess:
    """`cosim ARGS` in a process of its own, under a file-size limit of ``limit`` bytes (which stands
    in for a disk that fills up there)."""
    def limited() -> None:
        if limit is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "cosim.cli", *args], cwd=cwd, env=env, text=True,
                          capture_output=True, timeout=WAIT_S, preexec_fn=limited)


SUMMARY_OFFSETS = 64  # bytes short of the whole file: the summary's offsets (about 150 bytes here) do not fit


def test_a_disk_that_fills_as_the_summary_is_written_leaves_the_recording_whole_and_the_run_ok(tmp_path):
    """The disk fills exactly as the writer writes the file's summary (a file-size limit a few bytes
    short of the whole file stands in): every message is there, so the run stands (exit 0) and one
    warning says the recording is whole, its summary written again without the summary offsets (it
    said "error: ...: the recording is whole (...), after File too large", exit 1)."""
    scene = tmp_path / "paint.yaml"
    scene.write_text(PAINT % "")
    room, cut = tmp_path / "room.mcap", tmp_path / "cuts.mcap"  # names of one length: files of one size
    assert _cosim("run", str(scene), "-q", "-o", str(room), cwd=tmp_path).returncode == 0
    size = room.stat().st_size
    proc = _cosim("run", str(scene), "-q", "-o", str(cut), cwd=tmp_path, limit=size - SUMMARY_OFFSETS)
    assert proc.returncode == 0, proc.stderr
    rec, whole = Recording(cut), Recording(room)
    messages = sum(c.count for c in rec.channels.values())
    assert proc.stderr.strip() == (f"warning: {cut}: the recording is whole ({messages} messages, to t = 0.05 s); "
                                   "its summary, cut short (File too large) as the writer finished the file, was "
                                   "written again without the summary offsets (readers do not need them)")
    assert rec.status().status == "ok"
    assert {t: c.count for t, c in rec.channels.items()} == {t: c.count for t, c in whole.channels.items()}
    assert list(rec.raw(sorted(rec.channels))) == list(whole.raw(sorted(whole.channels)))


def test_a_restart_onto_a_disk_with_room_for_nothing_ends_where_it_began(tmp_path):
    """`replay --from 0.02 -o OUT` under a limit that keeps none of its messages: the line and the
    recording's failed status stand at t = 0.02 s, where the restart began (they said t = 0 s, "the
    run's first 0 messages", and inspect "-20 steps from t = 0.02 s")."""
    scene = tmp_path / "paint.yaml"
    scene.write_text(PAINT % ", checkpoint_every: 0.01")
    source, out = tmp_path / "source.mcap", tmp_path / "restart.mcap"
    assert _cosim("run", str(scene), "-q", "-o", str(source), cwd=tmp_path).returncode == 0
    # room for the writer's shared memory (1 MiB at the least) and the file's start, not its first chunk
    proc = _cosim("replay", str(source), "--from", "0.02", "-o", str(out), cwd=tmp_path, limit=1030 << 10)
    assert proc.returncode == 1, proc.stderr
    assert one_error_line(proc.stderr) == (
        f"error: {out}: writing the recording failed (File too large); the recording was closed where it stopped, "
        "at t = 0.02 s (none of the run's messages), and what the run recorded after that was lost")
    status = Recording(out).status()
    assert (status.status, status.tick, status.time, status.component_steps) == ("failed", 20, 0.02, 0)
    assert "closed where it stopped, at t = 0.02 s" in status.reason


def test_no_room_for_even_the_private_file_is_a_full_disk_not_bad_input(scene, tmp_path, monkeypatch, capsys,
                                                                        fresh_writer):
    """The private file cannot be created for want of room (a disk's inodes used up: ENOSPC on
    creation): exit 1 with the words of a disk whose bytes ran out, nothing left (it was exit 2,
    "cannot write the recording", as for an output path that may not be written)."""
    def no_room(path, *args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(writer, "claim", no_room)
    out = tmp_path / "full.mcap"
    assert main(["run", str(scene), "-q", "-o", str(out)]) == 1
    assert one_error_line(capsys.readouterr().err) == (
        f"error: {out}: the recording could not be written: No space left on device; no file was left")
    assert not list(tmp_path.glob("full.mcap*"))
