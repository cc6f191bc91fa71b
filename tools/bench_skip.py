"""The reference skip's speed: real-time factor with recording off and on, and what recording costs.

Runs scenarios/skip.yaml (1 cm water cells) in one process: a warm-up, then alternately without and
with a recording of every exchange (plus the viewer channels), best of several repeats each, and
reports the real-time factor of each and the recording overhead as a ratio measured in the same run.
The recorded wall time includes closing the file.

    python tools/bench_skip.py [--repeats 3] [--write docs/performance.md]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cosim.docsection import replace_section  # noqa: E402
from cosim.runner import run_scene  # noqa: E402
from cosim.scenario import load  # noqa: E402

SCENE = ROOT / "scenarios" / "skip.yaml"


PHYSICS_ONLY = ["record.visual_rate=0", "record.checkpoint_every=0"]


def timed_run(record: bool, overrides: list[str] | None = None) -> tuple[float, float]:
    """(simulated seconds, wall seconds) of one run of the reference skip."""
    scene = load(SCENE, overrides=overrides)
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        outcome = run_scene(scene, Path(tmp) / "skip.mcap" if record else None, progress=False)
        wall = time.perf_counter() - start
    return outcome.result.time_ns / 1e9, wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--write", metavar="MARKDOWN", help="update the reference-skip section of this file")
    args = parser.parse_args()
    run_scene(load(SCENE, overrides=["until=0.05"]), None, progress=False)  # compile / load kernels
    off: list[float] = []
    on: list[float] = []
    physics: list[float] = []
    sim_s = 0.0
    for _ in range(args.repeats):
        sim_s, wall = timed_run(False)
        off.append(wall)
        _, wall = timed_run(True)
        on.append(wall)
        _, wall = timed_run(True, PHYSICS_ONLY)
        physics.append(wall)
    best_off, best_on, best_physics = min(off), min(on), min(physics)
    overhead = best_on / best_off - 1.0
    text = "\n".join([
        "## The reference skip",
        "",
        f"`scenarios/skip.yaml` ({sim_s:.3g} s simulated until the stone sinks), best of {args.repeats} "
        "alternating runs in one process, `python tools/bench_skip.py --write docs/performance.md`:",
        "",
        "| run | wall time [s] | real-time factor |",
        "|---|---:|---:|",
        f"| recording off | {best_off:.3g} | {sim_s / best_off:.2f} |",
        f"| every exchange recorded, no viewer channels or checkpoints | {best_physics:.3g} | "
        f"{sim_s / best_physics:.2f} |",
        f"| every exchange, the viewer channels and checkpoints recorded (default) | {best_on:.3g} | "
        f"{sim_s / best_on:.2f} |",
        "",
        f"Recording costs **{overhead * 100:.0f}%** of the run (target: at most 25%); the real-time factor "
        f"with recording is **{sim_s / best_on:.2f}** (target: 1 or more). The physics channels alone cost "
        f"{(best_physics / best_off - 1.0) * 100:.0f}%. Other load on the machine "
        f"while measuring lowers both; the wall times of all runs were {', '.join(f'{w:.2f}' for w in off)} s "
        f"(off) and {', '.join(f'{w:.2f}' for w in on)} s (on).",
    ])
    print(text)
    if args.write:
        replace_section(args.write, "skip", text)


if __name__ == "__main__":
    main()
