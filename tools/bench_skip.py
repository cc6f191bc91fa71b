"""The reference skip's speed: real-time factor with recording off and on, and what recording costs.

Runs scenarios/skip.yaml (1 cm water cells) in one process: a warm-up, then, in turn, without a
recording, with every exchange recorded (no viewer channels, no checkpoints), and as the scene says
(every exchange, the viewer channels at 30 frames/s and a checkpoint every 0.5 s), several times
each. Reports the best and the median wall time of each, the recording overhead as the ratio of
those measured in this run, and where the CPU time went (the simulating process, the writer process).
The recorded wall time includes closing the file.

    python tools/bench_skip.py [--repeats 7] [--busy] [--write docs/performance.md]
    python tools/bench_skip.py --scene scenarios/held_skip.yaml     # another scene, figures on stdout

With ``--busy`` another job keeps one core busy throughout the timed runs (a process spinning in a
loop), as on a shared machine: the simulation, the recording's writer process and that job then
share the machine's cores (two on the machine of docs/performance.md).

In one process, every recording after the warm-up is written by the writer process kept from the
one before (``cosim.record.writer``), as in any process that records more than once (a sweep's
worker, a notebook, the tests). With ``--fresh`` each run is instead a one-off ``cosim run`` as a
user types it, in a fresh process, timed from its start to its exit: its start-up (the writer
started first), the run and the file's finishing; the CPU column is that process's and its writer's
together (the writer ends, and is waited for, as the process exits).

    python tools/bench_skip.py --fresh [--busy] [--write docs/performance.md]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cosim.docsection import replace_section  # noqa: E402
from cosim.errors import CosimError, ScenarioError, one_line  # noqa: E402
from cosim.record import writer as writer_module  # noqa: E402
from cosim.runner import run_scene  # noqa: E402
from cosim.scenario import load  # noqa: E402
from tools.options import check_output, command_line, description, positive_int  # noqa: E402

SCENE = ROOT / "scenarios" / "skip.yaml"

RUNS = {  # name: (overrides, record)
    "recording off": ([], False),
    "every exchange recorded, no viewer channels or checkpoints": (
        ["record.visual_rate=0", "record.checkpoint_every=0"], True),
    "every exchange, the viewer channels and checkpoints recorded (the scene's default)": ([], True),
}


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _writer_cpu(before: float) -> float:
    """CPU s of the writer process since ``before``: counted once the process has been reaped, which
    happens in the background just after the file is finished."""
    deadline = time.perf_counter() + 5.0
    while _children_cpu() == before and time.perf_counter() < deadline:
        time.sleep(0.005)
    return _children_cpu() - before


def _kept_writer() -> tuple[int, float]:
    """(pid, CPU s so far) of the writer process kept for this process's next recording
    (``cosim.record.writer``), or (0, 0.0) when none is kept."""
    kept = writer_module._spare
    if kept is None:
        return 0, 0.0
    try:
        with open(f"/proc/{kept.proc.pid}/stat") as f:
            fields = f.read().rsplit(") ", 1)[1].split()
    except (OSError, IndexError):
        return kept.proc.pid, 0.0
    return kept.proc.pid, (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")  # utime, stime


def timed_run(overrides: list[str], record: bool, scene_file: Path = SCENE) -> tuple[float, float, float, float]:
    """(simulated s, wall s, CPU s of this process, CPU s of the writer process) of one run. The
    writer is the one kept from the last recording when there is one (its CPU counted from this
    run's start), else one started for this run (all of its CPU)."""
    scene = load(scene_file, overrides=overrides)
    with tempfile.TemporaryDirectory() as tmp:
        pid, kept_cpu = _kept_writer()
        cpu, children, start = time.process_time(), _children_cpu(), time.perf_counter()
        outcome = run_scene(scene, Path(tmp) / "skip.mcap" if record else None, progress=False)
        wall = time.perf_counter() - start
        cpu = time.process_time() - cpu
        writer = 0.0
        if record:
            now_pid, now_cpu = _kept_writer()
            if now_pid:  # kept again: this run's share of its CPU
                writer = now_cpu - (kept_cpu if now_pid == pid else 0.0)
            else:  # let go at the end of the run, and reaped
                writer = _writer_cpu(children)
    return outcome.result.time_ns / 1e9, wall, cpu, writer


DEFAULT_TARGET = 0.15  # recording with the scene's defaults at most this much over recording off
BUSY_LOOP = "while True: pass"  # the other job: one core's worth of pure CPU


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--repeats", type=positive_int, default=7, help="runs of each kind (default %(default)s)")
    parser.add_argument("--busy", action="store_true", help="keep one core busy with another job meanwhile")
    parser.add_argument("--fresh", action="store_true", help="each run a one-off `cosim run` in a fresh process")
    parser.add_argument("--write", metavar="MARKDOWN", help="update the reference-skip section of this file")
    parser.add_argument("--scene", type=Path, default=SCENE,
                        help="the scene to run (default: the reference skip; another one's figures are not written)")
    args = parser.parse_args(argv)
    if not args.scene.is_file():
        parser.error(f"--scene {args.scene}: {'a folder' if args.scene.is_dir() else 'no such file'}")
    try:  # a scene that does not load is said before anything runs, in its own words
        load(args.scene)
    except ScenarioError as exc:
        more = f" (and {len(exc.problems) - 1} more: cosim validate {args.scene})" if len(exc.problems) > 1 else ""
        parser.error(f"--scene {args.scene}: {exc.problems[0] if exc.problems else one_line(str(exc))}{more}")
    except CosimError as exc:
        parser.error(f"--scene {args.scene}: {one_line(str(exc))}")
    if args.write and args.scene.resolve() != SCENE:
        parser.error(f"--write updates the reference skip's sections; {args.scene} is another scene")
    check_output(parser, args.write, "--write", text=True,
                 sections=("skip" + ("-fresh" if args.fresh else "") + ("-busy" if args.busy else ""),))
    busy = subprocess.Popen([sys.executable, "-c", BUSY_LOOP]) if args.busy else None
    try:
        report(args, command_line("bench_skip.py", argv))
    finally:
        if busy is not None:
            busy.kill()
            busy.wait()


def _cosim() -> list[str]:
    """The command a user runs: the console script beside this interpreter, else ``python -m``."""
    script = Path(sys.executable).with_name("cosim")
    return [str(script)] if script.exists() else [sys.executable, "-m", "cosim.cli"]


def _checkout_env() -> dict[str, str]:
    """The environment of a ``cosim`` subprocess that imports this checkout's packages (not whatever
    cosim is installed): its root first on PYTHONPATH."""
    return {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}


def fresh_run(overrides: list[str], record: bool, scene_file: Path) -> tuple[float, float, float]:
    """(wall s, CPU s of the process and its writer, 0.0) of a one-off ``cosim run`` of the scene in a
    fresh process (this checkout's cosim, see ``_checkout_env``)."""
    sets = [arg for o in overrides for arg in ("--set", o)]
    with tempfile.TemporaryDirectory() as tmp:
        output = ["-o", str(Path(tmp) / "skip.mcap")] if record else ["--no-record"]
        children, start = _children_cpu(), time.perf_counter()
        subprocess.run([*_cosim(), "run", str(scene_file.resolve()), "-q", *sets, *output], check=True, cwd=tmp,
                       stdout=subprocess.DEVNULL, env=_checkout_env())
        wall = time.perf_counter() - start
    return wall, _children_cpu() - children, 0.0


def report(args: argparse.Namespace, command: str) -> None:
    with tempfile.TemporaryDirectory() as warm:
        for overrides, record in RUNS.values():  # compile / load kernels, import the writer's modules
            run_scene(load(args.scene, overrides=["until=0.05", *overrides]),
                      Path(warm) / "warm.mcap" if record else None, progress=False)
    sim_s = timed_run([], False, args.scene)[0] if args.fresh else 0.0
    load_before = os.getloadavg()[0]
    samples: dict[str, list[tuple[float, float, float]]] = {name: [] for name in RUNS}
    for _ in range(args.repeats):
        for name, (overrides, record) in RUNS.items():
            if args.fresh:
                samples[name].append(fresh_run(overrides, record, args.scene))
                continue
            sim_s, wall, cpu, writer = timed_run(overrides, record, args.scene)
            samples[name].append((wall, cpu, writer))
    load_after = os.getloadavg()[0]
    best = {name: min(w for w, _, _ in runs) for name, runs in samples.items()}
    median = {name: statistics.median(w for w, _, _ in runs) for name, runs in samples.items()}
    off, physics, default = list(RUNS)
    rows = []
    for name, runs in samples.items():
        cpu = statistics.median(c for _, c, _ in runs)
        writer = statistics.median(w for _, _, w in runs)
        rows.append(f"| {name} | {best[name]:.3f} | {median[name]:.3f} | {sim_s / best[name]:.2f} | "
                    f"{cpu:.2f} | {'-' if args.fresh else f'{writer:.2f}'} |")

    def cost(name: str, of: dict[str, float]) -> str:
        return f"{(of[name] / of[off] - 1.0) * 100:+.0f}%"

    def paired(name: str) -> str:
        """The median over the rounds of this kind's wall time against the recording-off run of the
        same round (each round runs the kinds back to back, so a slow spell of the machine that
        lasts a round cancels)."""
        ratios = [run[0] / base[0] for run, base in zip(samples[name], samples[off], strict=True)]
        return f"{(statistics.median(ratios) - 1.0) * 100:+.0f}%"

    scene = args.scene.resolve()
    name = scene.relative_to(ROOT).as_posix() if scene.is_relative_to(ROOT) else str(args.scene)
    where = ("as a one-off `cosim run` each, in a fresh process (start-up and the file's finishing included; "
             "the real-time factor counts them too)" if args.fresh else "in one process")
    text = "\n".join([
        ("## The reference skip" if scene == SCENE else f"## {name}")
        + (", one-off runs" if args.fresh else "") + (", with another job on one core" if args.busy else ""),
        "",
        f"`{name}` ({sim_s:.3g} s simulated until the stone sinks), {args.repeats} runs of each "
        f"kind in turn {where}" + (", while another job kept one core busy" if args.busy else "")
        + f" (load average {load_before:.1f} before, {load_after:.1f} after), `{command}`:",
        "",
        ("| run | best wall [s] | median wall [s] | real-time factor (best) | CPU, the process and its writer "
         "together [s] (median) | |" if args.fresh else
         "| run | best wall [s] | median wall [s] | real-time factor (best) | CPU, simulating process [s] "
         "(median) | CPU, writer process [s] (median) |"),
        "|---|---:|---:|---:|---:|---:|",
        *rows,
        "",
        f"With the scene's defaults (every exchange, the viewer channels, checkpoints) recording costs "
        f"**{paired(default)}** of the run's wall time as the median of the rounds' own ratios "
        f"({cost(default, median)} median against median, {cost(default, best)} best against best; target: at most "
        f"{DEFAULT_TARGET:.0%}). Every exchange alone costs {paired(physics)} ({cost(physics, median)}, "
        f"{cost(physics, best)}). The real-time factor with everything recorded is "
        f"**{sim_s / median[default]:.2f}** (median run; target: 1 or more).",
    ])
    print(text)
    if args.write:
        replace_section(args.write, "skip" + ("-fresh" if args.fresh else "") + ("-busy" if args.busy else ""), text)


if __name__ == "__main__":
    main()
