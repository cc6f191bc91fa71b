"""Framework overhead: microseconds per component-step of the ping-pong scene.

Runs scenarios/ping_pong.yaml (two components, one direct and one delayed edge) with recording off
and on, beside a plain Python loop doing the same arithmetic and the same scene in mosaik, the peer
(``tools/mosaik_peer.py``; DESIGN.md section 5: cosim at least 25x less overhead per
component-step), all in one process and one run, and reports the figures and their ratios (the
machines are shared and noisy: compare ratios, not absolute times). Each figure is the best of
several repeats, the kinds taken in turn.

    python tools/bench_framework.py [--ticks 20000] [--repeats 5] [--write docs/performance.md]
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from cosim.docsection import replace_section  # noqa: E402
from cosim.record.recorder import Recorder  # noqa: E402
from cosim.scenario import load  # noqa: E402
from cosim.scheduler import Simulation  # noqa: E402
from tools.options import check_output, command_line, description, machine, positive_int  # noqa: E402

SCENE = ROOT / "scenarios" / "ping_pong.yaml"
PEER_TARGET = 25.0  # cosim's overhead per component-step at least this many times below mosaik's


def plain_loop(ticks: int) -> float:
    """The same arithmetic without any framework: x <- (x + 1) / 2, twice per tick's worth."""
    start = time.perf_counter()
    x = 0.0
    for _ in range(ticks):
        y = x + 1.0
        x = y * 0.5
    elapsed = time.perf_counter() - start
    return elapsed


def framework(ticks: int, record: bool) -> float:
    scene = load(SCENE, overrides=[f"until={ticks * 0.001}", "record.checkpoint_every=0"])
    with tempfile.TemporaryDirectory() as tmp:
        observers = [Recorder(Path(tmp) / "bench.mcap", scene)] if record else []
        sim = Simulation(scene, observers=observers)
        start = time.perf_counter()
        sim.run()
        for obs in observers:
            obs.close()
        elapsed = time.perf_counter() - start
    return elapsed


def mosaik_loop(ticks: int) -> float:
    """The same scene in mosaik (the peer), the run alone [s]."""
    from tools import mosaik_peer

    return mosaik_peer.run(ticks)[0]


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--ticks", type=positive_int, default=20000,
                        help="ticks of the ping-pong scene (default %(default)s)")
    parser.add_argument("--repeats", type=positive_int, default=5,
                        help="runs of each kind, the best kept (default %(default)s)")
    parser.add_argument("--write", metavar="MARKDOWN", help="update the framework section of this file")
    args = parser.parse_args(argv)
    check_output(parser, args.write, "--write", text=True, sections=("framework",))
    steps = 2 * args.ticks
    runs = {"plain": lambda: plain_loop(args.ticks), "off": lambda: framework(args.ticks, False),
            "on": lambda: framework(args.ticks, True), "mosaik": lambda: mosaik_loop(args.ticks)}
    if importlib.util.find_spec("mosaik") is None:  # the peer is in the [test] extra
        del runs["mosaik"]
        print("mosaik is not installed (pip install -e '.[test]'): the peer's row is left out", file=sys.stderr)
    best = {name: math.inf for name in runs}
    load_before = os.getloadavg()[0]
    for _ in range(args.repeats):  # interleaved, so a noisy spell of the machine hits every kind alike
        for name, fn in runs.items():
            best[name] = min(best[name], fn())
    load_after = os.getloadavg()[0]
    us = {k: v / steps * 1e6 for k, v in best.items()}
    rows = [
        "| run | us per component-step | ratio to plain loop |",
        "|---|---:|---:|",
        f"| plain Python loop, same arithmetic | {us['plain']:.3f} | 1 |",
        f"| cosim, recording off | {us['off']:.2f} | {us['off'] / us['plain']:.0f} |",
        f"| cosim, every exchange recorded to MCAP | {us['on']:.2f} | {us['on'] / us['plain']:.0f} |",
    ]
    if "mosaik" in us:
        import mosaik

        rows.append(f"| mosaik {getattr(mosaik, '__version__', '')} (the peer: the same scene, its simulators in "
                    f"this process, `tools/mosaik_peer.py`) | {us['mosaik']:.2f} | {us['mosaik'] / us['plain']:.0f} |")
        ratio = us["mosaik"] / us["off"]
        peer = (f"**{ratio:.1f}x** less than mosaik's ({us['mosaik']:.1f} us), recording off; "
                f"{us['mosaik'] / us['on']:.1f}x with every exchange recorded (target: at least "
                f"{PEER_TARGET:g}x: {'met' if ratio >= PEER_TARGET else 'not met'})")
    else:
        peer = "mosaik, the peer, was not installed for this run: not judged"
    text = "\n".join([
        "## Framework overhead",
        "",
        f"Ping-pong scene (2 components, one direct and one delayed edge), {args.ticks} ticks, best of "
        f"{args.repeats}, the kinds in turn ({machine(load_before, load_after)}), one run of "
        f"`{command_line('bench_framework.py', argv)}`:",
        "",
        *rows,
        "",
        f"Framework overhead with recording off: **{us['off']:.2f} us per component-step**, {peer}. "
        f"Recording every exchange costs {us['on'] - us['off']:.2f} us more per "
        "component-step here (two messages per tick, packed as protobuf here, copied into the file and "
        "zstd-chunked by the writer process).",
    ])
    print(text)
    if args.write:
        replace_section(args.write, "framework", text)


if __name__ == "__main__":
    main()
