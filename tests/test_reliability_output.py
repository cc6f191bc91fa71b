"""Where a recording goes: never onto the scene or a file that is not a recording, always through a
private file moved into place when complete, and a clear line (never a traceback) when the writer is
killed (the recording salvaged up to then) or the disk fills up (the recording closed where it was
cut)."""

from __future__ import annotations

import os
import resource
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.errors import RecordingError
from cosim.record.output import check_output, claim
from cosim.record.reader import Recording
from cosim.record.writer import RING_BYTES
from cosim.runner import run_scene
from cosim.scenario import loads
from tests.cli_toys import DEMO_SCENE, one_error_line
from tests.test_recording_paths import Frame

ROOT = Path(__file__).resolve().parents[1]
WAIT_S = 60  # longest wait for a subprocess to get somewhere (never a measured time)

SCENE = DEMO_SCENE
LONG = SCENE.replace("until: 0.05", "until: 100000")


def cosim_popen(*args: str, cwd: Path, **kw) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-m", "cosim.cli", *args], cwd=cwd, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, **kw)


def long_run(tmp_path: Path, out: Path) -> subprocess.Popen:
    """`cosim run` of a scene that runs until stopped (LONG), recording to ``out``."""
    long = tmp_path / "long.yaml"
    long.write_text(LONG)
    return cosim_popen("run", str(long), "-o", str(out), "-q", cwd=tmp_path)


def parts(out: Path) -> list[Path]:
    return sorted(out.parent.glob(out.name + ".*.part"))


def wait_for_part(out: Path, size: int = 20_000) -> Path:
    deadline = time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        big = [p for p in parts(out) if p.exists() and p.stat().st_size > size]
        if big:
            return big[0]
        time.sleep(0.02)
    raise AssertionError(f"no private file for {out} grew past {size} bytes")


def children(pid: int) -> list[int]:
    text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    return [int(c) for c in text.split()]


@pytest.mark.parametrize("spelling", ["same", "dotted", "relative"])
def test_the_scene_is_never_the_output(scene, tmp_path, capsys, monkeypatch, spelling):
    """`cosim run S.yaml -o S.yaml` (however S is spelled) exits 2 in one line and leaves S as it was."""
    monkeypatch.chdir(tmp_path)
    target = {"same": str(scene), "dotted": str(tmp_path / "sub" / ".." / scene.name),
              "relative": scene.name}[spelling]
    assert main(["run", str(scene), "-o", target, "-q"]) == 2
    assert "is the run's own input" in one_error_line(capsys.readouterr().err)
    assert scene.read_text() == SCENE
    assert not list(tmp_path.glob("*.part"))


def test_outputs_that_are_not_recordings_are_refused(scene, tmp_path, capsys):
    """-o onto a folder, a device, a file that is not MCAP or a read-only recording: exit 2, one line,
    nothing touched."""
    notes = tmp_path / "notes.txt"
    notes.write_text("keep me")
    folder = tmp_path / "folder"
    folder.mkdir()
    old = tmp_path / "old.mcap"
    assert main(["run", str(scene), "-o", str(old), "-q"]) == 0
    old.chmod(stat.S_IRUSR | stat.S_IRGRP)
    capsys.readouterr()
    cases = {str(folder): "is a folder", os.devnull: "is not a regular file", str(notes): "is not an MCAP recording",
             str(old): "is read-only"}
    for target, why in cases.items():
        assert main(["run", str(scene), "-o", target, "-q"]) == 2, target
        assert why in one_error_line(capsys.readouterr().err)
    assert notes.read_text() == "keep me" and list(folder.iterdir()) == []
    assert not list(tmp_path.glob("*.part"))


def test_an_mcap_file_cosim_did_not_write_is_not_overwritten(scene, tmp_path, capsys):
    """-o onto another program's MCAP file (a robot's log): exit 2 naming its writer, the file
    untouched; it was replaced like a recording of cosim's."""
    from mcap.writer import Writer

    bag = tmp_path / "robot.mcap"
    with open(bag, "wb") as f:
        writer = Writer(f)
        writer.start(profile="ros2", library="someone-elses-logger")
        schema = writer.register_schema("std_msgs/String", "ros2msg", b"string data")
        channel = writer.register_channel("/chatter", "cdr", schema)
        writer.add_message(channel, log_time=1, data=b"hello", publish_time=1)
        writer.finish()
    data = bag.read_bytes()
    assert main(["run", str(scene), "-o", str(bag), "-q"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert "cosim did not write" in line and "someone-elses-logger" in line
    assert bag.read_bytes() == data and not list(tmp_path.glob("*.part"))


def test_a_recording_cut_short_is_not_replaced_but_sent_to_repair(scene, tmp_path, capsys):
    """-o onto a recording cut short (a copy that stopped, a disk that filled): exit 2 pointing to
    `cosim repair`, the file untouched; it was replaced, and what repair could have kept was lost. A
    whole recording is still replaced."""
    whole = tmp_path / "whole.mcap"
    assert main(["run", str(scene), "-o", str(whole), "-q"]) == 0
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole.read_bytes()[:whole.stat().st_size // 2])
    data = cut.read_bytes()
    assert main(["run", str(scene), "-o", str(cut), "-q"]) == 2
    assert one_error_line(capsys.readouterr().err) == (
        f"error: {cut}: exists and is a recording cut short (no MCAP end); it is not replaced: `cosim repair "
        f"{cut}` keeps what it holds (or remove it, or choose another output)")
    assert cut.read_bytes() == data and not list(tmp_path.glob("*.part"))
    assert main(["run", str(scene), "-o", str(whole), "-q"]) == 0


def test_an_existing_recording_is_replaced_only_when_the_new_one_is_complete(scene, tmp_path, capsys):
    """The recording is written to a private file with a unique name beside the target and moved
    onto it when complete; until then the target keeps the previous recording."""
    out = tmp_path / "run.mcap"
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 0
    first = out.read_bytes()
    a, b = claim(out), claim(tmp_path / "other.mcap")
    try:
        assert a.part.parent == tmp_path and a.part.name.startswith("run.mcap.") and a.part.name.endswith(".part")
        assert out.read_bytes() == first  # claiming does not touch the target
    finally:
        a.release(remove=True)
        b.release(remove=True)
    assert run_scene(loads(SCENE.replace("0.05", "0.02")), out, progress=False).recording == out
    assert out.read_bytes() != first and Recording(out).status().tick == 20
    assert parts(out) == []


@pytest.mark.parametrize("umask", [0o022, 0o077])
def test_a_recording_gets_the_mode_of_any_new_file(tmp_path, umask):
    """Not tempfile's 0600: readable by whoever the user's umask lets read their files."""
    old = os.umask(umask)
    try:
        out = run_scene(loads(SCENE), tmp_path / "run.mcap", progress=False).recording
    finally:
        os.umask(old)
    assert stat.S_IMODE(out.stat().st_mode) == 0o666 & ~umask


def test_a_second_run_on_the_same_output_is_refused_while_the_first_writes(tmp_path):
    """Two runs on one path: the second is refused in one line (exit 2) while the first is writing,
    and the first still finishes a valid recording."""
    out = tmp_path / "same.mcap"
    first = long_run(tmp_path, out)
    try:
        wait_for_part(out)
        second = long_run(tmp_path, out)
        _, err = second.communicate(timeout=WAIT_S)
        assert second.returncode == 2
        assert "another run is writing it now" in one_error_line(err)
    finally:
        first.send_signal(signal.SIGTERM)
        _, err = first.communicate(timeout=WAIT_S)
    assert first.returncode == 1 and "interrupted by SIGTERM" in err
    assert Recording(out).status().status == "interrupted"
    assert parts(out) == []


def test_claims_of_one_target_exclude_each_other(tmp_path):
    """claim() refuses a target another live claim is writing, and allows it once that one ends."""
    out = tmp_path / "x.mcap"
    held = claim(out)
    with pytest.raises(RecordingError, match="another run is writing it now"):
        claim(out)
    held.release(remove=True)
    claim(out).release(remove=True)
    assert parts(out) == []


def test_a_private_file_is_locked_before_another_run_can_find_it(tmp_path, monkeypatch):
    """The private file gets its .part name (the one another run looks for) only once locked: made and
    locked under it, a run starting at that moment found it unlocked, said it was an earlier run's
    leftover to repair, and its probe's shared lock could make the first run's own lock fail."""
    import cosim.record.output as output

    seen = []
    renamed = output.rename_new

    def rename_new(source, target):
        seen.append((Path(target).suffix, output.being_written(str(source)), list(tmp_path.glob("*.part"))))
        renamed(source, target)

    monkeypatch.setattr(output, "rename_new", rename_new)
    held = claim(tmp_path / "x.mcap")
    assert seen == [(".part", True, [])]  # locked already, and no .part to be found before the rename
    assert output.being_written(str(held.part)) and held.part.suffix == ".part"
    held.release(remove=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_a_private_file_removed_as_it_is_looked_at_is_no_leftover(tmp_path, monkeypatch, recwarn):
    """A run that ends removes its private file, then lets go of its lock: found by another run's look
    between the two, or gone by the time it is opened, it was said to be what an earlier run left,
    with a repair of a file no longer there."""
    import cosim.record.output as output

    out = tmp_path / "x.mcap"
    ending = claim(out)

    def being_written(part):  # the other run ends just as it is looked at
        ending.release(remove=True)
        return False

    monkeypatch.setattr(output, "being_written", being_written)
    claim(out).release(remove=True)
    assert [str(w.message) for w in recwarn] == []
    assert parts(out) == []


def test_a_whole_recording_left_under_a_private_name_is_said_whole_not_cut_short(tmp_path):
    """A finished recording its run could not move onto its target (the folder made read-only) stays
    under its private .part name: the next run said it was cut short and that repair would make it a
    recording, and repair refused it as whole already. It is said whole, with the name to give it;
    one cut short is still sent to repair."""
    out = tmp_path / "x.mcap"
    assert main(["run", str(tmp_path / "s.yaml") if (tmp_path / "s.yaml").write_text(SCENE) else "", "-q",
                 "-o", str(out)]) == 0
    whole = tmp_path / "x.mcap.0123abcd.part"
    out.rename(whole)
    with pytest.warns(UserWarning) as said:
        claim(out).release(remove=True)
    assert [str(w.message) for w in said] == [
        f"{out}: beside it, {whole.name} is a whole recording an earlier run could not move onto it; give it a "
        f"name ending in .mcap to keep it (mv {whole} {tmp_path / 'x.mcap.kept.mcap'})"]
    whole.write_bytes(whole.read_bytes()[:-100])
    with pytest.warns(UserWarning, match=r"is what an earlier run left cut short \(killed with its writer\); "
                                         rf"cosim repair {whole} makes it a valid recording"):
        claim(out).release(remove=True)


def test_the_writer_killed_mid_run_is_one_line_and_leaves_the_recording_salvaged(tmp_path, capsys):
    """SIGKILL of the writer process: exit 1, one line saying so and up to when and where the
    recording was salvaged; the output is a valid recording, ending there with a `failed` status
    (tests/test_reliability_salvage.py checks its messages one by one)."""
    out = tmp_path / "k.mcap"
    proc = long_run(tmp_path, out)
    try:
        wait_for_part(out)
        (writer,) = children(proc.pid)
        os.kill(writer, signal.SIGKILL)
        _, err = proc.communicate(timeout=WAIT_S)
    finally:
        proc.kill()
    assert proc.returncode == 1
    rec = Recording(out)
    line = one_error_line(err)
    assert line.startswith(f"error: {out}: the recording writer was killed (SIGKILL); the recording was salvaged "
                           f"up to t = {rec.end_ns / 1e9:g} s, all the run had recorded (")
    assert line.endswith(f"into {out}")
    status = rec.status()
    assert status.status == "failed" and status.reason.startswith("the recording writer was killed (SIGKILL)")
    assert rec.channels["/src/out"].count >= status.tick > 0
    assert parts(out) == []
    assert main(["inspect", str(out)]) == 0
    assert f"status: failed at t = {status.time:g} s" in capsys.readouterr().out


def test_a_writer_that_stops_answering_does_not_hold_the_command_past_a_second_ctrl_c(tmp_path):
    """The writer process stopped (SIGSTOP: stuck on a file system, say) while the run goes on: two
    Ctrl-C end the command (exit 1, one line) instead of each moving it on to its next wait for the
    writer; the writer, let go on, then finishes the recording on its own."""
    out = tmp_path / "s.mcap"
    proc = long_run(tmp_path, out)
    writer = None
    try:
        wait_for_part(out)
        (writer,) = children(proc.pid)
        os.kill(writer, signal.SIGSTOP)
        os.kill(proc.pid, signal.SIGINT)
        time.sleep(0.5)
        os.kill(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=WAIT_S)
    finally:
        proc.kill()
        if writer is not None:
            os.kill(writer, signal.SIGCONT)
    assert proc.returncode == 1
    assert one_error_line(err).startswith("error: ")
    deadline = time.monotonic() + WAIT_S
    while (parts(out) or not out.exists()) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert out.exists() and parts(out) == []
    assert Recording(out).end_ns > 0


# above the shared-memory ring (its memory file counts against the limit too), below PAINT's 96 MB recording
FILE_LIMIT = RING_BYTES + (8 << 20)
PAINT_FRAMES = 800

PAINT = """
dt: 0.001
until: %g
components:
  p: {type: "tests.test_recording_paths:Painter"}
record: {visual_rate: 0}
""" % (PAINT_FRAMES / 1000)


def _small_file_limit() -> None:
    resource.setrlimit(resource.RLIMIT_FSIZE, (FILE_LIMIT, FILE_LIMIT))


SMALL_LIMIT = 20 << 20  # bytes: a file-size limit below the writer's usual shared memory (64 MiB)


def _limit_below_the_ring() -> None:
    resource.setrlimit(resource.RLIMIT_FSIZE, (SMALL_LIMIT, SMALL_LIMIT))


def test_a_file_size_limit_below_the_shared_memory_still_records(tmp_path):
    """Under a file-size limit lower than the writer's shared memory (which counts against it), the
    writer takes a smaller share and the run records as usual (every recorded run failed at its
    start, blaming its output file); a limit too small even for that says so."""
    scene = tmp_path / "s.yaml"
    scene.write_text(SCENE)
    out = tmp_path / "s.mcap"
    proc = cosim_popen("run", str(scene), "-o", str(out), "-q", cwd=tmp_path, preexec_fn=_limit_below_the_ring)
    _, err = proc.communicate(timeout=WAIT_S)
    assert proc.returncode == 0, err
    assert Recording(out).status().status == "ok"

    def tiny() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (256 << 10, 256 << 10))

    proc = cosim_popen("run", str(scene), "-o", str(tmp_path / "t.mcap"), "-q", cwd=tmp_path, preexec_fn=tiny)
    _, err = proc.communicate(timeout=WAIT_S)
    assert proc.returncode == 1
    assert "the file-size limit (ulimit -f) is below the 1 MiB of shared memory" in one_error_line(err)
    assert not (tmp_path / "t.mcap").exists() and parts(tmp_path / "t.mcap") == []


def test_a_full_disk_is_one_line_and_keeps_what_fitted(tmp_path, capsys):
    """Writes that fail (a file-size limit stands in for a full disk): exit 1, one line with the
    system's reason, and the recording closed where it was cut: the run's first messages exactly as a
    run with room for all of them writes them, ending with a failed status."""
    scene = tmp_path / "big.yaml"
    scene.write_text(PAINT)
    out = tmp_path / "full.mcap"
    proc = cosim_popen("run", str(scene), "-o", str(out), "-q", cwd=tmp_path, preexec_fn=_small_file_limit)
    _, err = proc.communicate(timeout=WAIT_S)
    assert proc.returncode == 1
    line = one_error_line(err)
    assert os.strerror(27) in line and "the recording was closed where it stopped, at t = " in line  # EFBIG
    assert parts(out) == [] and out.stat().st_size <= FILE_LIMIT
    rec = Recording(out)
    status = rec.status()
    assert status.status == "failed" and os.strerror(27) in status.reason
    assert "the recording was closed where it stopped, at t = " in status.reason  # as the command's line says
    kept = rec.messages("/p/frame", Frame)
    assert 0 < len(kept) < PAINT_FRAMES and f"at t = {kept[-1][0] / 1e9:g} s" in line
    room = tmp_path / "room.mcap"
    run_scene(loads(PAINT), room, progress=False)
    assert list(rec.raw(["/p/frame"])) == list(Recording(room).raw(["/p/frame"]))[:len(kept)]
    assert main(["inspect", str(out)]) == 0
    assert "status: failed" in capsys.readouterr().out


def test_check_output_accepts_new_files_and_recordings(tmp_path):
    """A new file, or an existing recording, may be written."""
    out = tmp_path / "new.mcap"
    assert check_output(out) == out
    run_scene(loads(SCENE), out, progress=False)
    assert check_output(out) == out


FIGURE_LIMIT = 8 << 10  # bytes: less than any figure or frame


def _figure_limit() -> None:
    resource.setrlimit(resource.RLIMIT_FSIZE, (FIGURE_LIMIT, FIGURE_LIMIT))


@pytest.mark.parametrize("command", ["plot", "render"])
def test_figures_on_a_full_disk_are_one_line_and_leave_nothing_half_written(tmp_path, command):
    """plot and render writing into a full disk (a file-size limit stands in for it): exit 1, one
    line naming the file and the system's reason, no truncated picture and no temporary left. Before,
    plot left a truncated PNG and both said "internal error"."""
    from tests.viewer_toys import record_skip

    recording = tmp_path / "skip.mcap"
    record_skip(recording, ["until=0.2", "record.visual_rate=0"])
    out = tmp_path / "figs"
    target = out / "trajectory.png" if command == "plot" else out / "frame.png"
    args = ["plot", str(recording), "-o", str(out)] if command == "plot" else [
        "render", str(recording), "-o", str(target), "-q"]
    proc = cosim_popen(*args, cwd=tmp_path, preexec_fn=_figure_limit)
    _, err = proc.communicate(timeout=WAIT_S)
    assert proc.returncode == 1
    line = one_error_line(err)
    assert line == f"error: {target}: cannot be written ({os.strerror(27)})"  # EFBIG: File too large
    assert not out.exists()  # the folder it made for them goes too


def test_sigterm_while_plot_writes_is_one_line_and_leaves_nothing_half_written(tmp_path, capsys, monkeypatch):
    """A SIGTERM (a job scheduler, `kill`) lands as plot writes its first figure: exit 1, one line
    saying so, and neither the figure nor its temporary left. Before, the process died of the signal
    (exit 143, nothing said) and left `trajectory.png.tmp`."""
    from matplotlib.figure import Figure

    from cosim.cli import main
    from tests.viewer_toys import record_skip

    recording = tmp_path / "skip.mcap"
    record_skip(recording, ["until=0.2", "record.visual_rate=0"])
    out = tmp_path / "figs"

    def terminated_midway(fig, target, **kwargs):
        Path(target).write_bytes(b"\x89PNG half")
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(2.0)
        raise AssertionError("the signal did not arrive")

    monkeypatch.setattr(Figure, "savefig", terminated_midway)
    before = signal.getsignal(signal.SIGTERM)
    assert main(["plot", str(recording), "-o", str(out)]) == 1
    assert one_error_line(capsys.readouterr().err) == "error: cosim plot: interrupted (SIGTERM)"
    assert not out.exists() or not any(out.iterdir())
    assert signal.getsignal(signal.SIGTERM) is before  # the command's handler is gone with it


def test_file_names_near_the_limit_are_written_like_any_other(scene, tmp_path, capsys):
    """A recording named in 245 bytes and a picture in 250 (a file name holds 255): written, with
    nothing left beside them (their private and temporary files' longer names were refused as "File
    name too long"); a private file's stem is the same for the same name, so two runs on it still
    exclude each other."""
    from cosim.record.output import sibling_stem
    from tests.viewer_toys import record_skip

    out = tmp_path / ("a" * 240 + ".mcap")
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 0
    skip = tmp_path / "skip.mcap"
    record_skip(skip, ["until=0.05", "record.visual_rate=0"])
    picture = tmp_path / ("b" * 246 + ".png")
    assert main(["render", str(skip), "-o", str(picture), "-q"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([out.name, skip.name, picture.name, scene.name])
    stem = sibling_stem(out.name, 14)
    assert len(stem.encode()) + 14 <= 255 and stem == sibling_stem(out.name, 14) != sibling_stem("a" + out.name, 14)
    first = claim(out)
    try:
        with pytest.raises(RecordingError, match="another run is writing it now"):
            claim(out)
        from cosim.record.repair import default_output

        assert default_output(first.part) == tmp_path / f"{stem}-repaired.mcap"  # the name cannot be recovered
    finally:
        first.release(remove=True)


def test_an_output_folder_removed_during_the_run_is_made_again_with_the_whole_recording(tmp_path):
    """The recording's folder removed while the run records (its private file with it): the writer,
    which still holds the file, makes the folder again and writes the whole recording into it, and
    the command says so in one warning line (the recording was lost, with "No such file or directory",
    exit 2)."""
    import shutil

    out = tmp_path / "gone" / "x.mcap"
    proc = long_run(tmp_path, out)
    try:
        wait_for_part(out)
        shutil.rmtree(out.parent)
        os.kill(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=WAIT_S)
    finally:
        proc.kill()
    assert proc.returncode == 1  # interrupted, as asked
    lines = err.strip().splitlines()
    assert f"warning: {out}: its private file was removed while the run was recorded (with its folder?); the " \
           "whole recording was written there all the same" == lines[0]
    assert lines[-1] == "error: interrupted by SIGINT"
    status = Recording(out).status()
    assert status.status == "interrupted" and status.tick > 0
    assert parts(out) == [] and sorted(p.name for p in out.parent.iterdir()) == ["x.mcap"]


def test_a_whole_recording_that_cannot_be_moved_onto_its_target_is_kept_beside_it(tmp_path):
    """A folder made at the output's path while the run records: the finished recording cannot be
    moved there, and it is kept, whole, under a recording's name beside it, named in the one error
    line (it was removed: "no file was left")."""
    out = tmp_path / "x.mcap"
    proc = long_run(tmp_path, out)
    try:
        wait_for_part(out)
        out.mkdir()
        (out / "keep").touch()
        os.kill(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=WAIT_S)
    finally:
        proc.kill()
    assert proc.returncode == 1
    (kept,) = tmp_path.glob("x.mcap.*.mcap")
    line = one_error_line(err)
    assert line.startswith(f"error: {out}: the recording is whole (") and line.endswith(
        f"); it could not be moved there (Is a directory) and is kept as {kept}"), line
    status = Recording(kept).status()
    assert status.status == "interrupted" and status.tick > 0  # the run's own end, whole
    assert parts(out) == [] and (out / "keep").exists()


def test_a_run_killed_with_its_writer_leaves_a_file_that_repair_makes_a_recording(tmp_path, capsys):
    """SIGKILL of the run and its writer together leaves the private file, cut short: inspect points
    to `cosim repair`, which writes it as a valid recording (no final status) where it was meant to
    go, leaving the file given as it was; a whole recording is not "repaired"; a later run on the
    target says the file is there and how to recover it."""
    out = tmp_path / "k.mcap"
    proc = long_run(tmp_path, out)
    try:
        part = wait_for_part(out, size=200_000)
        (writer,) = children(proc.pid)
        os.kill(writer, signal.SIGKILL)
        os.kill(proc.pid, signal.SIGKILL)
        proc.communicate(timeout=WAIT_S)
    finally:
        proc.kill()
    from cosim.record.output import being_written

    deadline = time.monotonic() + WAIT_S
    while being_written(str(part)) and time.monotonic() < deadline:  # the killed writer's lock goes with it
        time.sleep(0.02)
    assert not out.exists() and parts(out) == [part]
    before = part.read_bytes()
    assert main(["inspect", str(part)]) == 2
    assert "cosim repair makes what it holds a valid recording" in one_error_line(capsys.readouterr().err)
    assert main(["repair", str(part)]) == 0, capsys.readouterr().err
    said = capsys.readouterr().out
    rec = Recording(out)
    assert said.startswith(f"wrote {out}: ") and f"up to t = {rec.end_ns / 1e9:g} s" in said
    assert rec.status() is None and rec.end_ns > 0 and part.read_bytes() == before
    assert main(["repair", str(out)]) == 2
    assert "is a whole recording already" in one_error_line(capsys.readouterr().err)
    short = tmp_path / "short.yaml"
    short.write_text(SCENE)
    with pytest.warns(UserWarning, match=rf"{part.name} is what an earlier run left cut short .* cosim repair"):
        assert main(["run", str(short), "-o", str(out), "-q"]) == 0


def test_a_dash_is_no_output_and_a_link_is_written_through(scene, tmp_path, capsys, monkeypatch):
    """-o - (standard output, as many tools read it): exit 2, no file named "-" (one was written);
    -o LINK: the recording goes where the link points and the link stays (it was replaced by a file)."""
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(scene), "-o", "-", "-q"]) == 2
    assert "not to standard output" in one_error_line(capsys.readouterr().err)
    assert not (tmp_path / "-").exists()
    target = tmp_path / "kept" / "target.mcap"
    target.parent.mkdir()
    link = tmp_path / "link.mcap"
    link.symlink_to(target)
    assert main(["run", str(scene), "-o", str(link), "-q"]) == 0
    assert link.is_symlink() and Recording(target).status().status == "ok"


@pytest.mark.parametrize("name", ["skip.png", "run1", "notes.mcap.txt"])
def test_a_recording_is_named_as_one(scene, tmp_path, capsys, name):
    """-o naming a file that does not end in .mcap (a picture's name, none at all): exit 2 with the
    name it should have, nothing written (a recording was written there, which viewers would not
    open as one)."""
    assert main(["run", str(scene), "-o", str(tmp_path / name), "-q"]) == 2
    assert "a recording's file name ends in .mcap" in one_error_line(capsys.readouterr().err)
    assert sorted(p.name for p in tmp_path.iterdir()) == [scene.name]
    assert main(["run", str(scene), "-o", str(tmp_path / "Loud.MCAP"), "-q"]) == 0


@pytest.mark.parametrize("where", ["loop.mcap", "loops/x.mcap"])
def test_an_output_through_a_symlink_loop_is_bad_input(scene, tmp_path, capsys, where):
    """A link that points at itself, as the output or as its folder: exit 2, one line naming the loop
    (it was an internal error: Python 3.11's resolve() raises RuntimeError on a loop)."""
    (tmp_path / "loop.mcap").symlink_to(tmp_path / "loop.mcap")
    (tmp_path / "loops").symlink_to(tmp_path / "loops")
    assert main(["run", str(scene), "-o", str(tmp_path / where), "-q"]) == 2
    assert one_error_line(capsys.readouterr().err).endswith(
        "cannot use it as the output (Too many levels of symbolic links)")


def test_a_hidden_file_named_mcap_is_told_it_needs_a_name(scene, tmp_path, capsys):
    """`-o o/.mcap` does end in .mcap: it was told that it should, and to write .mcap.mcap."""
    assert main(["run", str(scene), "-o", str(tmp_path / ".mcap"), "-q"]) == 2
    assert one_error_line(capsys.readouterr().err) == (
        f"error: {tmp_path / '.mcap'}: a recording's file name needs a name before .mcap "
        f"(give e.g. {tmp_path / 'run.mcap'})")


def test_an_interrupt_remembered_from_the_start_up_leaves_the_recording_there_as_it_was(scene, tmp_path):
    """A Ctrl-C that start-up remembered is raised just before the first step: nothing ran, so no
    recording is written. The recording already at the output was replaced by an empty one without
    a status."""
    out = tmp_path / "run.mcap"
    run_scene(loads(SCENE), out, progress=False)
    before = out.read_bytes()

    def interrupted() -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_scene(loads(SCENE), out, progress=False, before_run=interrupted)
    assert out.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([out.name, scene.name])


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_while_the_finished_run_is_written_out_still_tells_the_run_as_it_ended(scene, tmp_path, capsys,
                                                                                      monkeypatch, signum):
    """A Ctrl-C or SIGTERM after the last step, while the writer finishes the file: the run had ended
    and its recording is whole, so the summary is printed and the exit code is the run's (it said
    'interrupted' with exit 1, no summary, and a whole recording with an 'ok' status)."""
    from cosim.record.recorder import Recorder

    close = Recorder.close

    def signalled_close(self):
        os.kill(os.getpid(), signum)
        return close(self)

    monkeypatch.setattr(Recorder, "close", signalled_close)
    out = tmp_path / "run.mcap"
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 0
    assert f"recording: {out}" in capsys.readouterr().out
    assert Recording(out).status().status == "ok"


def test_a_recording_whose_name_holds_a_newline_is_named_on_one_line(scene, tmp_path, capsys):
    out = tmp_path / "new\nline.mcap"
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 0
    said = [line for line in capsys.readouterr().out.splitlines() if "recording:" in line]
    assert len(said) == 1 and "new\\nline.mcap (" in said[0], said
    assert Recording(out).status().status == "ok"


@pytest.mark.parametrize("below", ["x.mcap", "deeper/x.mcap"])
def test_an_output_under_a_file_names_the_file(scene, tmp_path, capsys, below):
    """-o a_file/x.mcap: the file standing where a folder should be is named (it said "cannot create
    its folder (File exists)", naming neither)."""
    (tmp_path / "a_file").write_text("x")
    assert main(["run", str(scene), "-o", str(tmp_path / "a_file" / below), "-q"]) == 2
    assert one_error_line(capsys.readouterr().err).endswith(
        f"cannot create its folder: {tmp_path / 'a_file'} is a file, not a folder")


def test_until_in_parts_of_a_nanosecond_is_refused_not_rounded(scene, capsys):
    """--until 1.5 ns ran to 2 ns and was said to be 2e-09 s: refused as a scene's times are."""
    with pytest.raises(SystemExit) as exc:
        main(["run", str(scene), "--until", "0.0000000015", "--no-record"])
    assert exc.value.code == 2
    assert one_error_line(capsys.readouterr().err).endswith(
        "--until: must be a whole number of nanoseconds, got 0.0000000015 s")


def test_validate_names_a_scene_whose_name_holds_a_newline_on_one_line(tmp_path, capsys):
    path = tmp_path / "new\nline.yaml"
    path.write_text(DEMO_SCENE)
    assert main(["validate", str(path)]) == 0
    assert capsys.readouterr().out.splitlines()[0].startswith(f"{tmp_path!s}/new\\nline.yaml: ok - ")
