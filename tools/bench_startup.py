"""Start-up: a 1 ms run of the reference skip beside `python -c "import numba"`, measured in one run.

    python tools/bench_startup.py [--rounds 11] [--write docs/performance.md]

Each round starts, one after the other, fresh processes of: ``python -c "import numba"`` (the
peer: a process that can use compiled kernels at all), ``cosim run scenarios/skip.yaml --until
0.001 -q`` as a user types it (recording to a file: the writer process, the viewer channels) and the
same with ``--no-record``. Times are wall-clock from start to exit. The figure is the median over the
rounds of (run time / import time) within the round, so that a slow spell of a shared machine cancels;
the table also gives the median times. The kernels' disk cache is warmed by a first run that is not
counted (a fresh checkout compiles once, see docs/performance.md), and the project's modules are
byte-compiled first, as installing a package or importing it once does: an environment that sets
PYTHONDONTWRITEBYTECODE would otherwise have every process compile them from source again (about
60 modules; ``--no-byte-compile`` measures that).
"""

from __future__ import annotations

import argparse
import compileall
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cosim.docsection import replace_section  # noqa: E402
from tools.options import check_output, description, positive_int  # noqa: E402

TARGET = 2.0  # a 1 ms run at most this many times `import numba` (DESIGN.md section 5)
SCENE = "scenarios/skip.yaml"


def _cosim() -> list[str]:
    """The command a user runs: the console script beside this interpreter, else ``python -m``."""
    script = Path(sys.executable).with_name("cosim")
    return [str(script)] if script.exists() else [sys.executable, "-m", "cosim.cli"]


def commands(out: Path) -> dict[str, list[str]]:
    run = [*_cosim(), "run", SCENE, "--until", "0.001", "-q"]
    return {
        'python -c "import numba"': [sys.executable, "-c", "import numba"],
        f"cosim run {SCENE} --until 0.001 -q (recorded)": [*run, "-o", str(out)],
        f"cosim run {SCENE} --until 0.001 -q --no-record": [*run, "--no-record"],
    }


def byte_compile() -> None:
    """Write the bytecode of the project's packages, as an install (or a first import) would."""
    for package in ("cosim", "components"):
        compileall.compile_dir(ROOT / package, quiet=1)


def wall(cmd: list[str]) -> float:
    """Seconds from starting ``cmd`` to its exit (it must succeed)."""
    t0 = time.perf_counter()
    # this checkout's packages first (not whatever cosim is installed); the command itself is unchanged
    env = {**os.environ, "PYTHONPATH": str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    subprocess.run(cmd, cwd=ROOT, check=True, stdout=subprocess.DEVNULL, env=env)
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=description(__doc__))
    ap.add_argument("--rounds", type=positive_int, default=11,
                    help="rounds of the commands in turn (default %(default)s)")
    ap.add_argument("--write", metavar="MARKDOWN", help="update the start-up section of this file")
    ap.add_argument("--no-byte-compile", action="store_true",
                    help="leave the project's modules as they are (without bytecode, compiled at every start)")
    args = ap.parse_args(argv)
    check_output(ap, args.write, "--write", text=True, sections=("startup",))
    if not args.no_byte_compile:
        byte_compile()
    with tempfile.TemporaryDirectory() as tmp:
        cmds = commands(Path(tmp) / "short.mcap")
        for cmd in cmds.values():  # warm the kernels' disk cache and the OS file cache
            wall(cmd)
        load = [os.getloadavg()[0]]
        times: dict[str, list[float]] = {name: [] for name in cmds}
        for _ in range(args.rounds):
            for name, cmd in cmds.items():
                times[name].append(wall(cmd))
        load.append(os.getloadavg()[0])
    peer = next(iter(times.values()))
    rows = []
    ratios = {}
    for name, ts in times.items():
        ratios[name] = statistics.median(t / p for t, p in zip(ts, peer, strict=True))
        rows.append(f"| `{name}` | {statistics.median(ts):.3f} | {min(ts):.3f} | {ratios[name]:.2f} |")
    recorded = list(times)[1]
    verdict = "meets" if ratios[recorded] <= TARGET else "misses"
    given = argv if argv is not None else sys.argv[1:]
    command = " ".join(["python tools/bench_startup.py", *given])
    text = "\n".join([
        "## Start-up",
        "",
        f"Fresh processes, {args.rounds} rounds of each in turn (load average {load[0]:.1f} before, "
        f"{load[1]:.1f} after), kernels already in numba's disk cache, "
        + ("the project's modules as they were" if args.no_byte_compile else "the project's modules byte-compiled")
        + f"; `{command}`:",
        "",
        "| command | wall [s] (median) | wall [s] (best) | / `import numba` (median of the rounds) |",
        "|---|---:|---:|---:|",
        *rows,
        "",
        f"A 1 ms run of the reference skip, recorded, takes **{ratios[recorded]:.2f}x** "
        f"`python -c \"import numba\"` (target: at most {TARGET:g}x): it {verdict} the target.",
        "",
    ])
    print(text)
    if args.write:
        replace_section(args.write, "startup", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
