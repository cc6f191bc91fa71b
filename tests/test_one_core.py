"""A run keeps to its one thread: nothing the simulation calls leaves a thread of its own busy
beside it (a BLAS library's workers spin for a while after each call they take part in, a whole
core taken from the recording's writer or from another job)."""

from __future__ import annotations

import time
from pathlib import Path

from cosim.runner import run_scene
from cosim.scenario import load
from cosim.scheduler import Simulation

ROOT = Path(__file__).resolve().parents[1]
HELD_SKIP = ROOT / "scenarios" / "held_skip.yaml"


def _cpu_and_wall(run) -> tuple[float, float]:
    time.sleep(0.3)  # a worker an earlier test left spinning (a parallel kernel's) has stopped by then
    wall, cpu = time.perf_counter(), time.process_time()
    run()
    return time.process_time() - cpu, time.perf_counter() - wall


def test_the_held_skip_takes_no_more_cpu_than_wall_time():
    """Its first 0.6 s (two skips, the pond's whole field published and checked six times): the
    process's CPU time stays within its wall time (a spinning worker would add most of a core)."""
    sim = Simulation(load(HELD_SKIP, ["until=0.6"]))
    cpu, wall = _cpu_and_wall(sim.run)
    assert cpu <= 1.1 * wall + 0.05, f"CPU {cpu:.2f} s over a wall time of {wall:.2f} s"


def test_recording_it_takes_no_more_cpu_than_wall_time_in_this_process(tmp_path):
    """The same, recorded as the scene says (every exchange, the viewer's frames, a checkpoint): the
    packing, the viewer's meshes and the checkpoints run on this thread too (the writer is a process
    of its own, whose CPU is not counted here)."""
    scene = load(HELD_SKIP, ["until=0.6"])
    cpu, wall = _cpu_and_wall(lambda: run_scene(scene, tmp_path / "held.mcap", progress=False))
    assert (tmp_path / "held.mcap").stat().st_size > 0
    assert cpu <= 1.1 * wall + 0.05, f"CPU {cpu:.2f} s over a wall time of {wall:.2f} s"
