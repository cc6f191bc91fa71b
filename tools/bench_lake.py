"""The held skip's throw on a lake against the same throw on its own pond, and a lake's memory.

Runs ``scenarios/held_skip.yaml`` (recording off) on its 8 m x 1 m pond and on a 40 m x 6 m lake of the
same 1 cm columns (the stone over open water: 5 m of lake behind it, 3 m either side), in turn, for
several rounds in one process, and reports the wall time of the run loop of each (``RunResult.wall_s``,
compilation excluded), the ratio lake / pond as the median of each round's own ratio and best against
best, and the share of the water that was active. Then, in a fresh process each, the same throw on a
100 m x 10 m lake (10^7 columns): its peak resident memory (``ru_maxrss``) and the estimate that a
scene is checked against when it loads (``WaterSurface.estimate_bytes``).

    python tools/bench_lake.py [--rounds 7] [--write docs/performance.md]

The machine these figures come from is shared, so only ratios taken within one run mean much.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cosim.docsection import replace_section  # noqa: E402
from cosim.runner import run_scene  # noqa: E402
from cosim.scenario import load  # noqa: E402
from tools.options import check_output, command_line, description, machine, positive_int  # noqa: E402

SCENE = ROOT / "scenarios" / "held_skip.yaml"
POND: list[str] = []  # the scene as it is: 800 x 100 cells
LAKE = ["components.pond.nx=4000", "components.pond.ny=600", "components.pond.origin_x=-5",
        "components.pond.origin_y=-2.5", "components.pond.field_window=[8, 3]"]
BIG_LAKE = ["components.pond.nx=10000", "components.pond.ny=1000", "components.pond.origin_x=-10",
            "components.pond.origin_y=-4.5", "components.pond.field_window=[8, 3]"]


HOW = """\
How. The wave model is stepped by tiles of 32 x 32 columns (`components.water.tiles`): a tile whose
columns are all exactly at rest (h = 0 and v = 0), with its four neighbours at rest, is not stepped,
because the explicit step maps such water to exactly zero; a tile wakes when a neighbour moves or a
body displaces water in it. The explicit step carries a vanishing precursor ahead of every
wavefront, one column per water step, and a stepped tile whose every column moves by no more than
1e-30 m (|h|, and |v| in m/s; `rest_below`) is set to zeros and rests too: eleven orders of
magnitude below the round-off of a millimetre wave, and a whole tile at that height holds 1e-31 m^3,
beneath the round-off of the lake's volume. Every column stays the dense step's to round-off, and
the throw's stone the dense throw's bit for bit (`tests/test_water_tiles.py`; with `rest_below: 0`
the water too is the dense step's bit for bit), so the figures above are for the same physics. `shallow_water` (its
implicit sweeps reach a whole row in one step), `airy`, smoothing, a sloped bed whose waves run at
its depth's speed or that dries, and the numpy or parallel kernels keep the dense path (a sloped
bed under one set `wave_speed` or `wave_length` is uniform, and tiled). Memory: on a flat bed the
bed, depths, face coefficients and masks are one value seen at every column, and the height and
velocity arrays are zeros whose pages the system maps only when a wave first writes them, so the
far water of a lake takes no memory; volume and energy are summed over the moving tiles.
`WaterSurface.estimate_bytes` counts 8 arrays per column on a flat bed (the bound if every column
moved), 16 otherwise.

What the lake costs beyond the pond. The pond's absorbing edges are 0.5 m either side of the throw;
the lake keeps every wave the stone leaves. Its water runs them at the speed of the stone's ripples
(0.40 m/s, `wave_length`: docs/accuracy.md), so they stay within about a metre of the throw, and
the precursor ahead of them rests: at t = 2 s on the 40 m x 6 m lake, of its 2250 whole 32 x 32
tiles 532 held a non-zero column, but only 179, 147, 135 and 120 a column moving by more than
1e-30 m, 1e-15 m, 1 nm and 1 um (|h|, or |v| x 50 ms). Stepped with exact rest, the moving water
covered a seventh of the lake on average and lake / pond was 2.30 (2.20 to 2.44 over five rounds,
this round's code before `rest_below`); with the long waves' speed sqrt(g d) = 2.2 m/s, the scenes'
water before, the waves themselves spread over the lake (841 tiles held a non-zero column, and 682,
655, 633 and 627 those), a fifth of it moved on average and lake / pond was 2.40 the round before.
A moving column also costs the lake more: timed
in the run, the tiled step takes 0.8 ns per stepped column and step on the pond, whose four arrays
(2.6 MB) stay in the caches, and 2.6 ns on the lake, whose moving water (15 to 40 MB of its 77 MB
of arrays) streams from memory. The lake's absorbing edges (92 m of them, each row of the side
edges on a page of its own) visit only the tiles that moved and those around them, and the bottom
and top edges go by runs of columns, not by masks: 53 to 64 ms over the throw in a fresh process,
against 101 to 160 ms when every edge cell was visited at every step (most of a lake's edge is at
rest, where the condition gives zeros again). Masks were tried first and cost more than they saved:
a vectorised loop whose masks are off, over edge pages the lake has never written, took 1.2 ms a
call against 12 us once the pages are mapped. An earlier round the row
kernel came to vectorise in the tiled spans (see "Water paths"): on this machine, run in turn with
the code before it, the tiled step went from 4.2-5.4 to 0.8 ns a column on the pond and from 8.9 to
2.6 ns on the lake, and lake / pond from 5.4-6.2 (loops of 6.2 s and 1.0-1.2 s) to 3.7. Stepping
the moving water in place (one pair of arrays, a saved row for the stencil) would halve its
footprint; tried here on a 600 x 4000 grid, it took as long as the two-buffer step (2.2 ns a column
either way, dense), so the step is not held by the bytes alone.

`scenarios/lake.yaml` (50 m x 6 m, 3 million columns, the slate at 18 m/s, its attitude held): 11
skips over 37.0 m, on its line; the moving water covers 21% of the lake's tiles on average over
its 4.7 s, and the viewer's surface is an 8 m x 3 m window that follows the stone
(`field_window`), not the whole lake."""


def timed(overrides: list[str]) -> tuple[float, float, float, list[str]]:
    """(loop wall [s], peak and mean active fraction of the water, summary) of one run, recording off."""
    outcome = run_scene(load(SCENE, overrides=overrides), None, progress=False)
    pond = outcome.simulation.components["pond"]
    tiles = pond.tiles
    peak, mean = (tiles.peak_fraction(), tiles.mean_fraction()) if tiles is not None else (1.0, 1.0)
    return outcome.result.wall_s - outcome.result.compile_s, peak, mean, outcome.summary


def memory_child(overrides: list[str]) -> None:
    """In a fresh process: run the throw, print its peak RSS, estimate and skip count as JSON."""
    import resource

    scene = load(SCENE, overrides=overrides)
    estimate = scene.components["pond"].cls.estimate_bytes(scene.components["pond"].params)
    outcome = run_scene(scene, None, progress=False)
    skips = next((line for line in outcome.summary if line.startswith("skips:")), "")
    rss_kib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    print(json.dumps({"rss": rss_kib * 1024, "estimate": estimate, "skips": skips,
                      "wall": outcome.result.wall_s}))


def measure_memory(overrides: list[str]) -> dict:
    out = subprocess.run([sys.executable, __file__, "--memory-child", json.dumps(overrides)],
                         check=True, capture_output=True, text=True, cwd=ROOT)
    return json.loads(out.stdout.strip().splitlines()[-1])


def skips_line(summary: list[str]) -> str:
    return next((line for line in summary if line.startswith("skips:")), "")


def report(rounds: int, command: str) -> str:
    timed(["until=0.05"]), timed(["until=0.05", *LAKE])  # kernels compiled or loaded from their cache
    load_before = os.getloadavg()[0]
    pond_s, lake_s, ratios = [], [], []
    lake_peak = lake_mean = pond_peak = pond_mean = 0.0
    summaries: dict[str, list[str]] = {}
    for _ in range(rounds):
        p, pond_peak, pond_mean, summaries["pond"] = timed(POND)
        q, lake_peak, lake_mean, summaries["lake"] = timed(LAKE)
        pond_s.append(p)
        lake_s.append(q)
        ratios.append(q / p)
        print(f"pond {p:.3f} s, lake {q:.3f} s: {q / p:.2f}", file=sys.stderr)
    ratio = statistics.median(ratios)
    best = min(lake_s) / min(pond_s)
    pond_throw = skips_line(summaries["pond"]).removeprefix("skips: ")
    lake_throw = skips_line(summaries["lake"]).removeprefix("skips: ")
    throw = (f"The throw is the same on both (skips: {lake_throw})." if pond_throw == lake_throw else
             f"The throw differs between the two: on the pond skips: {pond_throw}; on the lake skips: {lake_throw}.")
    small = measure_memory(POND)
    dense = measure_memory([*BIG_LAKE, "components.pond.tile=0", "until=0.01"])
    big = measure_memory(BIG_LAKE)
    load_after = os.getloadavg()[0]
    mb = 1e6
    lines = [
        "## The lake",
        "",
        f"One run of `{command}` ({machine(load_before, load_after)}).",
        "",
        "The held skip's throw (`scenarios/held_skip.yaml`, recording off) on its own 8 m x 1 m pond and on a "
        "40 m x 6 m lake of the same 1 cm columns (2.4 million, 30 times the pond), in turn, "
        f"{rounds} rounds; wall time of the run loop:",
        "",
        "| water | columns | best loop [s] | median loop [s] | active water, peak | active water, mean |",
        "|---|---:|---:|---:|---:|---:|",
        f"| pond 8 m x 1 m | 80,000 | {min(pond_s):.3f} | {statistics.median(pond_s):.3f} | "
        f"{100 * pond_peak:.0f}% | {100 * pond_mean:.0f}% |",
        f"| lake 40 m x 6 m | 2,400,000 | {min(lake_s):.3f} | {statistics.median(lake_s):.3f} | "
        f"{100 * lake_peak:.1f}% | {100 * lake_mean:.1f}% |",
        "",
        f"Lake / pond: **{ratio:.2f}** (median of the rounds' own ratios; {best:.2f} best against best; "
        f"rounds from {min(ratios):.2f} to {max(ratios):.2f}); target at most 1.5: "
        f"{'met' if ratio <= 1.5 else 'not met'}. {throw}",
        "",
        f"Columns stepped per water step, on average: pond {pond_mean * 80_000:,.0f}, lake "
        f"{lake_mean * 2_400_000:,.0f} ({lake_mean * 30 / pond_mean:.1f} times as many).",
        "",
        "The same throw on a 100 m x 10 m lake (10^7 columns), each in a fresh process (the estimate "
        "counts the water's arrays; the process itself, Python with numpy, numba and the kernels, "
        "comes on top: the pond's row shows it):",
        "",
        "| run | peak resident memory [MB] | estimate checked at load [MB] |",
        "|---|---:|---:|",
        f"| the pond (800 x 100), the whole throw | {small['rss'] / mb:.0f} | {small['estimate'] / mb:.0f} |",
        f"| 100 m x 10 m lake, tiled (the default), the whole throw | {big['rss'] / mb:.0f} | "
        f"{big['estimate'] / mb:.0f} |",
        f"| 100 m x 10 m lake, dense (`tile: 0`), its first 10 ms | {dense['rss'] / mb:.0f} | "
        f"{dense['estimate'] / mb:.0f} |",
        "",
        f"Target under 1 GB: {'met' if big['rss'] < 1e9 else 'not met'} ({big['skips']}).",
        "",
        HOW,
    ]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--rounds", type=positive_int, default=7,
                        help="rounds of pond and lake in turn (default %(default)s)")
    parser.add_argument("--write", metavar="MARKDOWN", help="put the table into this file's lake section")
    parser.add_argument("--memory-child", metavar="OVERRIDES", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    check_output(parser, args.write, "--write", text=True, sections=("lake",))
    if args.memory_child is not None:
        memory_child(json.loads(args.memory_child))
        return 0
    text = report(args.rounds, command_line("bench_lake.py", argv))
    print(text)
    if args.write:
        replace_section(args.write, "lake", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
