"""Damaged recordings are one line and exit 2 from every command that reads them (inspect, replay,
plot, render): every CRC is checked, so a flipped byte is an error and never a wrong value. A run
killed with SIGKILL leaves a valid recording without a status, which inspect calls incomplete."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.errors import RecordingError
from cosim.record.reader import Recording
from cosim.replay import replay_component
from cosim.runner import run_scene
from cosim.scenario import loads

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
