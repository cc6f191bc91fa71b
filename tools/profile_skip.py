"""Where a skip's time goes: each component's share of the run loop, and the functions that take it.

    python tools/profile_skip.py [--runs 5] [--write docs/performance.md]

Two scenes, each with recording off (the physics alone), after a warm-up run that loads the kernels
from numba's disk cache: the reference skip (``scenarios/skip.yaml``, the free spinning throw on its
14 m x 3.5 m pond) and the held skip (``scenarios/held_skip.yaml``, the benchmarks' scene, whose
figures compare across rounds). Two measures of each:

* **Shares** (``--runs`` runs, median): every component's ``step`` is wrapped in a timer; the rest
  of the loop (gathering inputs, delivering outputs, the scheduler's bookkeeping) is the scheduler's.
  The wrappers cost a few hundred nanoseconds a step, so the shares are those of the plain run to
  within a percent or two.
* **Functions** (one run under ``cProfile``): the functions with the most time of their own. The
  profiler slows Python code several times and compiled kernels not at all (a numba call is one
  entry, its whole time its own), so this table says *which* code takes the time, the shares above
  *how much*.

The machine is shared: the shares are ratios within one run, the absolute times move with the load.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import statistics
import sys
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cosim.docsection import replace_section  # noqa: E402
from cosim.scenario import load  # noqa: E402
from cosim.scheduler import Simulation  # noqa: E402
from tools.bench_coupler import StepTimer  # noqa: E402
from tools.options import check_output, command_line, description, machine, positive_int  # noqa: E402

# (the doc section, its title, the scene)
SCENES = (
    ("profile-reference", "Where the reference skip's time goes", ROOT / "scenarios" / "skip.yaml"),
    ("profile", "Where the held skip's time goes", ROOT / "scenarios" / "held_skip.yaml"),
)
FUNCTIONS_SHOWN = 12


def shares(scene: Path) -> tuple[dict[str, float], float, str]:
    """(seconds per component type and 'scheduler', loop wall [s], the run's status line) of one run."""
    sim = Simulation(load(scene, ["record.visual_rate=0"]))
    timers = {name: (type(comp).__name__, StepTimer(comp)) for name, comp in sim.components.items()}
    start = time.perf_counter()
    result = sim.run()
    wall = time.perf_counter() - start
    seconds: dict[str, float] = defaultdict(float)
    for kind, timer in timers.values():
        seconds[kind] += timer.seconds
    seconds["scheduler"] = wall - sum(seconds.values())
    return dict(seconds), wall, f"{result.status} at t = {result.time_ns * 1e-9:.3g} s"


def _where(filename: str) -> str:
    """A function's file relative to the project, or the library it belongs to."""
    if filename.startswith("<"):
        return filename  # built-in
    path = Path(filename).resolve()
    if ROOT in path.parents:
        return str(path.relative_to(ROOT))
    parts = path.parts
    if "site-packages" in parts and parts.index("site-packages") + 1 < len(parts):
        return "/".join(parts[parts.index("site-packages") + 1:])
    return path.name


def functions(scene: Path, top: int) -> tuple[list[tuple[str, int, float, float]], float]:
    """([(function, calls, own seconds, cumulative seconds)], total profiled seconds) of one run."""
    sim = Simulation(load(scene, ["record.visual_rate=0"]))
    profile = cProfile.Profile()
    profile.enable()
    sim.run()
    profile.disable()
    stats = pstats.Stats(profile)
    rows = []
    for (filename, line, name), (_, calls, own, cumulative, _) in stats.stats.items():  # type: ignore[attr-defined]
        rows.append((f"`{name}` ({_where(filename)}:{line})", calls, own, cumulative))
    rows.sort(key=lambda r: -r[2])
    return rows[:top], stats.total_tt  # type: ignore[attr-defined]


def report(scene: Path, runs: int, command: str) -> str:
    Simulation(load(scene, ["until=0.05", "record.visual_rate=0"])).run()  # kernels from the disk cache
    load_before = os.getloadavg()[0]
    measured = [shares(scene) for _ in range(runs)]
    top, total = functions(scene, FUNCTIONS_SHOWN)
    load_after = os.getloadavg()[0]
    kinds = list(measured[0][0])
    share = {k: statistics.median(m[0][k] / m[1] for m in measured) for k in kinds}
    wall = statistics.median(m[1] for m in measured)
    lines = [
        f"`{scene.relative_to(ROOT)}` with recording off ({measured[0][2]}), {runs} runs, median "
        f"({machine(load_before, load_after)}); `{command}`:",
        "",
        "| part of the loop | share of the loop (median) |",
        "|---|---:|",
    ]
    for kind in sorted(kinds, key=lambda k: -share[k]):
        label = "the scheduler (inputs, outputs, bookkeeping)" if kind == "scheduler" else f"`{kind}` steps"
        lines.append(f"| {label} | {share[kind]:.0%} |")
    lines += [f"| the loop | {wall:.2f} s (median) |", "",
              f"The functions with the most time of their own, one run under `cProfile` ({total:.2f} s "
              f"profiled: the profiler slows Python code, not the compiled kernels, so their share "
              f"here is below the true one):", "",
              "| function | calls | own time [s] | with callees [s] |", "|---|---:|---:|---:|"]
    lines += [f"| {name} | {calls} | {own:.3f} | {cumulative:.3f} |" for name, calls, own, cumulative in top]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--runs", type=positive_int, default=5, help="runs of each measure (default %(default)s)")
    parser.add_argument("--write", metavar="MARKDOWN", help="update the two profile sections of this file")
    args = parser.parse_args(argv)
    check_output(parser, args.write, "--write", text=True, sections=tuple(s[0] for s in SCENES))
    for section, title, scene in SCENES:
        text = f"## {title}\n\n" + report(scene, args.runs, command_line("profile_skip.py", argv))
        print(text + "\n")
        if args.write:
            replace_section(Path(args.write), section, text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
