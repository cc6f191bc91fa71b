"""What the water coupler costs: a coupled step against the bare water step, and its share of the skip.

    python tools/bench_coupler.py                                # figures on stdout
    python tools/bench_coupler.py --write docs/performance.md    # also (re)write the coupler section

Two measures, each a ratio taken within one run (the machine is shared: absolute times move with
its load, ratios much less):

* **Coupled / bare step.** A floating ball (5 cm radius, 500 kg/m^3, half under water, pushed
  along at 0.3 m/s so its window moves) on an n x n pond of 1 cm columns, the water stepping every
  tick; one tick of the scheduler with the ball, the water and the coupler against one tick of the
  same pond alone (recording off). Batches of coupled and bare ticks alternate; the figure is the
  median over the rounds of (coupled batch / bare batch). The pond is the one
  ``tools/bench_water.py`` times (cell 0.01 m, depth 0.5 m, reflecting walls, every column stepped:
  ``tile: 0``; tiled, the bare pond at rest would not be stepped at all).
* **The coupler's share of the reference skip.** ``scenarios/skip.yaml`` with recording off, the
  wall time spent inside the coupler's steps (``WaterCoupler.step``, timed around each call) over
  the wall time of the whole run loop, median over the repeats.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from components.coupler.component import WaterCoupler  # noqa: E402
from cosim.component import Component  # noqa: E402
from cosim.docsection import replace_section  # noqa: E402
from cosim.scenario import load, loads  # noqa: E402
from cosim.scheduler import Simulation  # noqa: E402

SKIP = ROOT / "scenarios" / "skip.yaml"
CELL = 0.01  # [m] as tools/bench_water.py
DEPTH = 0.5  # [m] as tools/bench_water.py
DT = 0.001  # [s] c dt / s = 0.22 at c = sqrt(g d): the water steps every tick
TARGETS = {256: 1.5, 512: 1.2}  # coupled / bare step at most (issue 15, DESIGN.md section 5)
SHARE_TARGET = 0.30  # the coupler's share of the reference skip's loop at most

_POND = f"""
  pond:
    type: WaterSurface
    nx: {{n}}
    ny: {{n}}
    cell: {CELL}
    depth: {DEPTH}
    boundary: reflecting
    tile: 0
    origin_x: {{origin}}
    origin_y: {{origin}}
    field_rate: 0
"""

_BALL = """
  ball:
    type: RigidBody
    shape: sphere
    radius: 0.05
    density: 500
    position: [0.0, 0.0, 0.0]
    velocity: [0.3, 0.0, 0.0]
  coupler:
    type: WaterCoupler
    effects: [displacement, buoyancy, pressure, friction, wave_drag]
connections:
  - ball.state -> coupler.body
  - pond.patch -> coupler.water
  - {from: coupler.wrench, to: ball.wrench, delay: 1, initial: {force: [0, 0, 0], torque: [0, 0, 0]}}
  - {from: coupler.occupied, to: pond.occupied, delay: 1, initial: {i0: 0, j0: 0, b: []}}
  - {from: coupler.request, to: pond.request, delay: 1, initial: {x_min: 1, x_max: 0, y_min: 1, y_max: 0}}
"""


HOW = """How the coupler's step runs. Everything it computes over the columns and the body's surface
(the body's pose, the planing share, the forces of the named effects against the met surface, the
body under the rest level, the ring's map, deposit and lift, the hydrostatics, the stability bound)
is one compiled call, `components.coupler.step_kernel.ring_step`, into three work blocks the
component keeps (grid planes, numbers, work); the frozen surface the planing law reads is overlaid
and blended in one compiled pass (`met_surface._freeze`); Python reads the messages and builds the
four it publishes. The water takes a body's occupied height, and reads its patch, in one compiled
pass each (`components/water/windows.py`). Since the section was last written (4.13, 2.06 and 54%,
before the water was stepped by tiles):

- The ring's shares matrix (occupied columns x band columns, about 11,000 weights a step for the
  ball) is never formed. A column's share of a band column is a polynomial of degree 4 in the band
  column's direction, so the matrix is the product of a (columns x 15) and a (band x 15) factor, and
  the deposit and the lift go through 15 moments: work in columns + band, not columns x band (ring
  map, deposit and lift about 37 -> 15 us). The results move by round-off (deposit and lift within
  1e-14 of the matrix's on 300 random poses, the scenes' bodies within 1e-13; every pinned test
  passes unchanged).
- The forces' pass over the columns and the ring's pass under the rest level share one loop, each
  sub-column's chord through the body found once for both; the pose is computed inside the call,
  which passes three blocks instead of twenty arrays. Bit for bit.
- The benchmark's pond steps every column (`tile: 0`, as `tools/bench_water.py`): tiled, the bare
  pond at rest is not stepped at all and the ratio would say nothing.

Where the time still goes (py-spy, floating ball on 256 x 256): the water's own step about a quarter
of the tick; the compiled coupler step about a sixth, half of it the ball's surface elements (1200,
about 670 wet, each sampling the surface bilinearly: the pressure and friction the model asks for);
the coupler's Python around it about an eighth; the water's patch and the framework's checks of
every message (`Message.first_nonfinite` sums each array of each patch) about a fifth; the ball's
own step and the scheduler's exchange about a sixth. At 256 x 256 the target leaves half a bare
tick (about 50 us) for everything but the water's step, and the ball's step and the scheduler's
exchange alone take about that, outside the coupler's and the water's code; at 512 x 512 the 0.2
left (about 90 us) is less than the coupler's compiled step and the ball's step together."""


def pond_scene(n: int, coupled: bool) -> str:
    """YAML of an n x n pond centred on the origin, with the floating ball and its coupler or bare."""
    head = f"name: bench_coupler_{n}\ndt: {DT}\nuntil: 1000\non_unstable: substep\ncomponents:"
    pond = _POND.format(n=n, origin=-0.5 * (n - 1) * CELL)
    return head + pond + (_BALL if coupled else "")


def _ticks(sim: Simulation, count: int) -> float:
    start = time.perf_counter()
    for _ in range(count):
        sim.step()
    return time.perf_counter() - start


def step_ratio(n: int, *, rounds: int, batch: int) -> tuple[float, float, float]:
    """(median coupled / bare ratio, best coupled tick [s], best bare tick [s]) on an n x n pond."""
    coupled = Simulation(loads(pond_scene(n, True)))
    bare = Simulation(loads(pond_scene(n, False)))
    for sim in (coupled, bare):
        sim.initialize()
        _ticks(sim, 200)  # the ball settles into its first waves; kernels loaded and warm
    ratios, best_c, best_b = [], float("inf"), float("inf")
    for _ in range(rounds):
        t_c = _ticks(coupled, batch)
        t_b = _ticks(bare, batch)
        ratios.append(t_c / t_b)
        best_c, best_b = min(best_c, t_c / batch), min(best_b, t_b / batch)
    return statistics.median(ratios), best_c, best_b


class StepTimer:
    """Adds up the wall time of a component's steps [s] (wraps its ``step``)."""

    def __init__(self, comp: Component):
        self.seconds = 0.0
        inner = comp.step

        def step(*args, **kwargs):
            start = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - start

        comp.step = step  # type: ignore[method-assign]


def skip_share() -> tuple[float, float]:
    """(coupler's share of the loop, loop wall [s]) of one reference skip, recording off."""
    sim = Simulation(load(SKIP))
    timers = [StepTimer(c) for c in sim.components.values() if isinstance(c, WaterCoupler)]
    start = time.perf_counter()
    sim.run()
    wall = time.perf_counter() - start
    return sum(t.seconds for t in timers) / wall, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=15, help="alternating batches per grid")
    parser.add_argument("--batch", type=int, default=100, help="ticks per batch")
    parser.add_argument("--repeats", type=int, default=5, help="runs of the reference skip")
    parser.add_argument("--write", metavar="MARKDOWN", help="update the coupler section of this file")
    args = parser.parse_args()
    Simulation(load(SKIP, overrides=["until=0.05"])).run()  # kernels loaded from numba's cache
    load_before = os.getloadavg()[0]
    rows = []
    for n, target in TARGETS.items():
        ratio, t_c, t_b = step_ratio(n, rounds=args.rounds, batch=args.batch)
        verdict = "met" if ratio <= target else "not met"
        rows.append(f"| {n} x {n} | {t_b * 1e6:.0f} | {t_c * 1e6:.0f} | **{ratio:.2f}** | {target} | {verdict} |")
    shares = [skip_share() for _ in range(args.repeats)]
    share = statistics.median(s for s, _ in shares)
    wall = statistics.median(w for _, w in shares)
    load_after = os.getloadavg()[0]
    share_verdict = "met" if share <= SHARE_TARGET else "not met"
    text = "\n".join([
        "## The coupler",
        "",
        f"One run of `python tools/bench_coupler.py --write docs/performance.md` (load average "
        f"{load_before:.1f} before, {load_after:.1f} after; 2 cores shared with other jobs).",
        "",
        "A floating ball (5 cm, half under water, drifting at 0.3 m/s) on an n x n pond of 1 cm "
        "columns, the water stepping every tick, recording off; a tick of ball + water + coupler "
        f"against a tick of the bare pond, {args.rounds} alternating batches of {args.batch} ticks "
        "(the ratio is the median of the batches' ratios, the times the best batch):",
        "",
        "| pond | bare water tick [us] | coupled tick [us] | coupled / bare (median) | target | |",
        "|---|---:|---:|---:|---:|---|",
        *rows,
        "",
        f"The reference skip (`scenarios/skip.yaml`, recording off), {args.repeats} runs: the coupler's "
        f"steps take **{share:.0%}** of the run loop (median; target at most {SHARE_TARGET:.0%}: "
        f"{share_verdict}), the loop {wall:.2f} s.",
        "",
        HOW,
    ])
    print(text)
    if args.write:
        replace_section(args.write, "coupler", text)


if __name__ == "__main__":
    main()
