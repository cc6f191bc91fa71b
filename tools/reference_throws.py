"""The reference skip beside the same throw held and the same throw with a thin slate, as one figure
(docs/validation.md, section 2).

    python tools/reference_throws.py --figure docs/figures/reference_throws.png     # ~10 s

Three runs of ``scenarios/skip.yaml`` (recording off) on a pond long and wide enough that none leaves
it: as written (the 15 mm stone free, spun at 12 rev/s), with its attitude held (the infinite-spin
limit), and with a 6 mm slate instead (free, 12 rev/s). The figure is each path seen from the side
and from above; the table on stdout gives each one's skips, take-off angles and where it sank.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from cosim.scenario import load  # noqa: E402
from cosim.scheduler import Simulation  # noqa: E402
from tools.options import check_figure, description, save_figure  # noqa: E402
from tools.validate_scenes import Watch  # noqa: E402

SCENE = ROOT / "scenarios" / "skip.yaml"
START_Y = 2.0  # [m] the throw's line, mid-pond
POND = ["components.pond.nx=2400", "components.pond.ny=400", f"components.stone.position=[0.3, {START_Y}, 0.10]",
        "record.visual_rate=0"]  # 24 m x 4 m: the held throw planes on for 20 m
THROWS = (  # (label, overrides)
    ("reference skip: 15 mm, free, 12 rev/s", []),
    ("the same held (infinite spin)", ["components.stone.lock_attitude=true", "components.stone.spin=0"]),
    ("a 6 mm slate, free, 12 rev/s", ["components.stone.thickness=0.006"]),
)
COLORS = ("#1f5f8b", "#7f8c8d", "#c0392b")


@dataclass
class Path3:
    """A run's stone positions (n, 3) [m] and its stage monitor."""

    position: np.ndarray
    stages: object


def throw(overrides: list[str]) -> Path3:
    """The reference skip with ``overrides`` on the long pond, run to its end."""
    watch = Watch(["stone.state"])
    sim = Simulation(load(SCENE, [*POND, *overrides]), observers=[watch])
    sim.run()
    return Path3(np.array([state.position for _, state in watch.seen["stone.state"]], dtype=float),
                 sim.components["stages"])


def table(runs: list[Path3]) -> str:
    rows = ["| throw | skips | take-off angles [deg] | end |", "|---|---:|---|---|"]
    for (label, _), run in zip(THROWS, runs, strict=True):
        takeoffs = ", ".join(f"{r.takeoff_angle_deg:.1f}" for r in run.stages.records) or "-"
        end = run.stages.timeline[-1][1]
        x, y = run.position[-1, :2]
        where = f"{end} at x = {x:.1f} m, y = {y - START_Y:+.2f} m"
        rows.append(f"| {label} | {run.stages.track.skips} | {takeoffs} | {where} |")
    return "\n".join(rows)


def figure(path: Path, runs: list[Path3]) -> None:
    """Side view and view from above of the three paths, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (side, above) = plt.subplots(2, 1, figsize=(10.0, 6.5), dpi=110, sharex=True)
    for (label, _), run, color in zip(THROWS, runs, COLORS, strict=True):
        p = run.position
        n = run.stages.track.skips
        text = f"{label}: {n} skip{'' if n == 1 else 's'}"
        side.plot(p[:, 0], p[:, 2], color=color, lw=1.6, label=text)
        above.plot(p[:, 0], p[:, 1] - START_Y, color=color, lw=1.6)
    side.axhline(0.0, color="#3a7bd5", lw=0.8, ls="--")
    side.set_ylabel("height z [m]")
    side.set_title("The reference throw (11 m/s, 6 deg down, nose up 8 deg) three ways", fontsize=10)
    side.legend(fontsize=8, loc="upper right")
    above.set_xlabel("x [m]")
    above.set_ylabel("sideways y [m] (left +)")
    above.set_title("seen from above (y to its own scale)", fontsize=9)
    for ax in (side, above):
        ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--figure", type=Path, help="draw the three paths into this figure (.png, .pdf or .svg)")
    args = parser.parse_args(argv)
    check_figure(parser, args.figure, "--figure")
    runs = [throw(overrides) for _, overrides in THROWS]
    print(table(runs))
    if args.figure is not None:
        figure(args.figure, runs)
        print(f"wrote {args.figure}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
