"""Water step throughput against the throughput of copying the same arrays, measured in one run.

    python tools/bench_water.py                      # table on stdout
    python tools/bench_water.py --markdown docs/performance.md   # also (re)write that section

For each grid size and model, the script times ``WaterSurface.step`` (the whole component step the
scheduler calls: model, boundary, an empty patch; no field) and, interleaved with it, copying the
state arrays h and v into two other arrays of the same shape (``np.copyto``). Throughput is cells
per second; the ratio step / copy is what the design target is about (DESIGN.md section 5: at least
50% of the copy for every path; judged here on the `wave` step at 512 x 512, the other paths in
tools/bench_water_paths.py). The rounds alternate a short batch of copies and a short batch of
steps; the ratio reported is the median over rounds of copy time / step time within the round (adjacent
batches see the same machine load, so the ratio survives a shared, noisy machine), the absolute
figures are the best batch of each. Compiled kernels are warmed up first.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from components.water import WaterParams, WaterSurface  # noqa: E402
from components.water.boundaries import BOUNDARIES  # noqa: E402
from components.water.kernels_numba import PARALLEL_MIN_CELLS  # noqa: E402
from components.water.models import MODELS  # noqa: E402
from cosim.docsection import replace_section  # noqa: E402
from cosim.record.output import written_whole  # noqa: E402
from tools.options import check_output, command_line, description, positive_float, positive_int  # noqa: E402

COPY_TARGET = 0.50  # the step at least this share of the copy's throughput (DESIGN.md section 5)

SECTION = "## Water step throughput"
NAME = "water-throughput"  # the section's markers (cosim.docsection)
BEGIN = f"<!-- {NAME}:begin -->"
END = f"<!-- {NAME}:end -->"
NS = 1_000_000_000


@dataclass
class Row:
    n: int
    model: str
    boundary: str
    backend: str
    step_s: float
    copy_s: float
    ratio: float

    @property
    def cells(self) -> int:
        return self.n * self.n


def _per_call(fn: Callable[[], None], reps: int) -> float:
    t0 = time.perf_counter()
    for _ in range(reps):
        fn()
    return (time.perf_counter() - t0) / reps


KERNEL_SETS = {"numba": dict(backend="numba"), "numba-parallel": dict(backend="numba", parallel=True),
               "numpy": dict(backend="numpy")}


def measure(n: int, model: str, boundary: str, backend: str, *, rounds: int, min_time: float) -> Row:
    """Best seconds per step and per copy of an n x n grid (interleaved rounds)."""
    params = WaterParams(nx=n, ny=n, cell=0.01, depth=0.5, model=model, boundary=boundary, tile=0,
                         **KERNEL_SETS[backend])  # the dense kernels (tiles: the lake's benchmark)
    pond = WaterSurface("pond", params)
    dt = 0.5 * min(pond.max_stable_step(), 0.01 / np.sqrt(9.81 * 0.5))
    dt_ns = round(dt * NS)
    rng = np.random.default_rng(0)
    pond.set_state({**pond.get_state(), "h": 1e-3 * rng.standard_normal((n, n))})
    inputs: dict = {"occupied": None, "request": None}
    tick = [0]

    def step() -> None:
        pond.step(tick[0] * dt_ns, dt_ns, inputs)
        tick[0] += 1

    h2, v2 = np.empty((n, n)), np.empty((n, n))

    def copy() -> None:
        np.copyto(h2, pond._h)
        np.copyto(v2, pond._v)

    for _ in range(3):  # warm up: compile (or load) kernels, touch the buffers
        step()
        copy()
    reps_step = max(1, int(min_time / max(_per_call(step, 1), 1e-7)))
    reps_copy = max(1, int(min_time / max(_per_call(copy, 1), 1e-7)))
    copies, steps = [], []
    for _ in range(rounds):
        copies.append(_per_call(copy, reps_copy))
        steps.append(_per_call(step, reps_step))
    ratio = float(np.median(np.array(copies) / np.array(steps)))
    return Row(n, model, boundary, backend, min(steps), min(copies), ratio)


def table(rows: list[Row]) -> list[str]:
    lines = ["| grid | model | boundary | kernels | step [us] | step [Mcells/s] | copy h, v [Mcells/s] "
             "| step / copy (median) |",
             "|---|---|---|---|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r.n} x {r.n} | {r.model} | {r.boundary} | {r.backend} | {r.step_s * 1e6:.0f} "
                     f"| {r.cells / r.step_s / 1e6:.0f} | {r.cells / r.copy_s / 1e6:.0f} | {r.ratio:.0%} |")
    return lines


def markdown(rows: list[Row], command: str, load: tuple[float, float]) -> str:
    import numba

    target = [r for r in rows if r.n == 512 and r.model == "wave" and r.boundary == "reflecting"
              and r.backend == "numba"]  # the default kernels
    verdict = ""
    if target:
        ok = "meets" if target[0].ratio >= COPY_TARGET else "misses"
        verdict = (f"The `wave` step at 512 x 512 runs at {target[0].ratio:.0%} of the copy throughput: it "
                   f"{ok} the design target (>= {COPY_TARGET:.0%}; the other paths: \"Water paths\").\n\n")
    return "\n".join([
        SECTION,
        "",
        "Throughput of one `WaterSurface.step` (model, boundary, an empty patch; no field published) "
        "beside the throughput of copying the same two arrays h and v (`np.copyto`), measured in the "
        "same run: short batches of copies and of steps alternate, the ratio is the median over the "
        "rounds of (copy time / step time) within a round, the absolute figures the best batch of "
        "each. Cells per second = nx * ny / (seconds per step). The ratio is the figure to compare; "
        "absolute numbers vary with the machine and its load.",
        "",
        *table(rows),
        "",
        verdict + "How: the `wave` kernel is one fused pass over memory (read h and v once, write the new "
        "h and v into spare buffers that then swap), compiled with numba on one thread (`numba`, the "
        "default): it moves the same bytes as the copy. `numba-parallel` (parameter `parallel: true`) "
        f"splits the rows of grids of {PARALLEL_MIN_CELLS} cells or more across the cores: on an idle "
        "machine it is the fastest, but a step waits for its slowest thread, so while other jobs share "
        "the cores a step can stall for a whole scheduler time slice and its rows scatter (that is why "
        "it is opt-in). `shallow_water` does two tridiagonal sweeps (rows, then columns), "
        "each a dependent recurrence, so it runs at a fraction of the copy. The `numpy` rows are the "
        "reference kernels (numpy expressions over whole arrays).",
        "",
        f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}, numpy {np.__version__}, numba {numba.__version__}; "
        f"load average {load[0]:.1f} at the start, {load[1]:.1f} at the end (other jobs were running).",
        "",
        f"Reproduce: `{command}`",
        "",
    ])


def write_section(path: Path, text: str) -> None:
    """Put the water section into a markdown file, leaving everything else in it byte for byte.

    The section sits between ``BEGIN`` and ``END`` marker comments: a marked section is replaced, an
    unmarked one (from its heading to the next heading or marker comment) is replaced and marked, and
    a file without it gets it appended.

    The page is written whole under a temporary name and moved onto it (``cosim.docsection.replace_section``,
    as every tool writes its section), so a write that fails (a full disk) leaves it as it was, never cut
    short.
    """
    path = Path(path)
    old = path.read_text(encoding="utf-8") if path.exists() else ""
    lines = old.splitlines(keepends=True)
    start = next((k for k, line in enumerate(lines) if line.rstrip() == SECTION), None)
    if (BEGIN in old and END in old) or start is None:
        replace_section(path, NAME, text)
        return
    # an unmarked section (a page from before the markers): replaced from its heading to the next
    # heading or marker comment, and marked
    end = next((k for k in range(start + 1, len(lines)) if lines[k].startswith(("## ", "<!--"))), len(lines))
    rest = "".join(lines[end:])
    new = "".join(lines[:start]) + f"{BEGIN}\n{text.rstrip()}\n{END}\n" + ("\n" + rest if rest else "")
    with written_whole(path) as tmp:
        tmp.write_text(new, encoding="utf-8")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=description(__doc__))
    ap.add_argument("--sizes", type=positive_int, nargs="+", default=[256, 512],
                    help="grid sizes n (n x n) (default %(default)s)")
    ap.add_argument("--models", nargs="+", default=["wave", "shallow_water"], choices=sorted(MODELS),
                    help="water models (default %(default)s)")
    ap.add_argument("--boundaries", nargs="+", default=["reflecting", "absorbing"], choices=sorted(BOUNDARIES),
                    help="boundaries (default %(default)s)")
    ap.add_argument("--parallel", action="store_true", help="also time the multi-threaded compiled kernels")
    ap.add_argument("--numpy", action="store_true", help="also time the numpy reference kernels")
    ap.add_argument("--rounds", type=positive_int, default=41,
                    help="interleaved rounds (median ratio, best times) (default %(default)s)")
    ap.add_argument("--min-time", type=positive_float, default=0.01,
                    help="seconds per timed batch (default %(default)s)")
    ap.add_argument("--markdown", type=Path, help="write the results section into this markdown file")
    args = ap.parse_args(argv)
    check_output(ap, args.markdown, "--markdown", text=True, sections=(NAME,))
    least = 3 if "absorbing" in args.boundaries else 2  # (an absorbing edge needs a column inside it)
    if min(args.sizes) < least:  # refused before anything runs, not as a traceback after the first rows
        ap.error(f"--sizes: each at least {least} with the boundaries {' and '.join(args.boundaries)} "
                 f"(got {min(args.sizes)})")
    backends = ["numba"] + ["numba-parallel"] * args.parallel + ["numpy"] * args.numpy
    load_start = os.getloadavg()[0]
    rows = []
    for n in args.sizes:
        for model in args.models:
            for boundary in args.boundaries:
                for backend in backends:
                    row = measure(n, model, boundary, backend, rounds=args.rounds, min_time=args.min_time)
                    rows.append(row)
                    print(table(rows[-1:])[-1], flush=True)
    print()
    print("\n".join(table(rows)))
    if args.markdown is not None:
        command = command_line("bench_water.py", argv)
        write_section(args.markdown, markdown(rows, command, (load_start, os.getloadavg()[0])))
        print(f"\nwrote {args.markdown}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
