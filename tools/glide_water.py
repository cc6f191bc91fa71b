"""The water around the reference stone's glide, on one-speed and on dispersive water (docs/accuracy.md).

    python tools/glide_water.py --figure docs/figures/glide_water.png     # under a minute on 2 cores

The reference skip (scenarios/skip.yaml, recording off) run whole: as the scene is, its water's
one wave speed that of the ripples the stone makes (`wave_length`: a wave as long as the stone is
wide, 0.40 m/s), on 1 cm and 5 mm columns; with the long waves' speed sqrt(g d) = 2.2 m/s instead
(`wave_length` unset, the scenes' water before), on 1 cm and 5 mm columns, and on 5 mm columns with
the displaced water's band 1.5 columns wide too (its width before it became half the body's radius:
`components.coupler.ring_share=0`); and on the `airy` model's 1 cm columns (water with its
dispersion, every length at its own speed). For each: the largest vertical surface speed in the
stone's window at each water step, against time, with the stone's horizontal speed and both wave
speeds beside it, so the resonance of the long-wave water as the gliding stone passes through its
speed shows. The table on stdout is each run's peak after the skips and the skips themselves.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from components.water import WaterSurface  # noqa: E402
from components.water.grid import GRAVITY  # noqa: E402
from cosim.scenario import load  # noqa: E402
from cosim.scheduler import BaseObserver, Simulation  # noqa: E402
from tools.options import check_figure, description, save_figure  # noqa: E402

FINE = ("components.pond.cell=0.005", "components.pond.nx=2800", "components.pond.ny=700",
        "components.pond.every=2")
LONG = ("components.pond.wave_length=null",)  # the long waves' sqrt(g d)
RUNS = (  # (label, overrides, colour)
    ("wave, 1 cm columns (the scene: the stone's ripples' speed)", (), "#1f5f8b"),
    ("wave, 5 mm columns (the ripples' speed)", FINE, "#2e8b57"),
    ("airy (dispersive), 1 cm columns", ("components.pond.model=airy",), "#e67e22"),
    ("wave, 1 cm columns, the long waves' sqrt(g d) (before)", LONG, "#8e44ad"),
    ("wave, 5 mm columns, the long waves' sqrt(g d) (before)", (*FINE, *LONG), "#7f8c8d"),
    ("wave, 5 mm columns, sqrt(g d), band 1.5 columns wide (before)",
     (*FINE, *LONG, "components.coupler.ring_share=0"), "#c0392b"),
)
AFTER_SKIPS = 0.95  # [s] the third contact is over by then
STILL = 1e-3  # [m/s] a window whose surface moves slower than this is not drawn


@dataclass
class Trace:
    """One run: times [s], the largest |vertical surface speed| [m/s] in each patch, the stone's
    horizontal speed [m/s] at the same times, and the skips."""

    t: list[float] = field(default_factory=list)
    surface: list[float] = field(default_factory=list)
    stone: list[float] = field(default_factory=list)
    skips: int = 0
    end: str = ""


class _Watch(BaseObserver):
    def __init__(self, trace: Trace):
        self.trace = trace
        self.speed = 0.0

    def on_exchange(self, time_ns, component, port, msg):
        if component == "stone" and port == "state":
            self.speed = math.hypot(float(msg.velocity[0]), float(msg.velocity[1]))
        elif component == "pond" and port == "patch" and msg.velocity.size:
            self.trace.t.append(time_ns * 1e-9)
            self.trace.surface.append(float(np.abs(msg.velocity).max()))
            self.trace.stone.append(self.speed)


def run(overrides: tuple[str, ...]) -> Trace:
    """The reference skip with ``overrides``, traced."""
    trace = Trace()
    sim = Simulation(load(ROOT / "scenarios" / "skip.yaml", ["record.visual_rate=0", *overrides]),
                     observers=[_Watch(trace)])
    sim.run()
    monitor = sim.components["stages"]
    trace.skips, trace.end = monitor.track.skips, monitor.timeline[-1][1]
    return trace


def _broken(t: list[float], values: list[float], gap: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """(t, values) with a NaN wherever the water sent no window for longer than ``gap`` [s] (the
    stone in flight) and where the window was all but still (under 1 mm/s), so that a line is drawn
    only over contacts and glides."""
    times, out = [], []
    for k, (tk, vk) in enumerate(zip(t, values, strict=True)):
        if k and tk - t[k - 1] > gap:
            times.append(0.5 * (tk + t[k - 1]))
            out.append(math.nan)
        times.append(tk)
        out.append(vk if vk >= STILL else math.nan)
    return np.array(times), np.array(out)


def figure(path: Path, traces: list[Trace], long_speed: float, ripple_speed: float) -> None:
    """Surface speed against time for every run (log scale); below, the stone's speed, the long
    waves' sqrt(g d) and the scene's ripple speed [m/s]."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8.0, 6.4), dpi=120, sharex=True,
                                      gridspec_kw={"height_ratios": (2.2, 1.0)})
    for (label, _, color), trace in zip(RUNS, traces, strict=True):
        top.semilogy(*_broken(trace.t, trace.surface), color=color, lw=1.1, label=label)
    top.set_ylim(STILL, None)
    top.set_ylabel("largest vertical surface speed\nin the stone's window [m/s]")
    top.set_title("The reference skip's water: at the long waves' speed it resonates with the gliding stone;\n"
                  "at the speed of the stone's own ripples (the scene), as in dispersive water, it does not",
                  fontsize=9.5)
    top.grid(alpha=0.3, which="both")
    top.legend(fontsize=7.5, loc="upper left")
    scene = traces[0]
    bottom.plot(scene.t, scene.stone, color="0.2", lw=1.2, label="the stone's horizontal speed (1 cm, wave)")
    bottom.axhline(long_speed, color="#8e44ad", lw=1.0, ls="--", label=f"sqrt(g d) = {long_speed:.1f} m/s")
    bottom.axhline(ripple_speed, color="#1f5f8b", lw=1.0, ls=":",
                   label=f"the scene's: a 10 cm ripple's, {ripple_speed:.2f} m/s")
    bottom.set_xlabel("time [s]")
    bottom.set_ylabel("[m/s]")
    bottom.grid(alpha=0.3)
    bottom.legend(fontsize=7.5, loc="upper right")
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--figure", type=Path, help="draw the runs into this figure (.png, .pdf or .svg)")
    args = parser.parse_args(argv)
    check_figure(parser, args.figure, "--figure")
    traces = []
    print("| water | skips | end | largest surface speed after the skips [m/s] | when [s] | "
          "the stone's speed then [m/s] |")
    print("|---|---:|---|---:|---:|---:|")
    for label, overrides, _ in RUNS:
        trace = run(overrides)
        traces.append(trace)
        after = [k for k, t in enumerate(trace.t) if t > AFTER_SKIPS]
        k = max(after, key=lambda i: trace.surface[i]) if after else None
        peak, when, speed = ((trace.surface[k], trace.t[k], trace.stone[k]) if k is not None
                             else (math.nan, math.nan, math.nan))
        print(f"| {label} | {trace.skips} | {trace.end} | {peak:.1f} | {when:.3f} | {speed:.2f} |", flush=True)
    if args.figure:
        params = load(ROOT / "scenarios" / "skip.yaml").components["pond"].params
        figure(args.figure, traces, math.sqrt(GRAVITY * params.depth), WaterSurface.wave_speed(params))
        print(f"wrote {args.figure}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
