"""A sweep's own points run one at a time, for tests that hold the throws a sweep file describes."""

from __future__ import annotations

from pathlib import Path

from cosim.scenario import loads
from cosim.scheduler import Simulation
from cosim.sweep.plan import load_sweep


def skips_at(sweep_file: Path, **values: float) -> int:
    """Skips of the point of ``sweep_file`` whose axis values are ``values``, run as the sweep runs it."""
    sweep = load_sweep(sweep_file)
    point = next(p for p in sweep.points if p.values == values)
    sim = Simulation(loads(sweep.scene_text, source=sweep.scene_source, overrides=[*sweep.fixed, *point.overrides]))
    sim.run()
    return sim.components["stages"].track.skips
