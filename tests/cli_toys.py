"""What the command-line tests share: the smallest recorded scene (two toy components, one edge)
and the check that an error is one line, no traceback."""

from __future__ import annotations

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
