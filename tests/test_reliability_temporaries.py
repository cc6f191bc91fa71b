"""The files a command writes before moving them into place, and the folders it makes, never cost the
user a file (found by an audit):

- every temporary file is new, of a unique name, created exclusively beside its target
  (``NAME.<8 hex digits>.tmp``, :func:`cosim.record.output.new_temporary`). The names were fixed,
  ``NAME.tmp`` (repair, plot, every ``written_whole``) and ``NAME.part`` (render): a file of the
  user's so named was written over and removed, so ``cosim repair victim.mcap.tmp -o victim.mcap``
  lost the only copy of the recording it was asked to mend, and plot and render lost the recording
  they drew; two repairs onto one output shared one temporary (the second truncated the file the
  first had memory-mapped: SIGBUS, or the first failed blaming its input);
- a run that leaves no file (no room even for its private file, a run discarded, a recording that
  could not be kept) removes the folders it made for it, the deepest first, each only while empty:
  it said "no file was left" and left them.
"""

from __future__ import annotations

import errno
import os
import stat
import subprocess
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.record.output import written_whole
from cosim.record.reader import Recording
from cosim.record.repair import repair
from cosim.record.writer import SinkError
from cosim.runner import run_scene
from cosim.scenario import load
from tests.cli_toys import one_error_line

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def water_run(tmp_path_factory) -> Path:
    """The reference skip for 20 ms (a body and its water: what plot and render draw); read-only."""
    out = tmp_path_factory.mktemp("temporaries") / "skip.mcap"
    assert run_scene(load(ROOT / "scenarios" / "skip.yaml", overrides=["until=0.02"]), out,
                     progress=False).result.status == "ok"
    return out


def _cut(recording: Path, where: Path) -> Path:
    """A copy of ``recording`` cut at two thirds (a killed run's file, which repair mends) at ``where``."""
    data = recording.read_bytes()
    where.write_bytes(data[:2 * len(data) // 3])
    return where


def test_repair_of_a_file_named_as_its_outputs_temporary_keeps_it(water_run, tmp_path, capsys):
    """`repair victim.mcap.tmp -o victim.mcap`: exit 2 and the file given, the only copy, gone. Now it
    is left as it was and the repaired recording is written."""
    cut = _cut(water_run, tmp_path / "victim.mcap.tmp")
    data = cut.read_bytes()
    assert main(["repair", str(cut), "-o", str(tmp_path / "victim.mcap")]) == 0
    assert capsys.readouterr().out.startswith(f"wrote {tmp_path / 'victim.mcap'}: ")
    assert cut.read_bytes() == data
    assert Recording(tmp_path / "victim.mcap").status() is None  # (the run's end was cut off)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["victim.mcap", "victim.mcap.tmp"]


def test_plot_and_render_of_a_recording_named_as_their_temporary_keep_it(water_run, tmp_path, capsys):
    """`plot figs/energy.png.tmp -o figs` and `render anim.gif.part -o anim.gif`: exit 0, and the
    recording drawn was gone (written over by the picture, then moved onto the target). Now it stays,
    beside the pictures, and no temporary is left."""
    data = water_run.read_bytes()
    figs = tmp_path / "figs"
    figs.mkdir()
    in_plots = figs / "energy.png.tmp"
    in_plots.write_bytes(data)
    assert main(["plot", str(in_plots), "-o", str(figs)]) == 0
    assert in_plots.read_bytes() == data
    assert sorted(p.name for p in figs.iterdir()) == [  # (no contact in 20 ms: no contacts.png)
        "energy.png", "energy.png.tmp", "motion.png", "trajectory.png"]
    for name in ("anim.gif.part", "anim.gif.tmp"):  # (render's temporary was NAME.part, written_whole's NAME.tmp)
        recording = tmp_path / name
        recording.write_bytes(data)
        assert main(["render", str(recording), "-o", str(tmp_path / "anim.gif"), "--speed", "0.1", "-q"]) == 0
        assert recording.read_bytes() == data
    capsys.readouterr()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["anim.gif", "anim.gif.part", "anim.gif.tmp", "figs"]


def test_a_read_only_output_is_refused_by_every_command_not_replaced(water_run, tmp_path, capsys):
    """A picture, a set of figures or a page made read-only: exit 2, "is read-only; it is not
    replaced", the file as it was (render, plot and components --markdown replaced it, exit 0: a new
    file moved onto it needs only the folder's leave, which a run's recording already refused)."""
    def read_only(path: Path, text: bytes = b"mine") -> Path:
        path.write_bytes(text)
        path.chmod(stat.S_IRUSR | stat.S_IRGRP | stat.S_IROTH)
        return path

    gif = read_only(tmp_path / "anim.gif")
    figs = tmp_path / "figs"
    figs.mkdir()
    trajectory = read_only(figs / "trajectory.png")
    page = read_only(tmp_path / "types.md")
    for argv, target in ((["render", str(water_run), "-o", str(gif), "--speed", "0.1", "-q"], gif),
                         (["plot", str(water_run), "-o", str(figs)], trajectory),
                         (["components", "--markdown", str(page)], page)):
        assert main(argv) == 2
        assert one_error_line(capsys.readouterr().err) == f"error: {target}: is read-only; it is not replaced"
        assert target.read_bytes() == b"mine"
    assert sorted(p.name for p in figs.iterdir()) == ["trajectory.png"]  # (all figures or none)

def test_a_written_whole_file_goes_through_a_new_temporary_of_its_own(tmp_path):
    """written_whole (a sweep's table, its figure, `components --markdown`, `fmu export`, repair):
    the user's `NAME.tmp` is neither written nor removed, on success or failure; the temporary is a
    new file with a new file's mode, and is gone afterwards."""
    target, theirs = tmp_path / "table.csv", tmp_path / "table.csv.tmp"
    theirs.write_text("the user's")
    with written_whole(target) as tmp:
        assert tmp.parent == tmp_path and tmp.name.startswith("table.csv.") and tmp.name.endswith(".tmp")
        assert tmp != theirs and tmp.is_file() and tmp.stat().st_size == 0
        umask = os.umask(0)
        os.umask(umask)
        assert stat.S_IMODE(tmp.stat().st_mode) == 0o666 & ~umask
        tmp.write_text("new")
    assert target.read_text() == "new"
    with pytest.raises(RuntimeError), written_whole(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("failed half-way")
    assert target.read_text() == "new" and theirs.read_text() == "the user's"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table.csv", "table.csv.tmp"]
    with pytest.raises(OSError) as missing, written_whole(tmp_path / "no" / "x.csv"):
        pass
    assert missing.value.errno == errno.ENOENT and missing.value.filename == str(tmp_path / "no" / "x.csv")
    with written_whole(target) as first, written_whole(target) as second:  # two writers of one target
        assert first != second
        first.write_text("first")
        second.write_text("second")
    assert target.read_text() == "first"  # (the last moved in wins)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table.csv", "table.csv.tmp"]


def test_two_repairs_onto_one_output_each_write_their_own_temporary(water_run, tmp_path, monkeypatch):
    """A second `repair` onto the same output, run from start to end while the first seals its copy:
    both succeed and the output is a valid recording (the last move wins). They shared
    `same.mcap.tmp`: the second truncated, rewrote and moved away the file the first was sealing (with
    a memory map: SIGBUS), and the first failed, blaming its input."""
    import cosim.record.seal as seal_module

    cut, out = _cut(water_run, tmp_path / "cut.mcap"), tmp_path / "same.mcap"
    sealing, second = [], []
    real_seal = seal_module.seal

    def seal_while_another_repair_runs(path, *args, **kwargs):
        if not sealing:
            sealing.append(path)
            second.append(repair(cut, out))
        return real_seal(path, *args, **kwargs)

    monkeypatch.setattr(seal_module, "seal", seal_while_another_repair_runs)
    first = repair(cut, out)
    assert second and first.messages == second[0].messages > 0 and first.path == second[0].path == out
    assert sum(c.count for c in Recording(out).channels.values()) == first.messages
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.mcap", "same.mcap"]


# --- folders made for a recording that was not written ---------------------------------------------


def test_a_run_with_no_room_for_its_file_leaves_no_folder_it_made(scene, tmp_path, capsys, monkeypatch):
    """No room for even the private file: "no file was left", exit 1, and the folders the run made for
    it gone too; a folder that was there before stays."""
    import cosim.record.recorder as recorder

    def no_room(*args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(recorder, "open_sink", no_room)
    (tmp_path / "was").mkdir()
    for out in (tmp_path / "nd" / "sub" / "x.mcap", tmp_path / "was" / "new" / "x.mcap"):
        assert main(["run", str(scene), "-o", str(out), "-q"]) == 1
        assert one_error_line(capsys.readouterr().err) == (
            f"error: {out}: the recording could not be written: {os.strerror(errno.ENOSPC)}; no file was left")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo.yaml", "was"]
    assert not any((tmp_path / "was").iterdir())
    # through a '..': the user's empty folder 'was' is not taken for one the run made (it was removed)
    out = tmp_path / "nothere" / ".." / "was" / "x.mcap"
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 1
    assert (tmp_path / "was").is_dir()


def test_a_run_that_discards_or_cannot_keep_its_recording_leaves_no_folder_it_made(scene, tmp_path, monkeypatch):
    """A run discarded before its first step (a Ctrl-C remembered from the start-up), and one whose
    recording could not be kept (its writer's file removed, no file left): the folders made for it go."""
    from cosim.record import writer

    def interrupted() -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_scene(load(scene), tmp_path / "a" / "b" / "x.mcap", progress=False, before_run=interrupted)
    assert not (tmp_path / "a").exists()

    def lost(self) -> None:
        self.discard()
        raise SinkError(f"{self.path}: the recording could not be written: the disk failed; no file was left")

    monkeypatch.setattr(writer.ProcessSink, "close", lost)
    with pytest.raises(SinkError):
        run_scene(load(scene), tmp_path / "c" / "d" / "x.mcap", progress=False)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["demo.yaml"]
    monkeypatch.undo()
    assert run_scene(load(scene), tmp_path / "e" / "f" / "x.mcap", progress=False).result.status == "ok"
    assert Recording(tmp_path / "e" / "f" / "x.mcap").status() is not None  # a recording kept keeps its folders


def test_a_run_onto_a_disk_with_no_inode_left_leaves_no_folder_it_made(scene, tmp_path, capsys):
    """The audit's case, on a real file system: a tmpfs of three inodes takes the two folders and not
    the private file. It said "no file was left" and left nd/sub."""
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m,nr_inodes=3", "tmpfs", str(disk)],
                             capture_output=True).returncode == 0
    if not mounted:
        pytest.skip("mounting a tmpfs is not allowed here")
    try:
        out = disk / "nd" / "sub" / "x.mcap"
        assert main(["run", str(scene), "-o", str(out), "-q"]) == 1
        assert one_error_line(capsys.readouterr().err).endswith("; no file was left")
        assert not any(disk.iterdir())
    finally:
        subprocess.run(["umount", str(disk)], check=False)
