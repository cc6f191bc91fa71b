"""A run keeps to its one thread: nothing the simulation calls leaves a thread of its own busy
beside it (a BLAS library's workers spin for a while after each call they take part in, a whole
core taken from the recording's writer or from another job)."""

from __future__ import annotations

import time
from pathlib import Path

from cosim.scenario import load
from cosim.scheduler import Simulation

ROOT = Path(__file__).resolve().parents[1]


def test_the_held_skip_takes_no_more_cpu_than_wall_time():
    """Its first 0.6 s (two skips, the pond's whole field published and checked six times): the
    process's CPU time stays within its wall time (a spinning worker would add most of a core)."""
    sim = Simulation(load(ROOT / "scenarios" / "held_skip.yaml", ["until=0.6"]))
    time.sleep(0.3)  # a worker an earlier test left spinning (a parallel kernel's) has stopped by then
    wall, cpu = time.perf_counter(), time.process_time()
    sim.run()
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    assert cpu <= 1.1 * wall + 0.05, f"CPU {cpu:.2f} s over a wall time of {wall:.2f} s"
