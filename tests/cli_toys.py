"""What the command-line tests share: the smallest recorded scene (two toy components, one edge)
and the check that an error is one line, no traceback."""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest

DEMO_SCENE = """
name: demo
dt: 0.001
until: 0.05
components:
  src: {type: "tests.toys:Source"}
  g: {type: "tests.toys:Gain"}
connections:
  - src.out -> g.x
"""
CHECKPOINTED_SCENE = DEMO_SCENE + "record: {checkpoint_every: 0.01}\n"  # the same, with checkpoints to restart from


@pytest.fixture
def scene(tmp_path: Path) -> Path:
    """The demo scene written to ``demo.yaml`` in the test's folder."""
    path = tmp_path / "demo.yaml"
    path.write_text(DEMO_SCENE)
    return path


def one_error_line(err: str) -> str:
    """The single ``error: ...`` line of a command's stderr (asserting there is only that line)."""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "Traceback" not in err
    return lines[0]


@contextlib.contextmanager
def small_disk(folder: Path, size: str = "2m") -> Iterator[Path]:
    """``folder`` made a file system of its own, a tmpfs of ``size`` (unmounted after), to be filled
    with :func:`fill_leaving`: a real full disk (the test is skipped where mounting is not allowed)."""
    folder.mkdir(exist_ok=True)
    mounted = shutil.which("mount") is not None and subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)], capture_output=True).returncode == 0
    if not mounted:
        pytest.skip("mounting a tmpfs is not allowed here")
    try:
        yield folder
    finally:
        subprocess.run(["umount", str(folder)], check=False)


def fill_leaving(folder: Path, free: int) -> None:
    """Fill the file system of ``folder`` until ``free`` bytes are left (a file named ``fill``)."""
    room = os.statvfs(folder)
    (folder / "fill").write_bytes(bytes(max(0, room.f_bavail * room.f_frsize - free)))
