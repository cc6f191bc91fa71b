"""Sweep throughput: speed-up from 1 to 2 workers, and the per-run overhead of each backend.

The same sweep of N identical runs of scenarios/ping_pong.yaml (an axis over the scene's description
only, so every run costs the same: ``--until`` simulated seconds, about 0.3 s of CPU) runs on a process
pool of 1 and of 2 workers, and on a Dask LocalCluster of 2 worker processes on 127.0.0.1, all in one
process and one run. A second sweep of one-tick runs measures what each backend adds per run
(scheduling, pickling, the table). Backends are started and warmed before timing; the repeats are
interleaved and each figure is the best of ``--repeats``. The machines are shared and noisy: the pool
workers' CPU time over the wall time says how many cores they actually got, so a speed-up cut short by
other load shows as such. Compare ratios, not absolute times.

    python tools/bench_sweep.py [--runs 16] [--until 60] [--tiny-runs 200] [--write docs/performance.md]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cosim.docsection import replace_section  # noqa: E402
from cosim.runner import run_scene  # noqa: E402
from cosim.scenario import load  # noqa: E402
from cosim.sweep.backends import DaskBackend, ProcessBackend  # noqa: E402
from cosim.sweep.plan import loads_sweep  # noqa: E402
from cosim.sweep.run import run_sweep  # noqa: E402
from tools.options import check_output, command_line, description, positive_float, positive_int  # noqa: E402

SCENE = ROOT / "scenarios" / "ping_pong.yaml"


def sweep_text(runs: int, until: float) -> str:
    labels = ", ".join(f"'run {i}'" for i in range(runs))
    return (f"name: bench\nscene: {SCENE}\naxes:\n  description: [{labels}]\n"
            f"set: {{until: {until}, record.checkpoint_every: 0}}\n")


def worker_cpu_seconds(backend) -> float:
    """CPU time [s] used so far by a process pool's workers (Linux /proc; nan elsewhere or on Dask)."""
    pool = getattr(backend, "pool", None)
    if pool is None:
        return math.nan
    total = 0.0
    for proc in getattr(pool, "_processes", {}).values():
        try:
            fields = Path(f"/proc/{proc.pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            return math.nan
        total += (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime + stime
    return total


def timed_sweep(backend, runs: int, until: float, folder: Path) -> tuple[float, float]:
    """Wall time [s] of the sweep on a started backend (into a fresh table), and the cores its workers
    obtained meanwhile (their CPU time / wall time; nan where it cannot be read)."""
    sweep = loads_sweep(sweep_text(runs, until), "bench.yaml")
    cpu0 = worker_cpu_seconds(backend)
    start = time.perf_counter()
    outcome = run_sweep(sweep, folder / "bench.csv", backend, fresh=True, progress=False, figure=False)
    elapsed = time.perf_counter() - start
    if outcome.counts.get("ok") != runs:
        raise SystemExit(f"benchmark sweep did not run cleanly: {outcome.summary()}")
    return elapsed, (worker_cpu_seconds(backend) - cpu0) / elapsed


def in_process(until: float, repeats: int) -> float:
    """Best wall time [s] of one run in this process, loading the scene included (what a worker does
    per run)."""
    best = float("inf")
    for _ in range(repeats):
        start = time.perf_counter()
        scene = load(SCENE, overrides=[f"until={until}", "record.checkpoint_every=0"])
        run_scene(scene, None, progress=False)
        best = min(best, time.perf_counter() - start)
    return best


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--runs", type=positive_int, default=16,
                        help="runs in the throughput sweep (default %(default)s)")
    parser.add_argument("--until", type=positive_float, default=60.0,
                        help="simulated seconds per run (ping-pong) (default %(default)s)")
    parser.add_argument("--tiny-runs", type=positive_int, default=200,
                        help="one-tick runs in the overhead sweep (default %(default)s)")
    parser.add_argument("--repeats", type=positive_int, default=5, help="repeats of each sweep (default %(default)s)")
    parser.add_argument("--write", metavar="MARKDOWN", help="update the sweeps section of this file")
    args = parser.parse_args(argv)
    check_output(parser, args.write, "--write", text=True, sections=("sweeps",))
    tiny = 0.001  # one tick of ping-pong: the run itself costs next to nothing
    run_s = in_process(args.until, 3)
    tiny_ms = in_process(tiny, 20) * 1e3
    heavy: dict[str, float] = {}
    light: dict[str, float] = {}
    startup: dict[str, float] = {}
    cores: dict[str, float] = {}
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        backends = {"pool1": ProcessBackend(1), "pool2": ProcessBackend(2),
                    "dask2": DaskBackend("local", 2, processes=True)}
        try:
            for key, backend in backends.items():
                start = time.perf_counter()
                backend.start()
                run_sweep(loads_sweep(sweep_text(4, tiny), "warm.yaml"), folder / "warm.csv", backend,
                          fresh=True, progress=False, figure=False)
                startup[key] = time.perf_counter() - start
            # interleaved, so a burst of load from elsewhere hits every backend alike
            for _ in range(args.repeats):
                for key, backend in backends.items():
                    wall, got = timed_sweep(backend, args.runs, args.until, folder)
                    if wall < heavy.get(key, math.inf):
                        heavy[key], cores[key] = wall, got
                    if key != "pool1":
                        wall, _ = timed_sweep(backend, args.tiny_runs, tiny, folder)
                        light[key] = min(light.get(key, wall), wall)
        finally:
            for backend in backends.values():
                backend.close()
    load_after = os.getloadavg()[0]
    speedup = heavy["pool1"] / heavy["pool2"]
    dask_vs_pool = heavy["dask2"] / heavy["pool2"]
    efficiency = speedup * cores["pool1"] / cores["pool2"]
    per_run = {k: v / args.tiny_runs * 1e3 for k, v in light.items()}
    ncpu = os.cpu_count()
    rows = [
        "| backend | workers | wall for the sweep [s] | per run [s] | cores the workers got | speed-up |",
        "|---|---:|---:|---:|---:|---:|",
        f"| in this process, no pool (one run x {args.runs}) | 1 | {run_s * args.runs:.2f} | {run_s:.3f} "
        "| - | - |",
        f"| process pool | 1 | {heavy['pool1']:.2f} | {heavy['pool1'] / args.runs:.3f} | {cores['pool1']:.2f} | 1 |",
        f"| process pool | 2 | {heavy['pool2']:.2f} | {heavy['pool2'] / args.runs:.3f} | {cores['pool2']:.2f} "
        f"| **{speedup:.2f}** |",
        f"| Dask LocalCluster (2 processes, 127.0.0.1) | 2 | {heavy['dask2']:.2f} | "
        f"{heavy['dask2'] / args.runs:.3f} | - | {heavy['pool1'] / heavy['dask2']:.2f} |",
    ]
    overhead = [
        "| backend, 2 workers | per one-tick run [ms] | start-up and warm-up [s] |",
        "|---|---:|---:|",
        f"| (one one-tick run in this process, no pool) | {tiny_ms:.2f} | - |",
        f"| process pool | {per_run['pool2']:.2f} | {startup['pool2']:.2f} |",
        f"| Dask LocalCluster | {per_run['dask2']:.2f} | {startup['dask2']:.2f} |",
    ]
    verdict = "meets" if speedup >= 1.7 else "MISSES"
    text = "\n".join([
        "## Sweeps",
        "",
        f"`cosim sweep` on this machine ({ncpu} cores): {args.runs} identical runs of the ping-pong scene "
        f"({args.until:g} simulated s each, {run_s:.2f} s of wall time in one process), best of {args.repeats} "
        f"interleaved repeats, backends started and warmed before timing (load average {load_before:.1f} before, "
        f"{load_after:.1f} after); one run of `{command_line('bench_sweep.py', argv)}`:",
        "",
        *rows,
        "",
        f"Speed-up from 1 to 2 workers: **{speedup:.2f}x** ({verdict} the 1.7x target). The machine is "
        f"shared: the workers got {cores['pool1']:.2f} and {cores['pool2']:.2f} cores (their CPU time over "
        f"the wall time; the rest went to other load), so per core obtained 2 workers did {efficiency:.0%} "
        f"of what 1 worker does, which on 2 idle cores is a speed-up of about {2 * efficiency:.2f}x. On "
        f"Dask the same sweep takes {dask_vs_pool:.2f}x the process pool's time.",
        "",
        f"Per-run overhead, from {args.tiny_runs} one-tick runs (wall time of the sweep / runs; loading and "
        f"running such a run costs {tiny_ms:.2f} ms in one process, the rest is scheduling, pickling the "
        "task and its row, and appending the row to the table):",
        "",
        *overhead,
        "",
        f"The Dask backend adds **{per_run['dask2'] - per_run['pool2']:.2f} ms per run** over the process "
        "pool here (a task goes through the scheduler over loopback TCP); against runs of a second or more, "
        "as a real throw is, both overheads vanish.",
    ])
    print(text)
    if args.write:
        replace_section(args.write, "sweeps", text)


if __name__ == "__main__":
    main()
