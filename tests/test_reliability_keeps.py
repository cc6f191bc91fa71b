"""What a failing recording keeps, and what it never removes: a full disk that took none of the
run's messages leaves the recording there before; a second Ctrl-C during a salvage keeps the dead
writer's file; a recording kept beside its target stays when the run then discards its own; a
writer that stops answering as it finishes a file it had written whole lets the run stand; file
names no recording's metadata could hold, the private files of another target, and default names
past the file-name limit.

    run --records--> writer --> NAME.<8 hex digits>.part --> NAME      (cosim.record.writer)
"""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.record import salvage
from cosim.record.output import claim
from cosim.record.reader import Recording
from cosim.record.recorder import Recorder
from cosim.record.writer import SinkError
from cosim.runner import run_scene
from cosim.scenario import loads
from cosim.scheduler import BaseObserver, Simulation
from tests.cli_toys import DEMO_SCENE, fill_leaving, one_error_line, small_disk
from tests.test_reliability_salvage import KILL_TICK, ON_DISK, SCENE, KillWriter

ROOT = Path(__file__).resolve().parents[1]
WAIT_S = 60  # longest wait for another process to get somewhere (never a measured time)


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_full_disk_that_takes_none_of_the_runs_messages_leaves_the_recording_there_before(tmp_path, capsys):
    """8 KiB free on a real file system (a tmpfs) and a recording of 18 KB there: the new run's first
    batch does not fit, and the old recording is left as it was (it was replaced by one holding the
    failed status alone); nothing is left beside it."""
    with small_disk(tmp_path / "disk") as disk:
        out = disk / "old.mcap"
        scene = tmp_path / "demo.yaml"
        scene.write_text(DEMO_SCENE)
        assert main(["run", str(scene), "-q", "-o", str(out)]) == 0
        before = _digest(out)
        fill_leaving(disk, 8 << 10)
        capsys.readouterr()
        assert main(["run", str(scene), "--until", "100", "-q", "-o", str(out)]) == 1
        line = one_error_line(capsys.readouterr().err)
        assert line == (f"error: {out}: writing the recording failed ({os.strerror(28)}); none of the run's messages "
                        "could be written, so the recording there before is left as it was")
        assert _digest(out) == before and sorted(p.name for p in disk.iterdir()) == ["fill", "old.mcap"]


def test_a_second_ctrl_c_during_a_salvage_keeps_the_dead_writers_file(tmp_path, monkeypatch):
    """The writer killed mid-run, and the salvage interrupted (a Ctrl-C): the writer's file, the only
    copy of what it recorded, is kept and named, with how to repair it (it was removed: "salvaging
    what it had recorded failed too (interrupted); no file was left"). `cosim repair` makes it a
    valid recording of the run's first messages."""
    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(salvage, "rebuild", interrupted)
    out = tmp_path / "k.mcap"
    scene = loads(SCENE)
    with warnings.catch_warnings(record=True) as caught, pytest.raises((SinkError, KeyboardInterrupt)):
        warnings.simplefilter("always")
        run_scene(scene, out, progress=False, simulation=Simulation(scene, observers=[KillWriter(KILL_TICK, ON_DISK)]))
    (part,) = tmp_path.glob("k.mcap.*.part")
    said = [str(w.message) for w in caught if "interrupted" in str(w.message)]
    assert said == [f"{out}: the recording writer was killed (SIGKILL); salvaging what it had recorded was "
                    f"interrupted, and what the writer had written is kept as {part} (cosim repair {part} makes it "
                    "a valid recording)"]
    assert part.stat().st_size >= ON_DISK
    assert main(["repair", str(part)]) == 0
    assert Recording(out).channels["/src/out"].count > 0  # (the repair's default: the recording it was meant to be)


def test_a_recording_kept_beside_its_target_is_not_removed_when_the_run_discards_its_own(tmp_path):
    """The disk fills (a 2 MiB tmpfs) after a folder was made where the recording goes: the sealed
    recording cannot be moved there and is kept as NAME.<8 hex digits>.mcap, said so; the run then
    discards its recording, which removed that file too, leaving the line naming a file not there."""
    scene = tmp_path / "demo.yaml"
    scene.write_text(DEMO_SCENE)
    with small_disk(tmp_path / "disk") as disk:
        out = disk / "a.mcap"
        proc = subprocess.Popen([sys.executable, "-m", "cosim.cli", "run", str(scene), "--until", "1000", "-q", "-o",
                                 str(out)], cwd=tmp_path, text=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                env={**os.environ, "PYTHONPATH": str(ROOT)})
        try:
            deadline = time.monotonic() + WAIT_S
            while not list(disk.glob("a.mcap.*.part")) and time.monotonic() < deadline:
                time.sleep(0.01)
            out.mkdir()
            _, err = proc.communicate(timeout=WAIT_S)
        finally:
            proc.kill()
        assert proc.returncode == 1
        line = one_error_line(err)
        assert "writing the recording failed (No space left on device)" in line
        kept = Path(line.rsplit(" is kept as ", 1)[1])
        assert kept.parent == disk and kept.name.startswith("a.mcap.") and kept.suffix == ".mcap"
        assert kept.is_file() and Recording(kept).channels["/src/out"].count > 0


def test_a_writer_that_stops_answering_once_it_has_everything_lets_the_run_stand(tmp_path, monkeypatch):
    """The writer stopped (SIGSTOP) as it finishes the file, after it had taken every batch: it is
    killed and its recording salvaged whole, the run's ok status in it; the run stands, said in a
    warning (it was an error, exit 1, no summary, over a whole recording)."""
    from cosim.record import ring

    writer_pid = []

    class Pid(BaseObserver):
        def on_initialized(self, sim: Simulation) -> None:
            (recorder,) = [o for o in sim.observers if isinstance(o, Recorder)]
            writer_pid.append(recorder.sink.writer_pid)

    def stopped(self):
        deadline = time.monotonic() + WAIT_S
        while self.sent not in self.tallies() and time.monotonic() < deadline:
            time.sleep(0.01)
        os.kill(writer_pid[0], signal.SIGSTOP)
        raise ring.RingStuck("the consumer's process is stopped")

    monkeypatch.setattr(ring.RingProducer, "end_stream", stopped)
    out = tmp_path / "s.mcap"
    scene = loads(DEMO_SCENE)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        outcome = run_scene(scene, out, progress=False, simulation=Simulation(scene, observers=[Pid()]))
    assert outcome.result.status == "ok" and outcome.recording == out
    (said,) = [str(w.message) for w in caught if "salvaged" in str(w.message)]
    assert said.startswith(f"{out}: the recording writer (process {writer_pid[0]}) stopped responding")
    assert "all the run had recorded" in said
    status = Recording(out).status()
    assert status.status == "ok" and status.tick == 50


def test_a_writer_killed_while_the_last_batch_is_sent_lets_the_run_stand(tmp_path, monkeypatch):
    """The writer killed as the run, closing, sends its last batch: its recording is salvaged whole,
    the run's ok status in it, and the run stands, said in a warning, as when the writer dies later
    in closing (it was an error, exit 1, no summary, over a whole ok recording)."""
    from cosim.record.writer import ProcessSink

    send = ProcessSink._send

    def killed_first(self, batch):
        if self._closing and self._failed is None:
            self._writer.proc.kill()
            self._writer.proc.wait(WAIT_S)
        send(self, batch)

    monkeypatch.setattr(ProcessSink, "_send", killed_first)
    out = tmp_path / "s.mcap"
    scene = loads(DEMO_SCENE)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        outcome = run_scene(scene, out, progress=False)
    assert outcome.result.status == "ok" and outcome.recording == out
    (said,) = [str(w.message) for w in caught if "salvaged" in str(w.message)]
    assert "the recording writer was killed (SIGKILL)" in said and "all the run had recorded" in said
    status = Recording(out).status()
    assert status.status == "ok" and status.tick == 50


def test_the_private_files_of_another_target_are_not_taken_for_this_ones(tmp_path):
    """a.mcap.x.mcap's private file (a.mcap.x.mcap.<hex>.part) is not another run writing a.mcap, nor
    a leftover of a.mcap's: a.mcap is claimed without a word."""
    other = claim(tmp_path / "a.mcap.x.mcap")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            claim(tmp_path / "a.mcap").release(remove=True)
    finally:
        other.release(remove=True)


def test_default_names_past_the_file_name_limit_are_shortened(tmp_path, capsys):
    """A recording named in 247 bytes: repair's and replay --from's default outputs (STEM-repaired.mcap,
    STEM-from0.02s.mcap) are shortened with a digest, not refused ("File name too long")."""
    scene = tmp_path / "demo.yaml"
    scene.write_text(DEMO_SCENE + "record: {checkpoint_every: 0.01}\n")
    long = tmp_path / ("b" * 247 + ".mcap")
    assert main(["run", str(scene), "-q", "-o", str(long)]) == 0
    cut = tmp_path / ("c" * 247 + ".mcap")
    cut.write_bytes(long.read_bytes()[:6000])
    assert main(["repair", str(cut)]) == 0
    assert main(["replay", "--from", "0.02", str(long), "-q"]) == 0
    made = sorted(p.name for p in tmp_path.iterdir() if "~" in p.name)
    assert [n[-len("-repaired.mcap"):] if "repaired" in n else n[-len("-from0.02s.mcap"):] for n in made] == \
        ["-from0.02s.mcap", "-repaired.mcap"]
    assert all(len(n.encode()) <= 255 for n in made)


def test_a_scene_in_a_folder_whose_name_is_not_utf8_is_recorded(tmp_path, capsys):
    """A legal Linux folder name that is not UTF-8 (a byte 0xff): the recording's metadata holds it
    escaped, and the run records (every recording of such a scene failed, blamed on the writer)."""
    folder = Path(os.fsdecode(bytes(tmp_path) + b"/sc\xff"))
    folder.mkdir()
    (folder / "demo.yaml").write_text(DEMO_SCENE)
    out = tmp_path / "ok.mcap"
    assert main(["run", str(folder / "demo.yaml"), "-q", "-o", str(out)]) == 0
    rec = Recording(out)
    assert rec.metadata["base_dir"].endswith("/sc\\xff") and rec.status().status == "ok"


def test_replay_of_a_recording_whose_input_channel_holds_no_message_says_so(tmp_path, capsys):
    """A recording whose channels are declared but hold nothing: replay says which input has no message
    (it fed the component None, and reported "AttributeError" as the component's own failure)."""
    from cosim.record.reader import Recording as Reader

    full = tmp_path / "full.mcap"
    assert main(["run", str(ROOT / "scenarios" / "ping_pong.yaml"), "--until", "0.05", "-q", "-o", str(full)]) == 0
    empty = tmp_path / "empty.mcap"
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with open(full, "rb") as src, open(empty, "wb") as dst:
        reader = make_reader(src)
        summary = reader.get_summary()
        writer = Writer(dst)
        writer.start(profile="", library="test")
        ids = {}
        for schema in summary.schemas.values():
            ids[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
        for channel in summary.channels.values():
            writer.register_channel(channel.topic, channel.message_encoding, ids.get(channel.schema_id, 0),
                                    channel.metadata)
        for record in reader.iter_metadata():
            writer.add_metadata(record.name, record.metadata)
        for attachment in reader.iter_attachments():
            writer.add_attachment(attachment.log_time, attachment.create_time, attachment.name,
                                  attachment.media_type, attachment.data)
        writer.finish()
    assert "/ping/out" in Reader(empty).channels
    capsys.readouterr()
    assert main(["replay", str(empty), "--component", "pong"]) == 2
    assert "cannot replay 'pong': its input 'inp' comes from /ping/out, which the recording holds no message of" in \
        one_error_line(capsys.readouterr().err)
