"""What the water coupler costs: a coupled step against the bare water step, and its share of the skip.

    python tools/bench_coupler.py                                # figures on stdout
    python tools/bench_coupler.py --write docs/performance.md    # also (re)write the coupler section

Two measures, each a ratio taken within one run (the machine is shared: absolute times move with
its load, ratios much less):

* **Coupled / bare step.** A floating ball (5 cm radius, 500 kg/m^3, half under water, launched
  along x at 0.3 m/s so its window moves; the water slows it, and the section says its speed as the
  timed ticks begin and end) on an n x n pond of 1 cm columns, the water stepping every tick; one
  tick of the scheduler with the ball, the water and the coupler against one tick of the same pond
  alone (recording off). Batches of coupled and bare ticks alternate; the figure is the
  median over the rounds of (coupled batch / bare batch). The pond is the one
  ``tools/bench_water.py`` times (cell 0.01 m, depth 0.5 m, reflecting walls, every column stepped:
  ``tile: 0``; tiled, the bare pond at rest would not be stepped at all).
* **The coupler's share of the held skip.** ``scenarios/held_skip.yaml`` (the scene the target was set
  on) with recording off, the
  wall time spent inside the coupler's steps (``WaterCoupler.step_gathered``, timed around each call) over
  the wall time of the whole run loop, median over the repeats.
"""

from __future__ import annotations

import argparse
import math
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
from tools.options import check_output, command_line, description, machine, positive_int  # noqa: E402

SKIP = ROOT / "scenarios" / "held_skip.yaml"
CELL = 0.01  # [m] as tools/bench_water.py
DEPTH = 0.5  # [m] as tools/bench_water.py
DT = 0.001  # [s] c dt / s = 0.22 at c = sqrt(g d): the water steps every tick
TARGETS = {256: 1.5, 512: 1.2}  # coupled / bare step at most (issue 15, DESIGN.md section 5)
SHARE_TARGET = 0.30  # the coupler's share of the held skip's loop at most

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
component keeps (grid planes, numbers, work). The usual step (`WaterCoupler._ring_advance`) calls it
through `step_kernel.met_ring_step`, which first makes the surface the planing law reads (the
frozen window overlaid on the live patch and blended, `met_surface._freeze`) in the same call; it
fills a body vector it keeps, reads the call's numbers back once, as Python floats, and builds the
four messages, their force arrays views of one copy of the stats. The water takes a body's occupied
height, and reads its patch, in one compiled pass each (`components/water/windows.py`).

- The ring's shares matrix (occupied columns x band columns) is never formed: a column's share of
  a band column is a polynomial of degree 4 in the band column's direction, so the deposit and the
  lift go through 15 moments, work in columns + band, not columns x band.
- The forces' pass over the columns and the ring's pass under the rest level share one loop, each
  sub-column's chord through the body found once for both.
- The work planes span the whole patch (about 23 x 71 columns for the skip, its window reaching
  60 ms ahead), the body a few of its columns: each step clears only the columns the last one
  wrote, the ring's map scans only the body's columns, and the rest pass's flat plane is not
  scanned for its highest point. The met surface's freeze copies each row in runs with unsigned
  indices, so it vectorises (7.9 to 2.6 us a call, most of that the call itself). Bit for bit.
- The benchmark's pond steps every column (`tile: 0`, as `tools/bench_water.py`): tiled, the bare
  pond at rest is not stepped at all and the ratio would say nothing.

Where the time goes. On the machine as it was two rounds ago, the coupler's step on the held skip
took about 90 us, of which the compiled call was about 40 us (on the slower machine of the last two
rounds, 155 us and 64 us); the rest is
Python: reading the four inputs, the met surface's bookkeeping, the request, building four messages, and
the framework's checks of each (`Message.first_nonfinite`, now one generated expression per message
type; the checks of all outputs still take about 9% of the skip's loop in a sampling profile,
`py-spy record` over six runs). The water, meanwhile, got 5x cheaper on
the skip (its tiled row kernel now vectorises, see "Water paths"), so the bare water step the
targets divide by shrank: the coupler's share of the skip's loop rose from about 40% to 57% and
the coupled / bare ratios grew, while every run got faster (the skip's loop 1.06 s to 0.70 s in
the same runs). At 256 x 256 a bare tick then took about 45 us, less than the ball's compiled
coupler call alone (about 75 us: 1200 surface elements, about 670 of them wet, each sampling the
surface), so the 1.5 target would need that arithmetic itself to shrink, besides the Python around it.

Where the compiled call's time goes, and what the last round took from it (890 calls' arguments
captured from the two scenes and replayed, each change checked bit for bit on every output array;
best of several runs on the shared machine):

| part of the call | the ball [us] before | after |
|---|---:|---:|
| the column passes (live and under the rest level) | 17.2 | 12.0 |
| the surface elements (pressure and friction) | 27.2 | 26.8 |
| the ring (map, deposit, lift) | 15.7 | 15.5 |
| the met surface's freeze and the surface's figures | about 2.5 | about 2.5 |
| the whole call, the ball | 64.6 | 59.1 |
| the whole call, the held skip (mean of 631) | 43.3 | 33.1 |

The sub-columns' offsets are found once per call, not by a division per sub-column (a third of the
column pass); a disk face's 16 pieces are wetted in one loop with their box shape found once, and
their shares kept for the load's spread instead of worked out twice (the held skip's planing:
20.0 to 9.0 us at the median step); the sampling's indices are unsigned (no wrap-around selects); a
division-free bound leaves the columns surely inside or beyond the ring before its exact test. The
element pass is now about 23 ns an element, 40 ns a sampled one: the arithmetic itself (no sqrt,
trig or power left to hoist). What is left outside the call is Python, about 30 us a step: reading
four inputs, the request, building four messages and their checks, each item 1 to 3 us.

Building the messages. A frozen dataclass's own `__init__` stores each field through
`object.__setattr__`; `cosim.messages.message` now generates an `__init__` that writes the
instance's dict (the instances stay frozen). The body's 14-field state takes 0.72 us to build
instead of 2.52 us, the coupler's contact report 0.60 instead of 1.86 (best of 21 batches, warm).
Over the held skip's messages (4,302 body states, 4,301 contact reports, 3,524 wrenches, 3,090
occupied heights, 1,061 patches) that is about 17 ms of a loop of about 1.1 s on the machine of
these runs: 1.5%, inside the noise of whole runs there (the two versions run in turn, eight pairs,
differed by -28% to +40% pair by pair), so the figures above stand."""


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


def ball_speed(sim: Simulation) -> float:
    """The floating ball's speed [m/s]."""
    return math.hypot(*sim.components["ball"].get_state()["velocity"])


def step_ratio(n: int, *, rounds: int, batch: int) -> tuple[float, float, float, tuple[float, float]]:
    """(median coupled / bare ratio, best coupled tick [s], best bare tick [s], the ball's speed [m/s]
    as the timed ticks begin and as they end) on an n x n pond."""
    coupled = Simulation(loads(pond_scene(n, True)))
    bare = Simulation(loads(pond_scene(n, False)))
    for sim in (coupled, bare):
        sim.initialize()
        _ticks(sim, 200)  # the ball settles into its first waves; kernels loaded and warm
    first = ball_speed(coupled)
    ratios, best_c, best_b = [], float("inf"), float("inf")
    for _ in range(rounds):
        t_c = _ticks(coupled, batch)
        t_b = _ticks(bare, batch)
        ratios.append(t_c / t_b)
        best_c, best_b = min(best_c, t_c / batch), min(best_b, t_b / batch)
    return statistics.median(ratios), best_c, best_b, (first, ball_speed(coupled))


class StepTimer:
    """Adds up the wall time of a component's steps [s] (wraps its ``step_gathered``, the scheduler's
    call)."""

    def __init__(self, comp: Component):
        self.seconds = 0.0
        inner = comp.step_gathered

        def step(*args, **kwargs):
            start = time.perf_counter()
            try:
                return inner(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - start

        comp.step_gathered = step  # type: ignore[method-assign]


def skip_share() -> tuple[float, float]:
    """(coupler's share of the loop, loop wall [s]) of one held skip, recording off."""
    sim = Simulation(load(SKIP))
    timers = [StepTimer(c) for c in sim.components.values() if isinstance(c, WaterCoupler)]
    start = time.perf_counter()
    sim.run()
    wall = time.perf_counter() - start
    return sum(t.seconds for t in timers) / wall, wall


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--rounds", type=positive_int, default=15,
                        help="alternating batches per grid (default %(default)s)")
    parser.add_argument("--batch", type=positive_int, default=100, help="ticks per batch (default %(default)s)")
    parser.add_argument("--repeats", type=positive_int, default=5, help="runs of the held skip (default %(default)s)")
    parser.add_argument("--write", metavar="MARKDOWN", help="update the coupler section of this file")
    args = parser.parse_args(argv)
    check_output(parser, args.write, "--write", text=True, sections=("coupler",))
    Simulation(load(SKIP, overrides=["until=0.05"])).run()  # kernels loaded from numba's cache
    load_before = os.getloadavg()[0]
    rows, speeds = [], []
    for n, target in TARGETS.items():
        ratio, t_c, t_b, (first, last) = step_ratio(n, rounds=args.rounds, batch=args.batch)
        verdict = "met" if ratio <= target else "not met"
        rows.append(f"| {n} x {n} | {t_b * 1e6:.0f} | {t_c * 1e6:.0f} | **{ratio:.2f}** | {target} | {verdict} |")
        speeds.append(f"{first:.2f} to {last:.2f} m/s on the {n} x {n} pond")
    shares = [skip_share() for _ in range(args.repeats)]
    share = statistics.median(s for s, _ in shares)
    wall = statistics.median(w for _, w in shares)
    load_after = os.getloadavg()[0]
    share_verdict = "met" if share <= SHARE_TARGET else "not met"
    text = "\n".join([
        "## The coupler",
        "",
        f"One run of `{command_line('bench_coupler.py', argv)}` ({machine(load_before, load_after)}).",
        "",
        "A floating ball (5 cm, half under water, launched along x at 0.3 m/s and slowed by the water: "
        f"{' and '.join(speeds)} over the timed ticks) on an n x n pond of 1 cm "
        "columns, the water stepping every tick, recording off; a tick of ball + water + coupler "
        f"against a tick of the bare pond, {args.rounds} alternating batches of {args.batch} ticks "
        "(the ratio is the median of the batches' ratios, the times the best batch):",
        "",
        "| pond | bare water tick [us] | coupled tick [us] | coupled / bare (median) | target | |",
        "|---|---:|---:|---:|---:|---|",
        *rows,
        "",
        f"The held skip (`scenarios/held_skip.yaml`, recording off), {args.repeats} "
        f"run{'s' if args.repeats != 1 else ''}: the coupler's "
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
