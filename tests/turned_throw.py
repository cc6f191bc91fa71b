"""The held skip thrown along +y instead of +x, on its pond turned to match: the same throw, which
the summaries and figures must tell as they tell the one along x (tests/test_plot.py,
tests/test_stages.py)."""

from __future__ import annotations

from pathlib import Path

HELD_SKIP = Path(__file__).resolve().parents[1] / "scenarios" / "held_skip.yaml"
ALONG_Y = ("components.pond.nx=100", "components.pond.ny=800", "components.stone.position=[0.5, 0.3, 0.15]",
           "components.stone.velocity=[0, 7.88, -1.39]", "components.stone.tilt_axis=[1, 0, 0]")
