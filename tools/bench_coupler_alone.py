"""The water coupler alone, re-run over the held skip's own inputs: its cost per step, how much of
that is the compiled call, and (``--against REV``) how it compares with another revision's coupler.

    python tools/bench_coupler_alone.py                      # this checkout: us a step, compiled share
    python tools/bench_coupler_alone.py --against HEAD~3     # this checkout against another revision

The held skip (``scenarios/held_skip.yaml``, recording off) is run once and every input its coupler
receives is kept (about 4,500 steps: the flight, four contacts, the glide). A fresh coupler then takes
those inputs in turn, ``--passes`` times; each pass is timed, and one more with the compiled call
timed on its own (its share of the step; the rest is the Python around it and the framework's
checks of the outputs). Only the coupler runs, so the water, the body and the scheduler neither
add their time nor evict the coupler's data between steps as in a whole run: the figures are the
coupler's own, lower than its share of a run suggests.

Why this exists. The machines these benchmarks run on are shared, and their speed moves by a factor
1.5 over minutes: two whole runs of the skip taken a minute apart differ by more than a change to
the coupler's Python usually saves. With ``--against``, the other revision is checked out beside this
one (``git worktree``), and the two couplers take the same inputs in turn, one process each, pass by
pass, ``--pairs`` times; the figure is the median of the pairs' ratios (this / other), taken seconds
apart, with its range.
"""

from __future__ import annotations

import argparse
import json
import pickle
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # for tools.options; appended, so a root _import_from puts first wins for the rest
    sys.path.append(str(ROOT))

from tools.options import description  # noqa: E402

SCENE = "scenarios/held_skip.yaml"
OVERRIDES = ["record.visual_rate=0"]  # the coupler's inputs do not depend on the viewer
COMPILED = ("met_ring_step", "ring_step")  # the usual step's compiled call, newest name first


def _import_from(root: Path) -> None:
    """Make ``root``'s packages (cosim, components) the ones imported."""
    sys.path.insert(0, str(root))


def capture(path: Path, outputs: list | None = None) -> int:
    """Run the held skip once and pickle every (t_ns, dt_ns, inputs) its coupler steps on to ``path``
    (and append each step's outputs to ``outputs``, when given); the number of steps."""
    from cosim.scenario import load
    from cosim.scheduler import Simulation

    sim = Simulation(load(ROOT / SCENE, OVERRIDES))
    coupler = sim.components["coupler"]
    inner = coupler.step_gathered  # the scheduler's call
    steps: list[tuple] = []

    def step(t_ns, dt_ns, inputs, *args, **kwargs):
        steps.append((t_ns, dt_ns, dict(inputs), args, kwargs))
        result = inner(t_ns, dt_ns, inputs, *args, **kwargs)
        if outputs is not None:
            outputs.append(dict(result))
        return result

    coupler.step_gathered = step  # type: ignore[method-assign]
    sim.run()
    with path.open("wb") as f:
        pickle.dump(steps, f)
    return len(steps)


def _fresh_coupler():
    """A coupler of the held skip, initialised, as the run had it before its first step: built by the
    code imported (this checkout's or, in a worker, the other revision's) from this checkout's scene,
    so that two revisions' couplers are set up alike."""
    from cosim.scenario import load
    from cosim.scheduler import Simulation

    sim = Simulation(load(ROOT / SCENE, OVERRIDES))
    sim.initialize()
    return sim.components["coupler"]


def one_pass(steps: list[tuple], time_compiled: bool = False) -> tuple[float, float]:
    """(wall [s] of all the steps, of which in the compiled call [s]; 0 unless ``time_compiled``)."""
    from components.coupler import step_kernel

    coupler = _fresh_coupler()
    compiled = 0.0
    restore = None
    if time_compiled:
        name = next(n for n in COMPILED if hasattr(step_kernel, n))
        inner = getattr(step_kernel, name)

        def timed(*args):
            nonlocal compiled
            start = time.perf_counter()
            inner(*args)
            compiled += time.perf_counter() - start

        setattr(step_kernel, name, timed)  # the component looks it up on the module at each step
        restore = (name, inner)
    # the scheduler's call, as the run made it (a revision from before it had one: its step)
    step = getattr(coupler, "step_gathered", coupler.step)
    start = time.perf_counter()
    for t_ns, dt_ns, inputs, args, kwargs in steps:
        step(t_ns, dt_ns, inputs, *args, **kwargs)
    wall = time.perf_counter() - start
    if restore is not None:
        setattr(step_kernel, *restore)
    return wall, compiled


def measure(steps_file: Path, passes: int) -> dict:
    """The figures of the imported coupler over the captured steps (run in this process)."""
    with steps_file.open("rb") as f:
        steps = pickle.load(f)
    one_pass(steps)  # warm: kernels loaded from the disk cache, tilings built
    walls = [one_pass(steps)[0] for _ in range(passes)]
    wall, compiled = one_pass(steps, time_compiled=True)
    return {"steps": len(steps), "walls": walls, "compiled_share": compiled / wall}


def _worker(root: Path, steps_file: Path, passes: int) -> dict:
    """:func:`measure` of ``root``'s coupler in a fresh process (its own imports)."""
    out = subprocess.run([sys.executable, __file__, "--measure", str(root), "--steps", str(steps_file),
                          "--passes", str(passes)], capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise SystemExit(f"error: the coupler of {root} could not be timed:\n{out.stderr.strip()}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--passes", type=int, default=5, help="timed passes over the inputs (default 5)")
    parser.add_argument("--against", metavar="REV", help="compare with this git revision's coupler")
    parser.add_argument("--pairs", type=int, default=8, help="with --against: pairs of processes (default 8)")
    parser.add_argument("--measure", metavar="ROOT", help=argparse.SUPPRESS)  # a worker's own run
    parser.add_argument("--steps", metavar="FILE", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.passes < 1 or args.pairs < 1:
        parser.error("--passes and --pairs must be at least 1")
    if args.measure:
        _import_from(Path(args.measure))
        print(json.dumps(measure(Path(args.steps), args.passes)))
        return 0
    if args.against:  # a revision that is none is said before the held skip is run to capture its steps
        known = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--verify", "--quiet",
                                f"{args.against}^{{commit}}"], capture_output=True, text=True, check=False)
        if known.returncode != 0:
            print(f"error: --against {args.against}: not a revision of {ROOT}", file=sys.stderr)
            return 2
    _import_from(ROOT)
    with tempfile.TemporaryDirectory() as tmp:
        steps_file = Path(tmp) / "steps.pickle"
        n = capture(steps_file)
        if not args.against:
            figures = measure(steps_file, args.passes)
            best, median = min(figures["walls"]), statistics.median(figures["walls"])
            print(f"the coupler alone over the held skip's {n} steps, {args.passes} passes: "
                  f"{best / n * 1e6:.1f} us a step (best), {median / n * 1e6:.1f} us (median); "
                  f"the compiled call {figures['compiled_share']:.0%} of it")
            return 0
        other = Path(tmp) / "other"
        made = subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-f", str(other), args.against],
                              capture_output=True, text=True, check=False)
        if made.returncode != 0:
            print(f"error: --against {args.against}: {made.stderr.strip() or 'not a revision'}", file=sys.stderr)
            return 2
        try:
            ratios, here, there = [], [], []
            for k in range(args.pairs):
                order = (ROOT, other) if k % 2 == 0 else (other, ROOT)  # each first in turn
                walls = {root: min(_worker(root, steps_file, args.passes)["walls"]) for root in order}
                here.append(walls[ROOT])
                there.append(walls[other])
                ratios.append(walls[ROOT] / walls[other])
                print(f"pair {k + 1}: this {walls[ROOT] / n * 1e6:.1f} us a step, {args.against} "
                      f"{walls[other] / n * 1e6:.1f} us ({ratios[-1]:.3f})", flush=True)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(other)],
                           capture_output=True, check=False)
        print(f"this checkout / {args.against}: {statistics.median(ratios):.3f} (median of {args.pairs} pairs; "
              f"{min(ratios):.3f} to {max(ratios):.3f}); best {min(here) / n * 1e6:.1f} against "
              f"{min(there) / n * 1e6:.1f} us a step")
    return 0


if __name__ == "__main__":
    sys.exit(main())
