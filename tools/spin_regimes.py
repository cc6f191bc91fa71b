"""Rosellini et al.'s three spin regimes of a free disk as one figure (docs/validation.md, section 2).

    python tools/spin_regimes.py --figure docs/figures/spin_regimes.png     # ~5 s

The aluminium disk of Clanet et al. (R = 2.5 cm, e = 2.75 mm) thrown free at 3.5 m/s through the
full co-simulation (components.analysis.experiments, every effect on): at 65 rev/s and at 10 rev/s
with impact and attack angles of 20 deg (their figs. 3 and 7), and without spin at an attack angle
of 35 deg (fig. 5). The figure is the attack angle along the motion from the touchdown to just past
the first bounce or sink, the wetted spell shaded; the table on stdout is what the validation table
holds of each.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from components.analysis import experiments as ex  # noqa: E402
from tools.options import check_figure, description, save_figure  # noqa: E402

SPEED = 3.5  # [m/s]
IMPACT = 20.0  # [deg]
REGIMES = (  # (label, attack angle [deg], spin [rev/s], what the paper reports)
    ("fig. 3: 65 rev/s", 20.0, 65.0, "the attitude hardly changes"),
    ("fig. 7: 10 rev/s", 20.0, 10.0, "the tilt dips towards 0 and recovers; it bounces"),
    ("fig. 5: no spin, 35 deg", 35.0, 0.0, "it tumbles nose-down and dives"),
)
COLORS = ("#1f5f8b", "#e67e22", "#c0392b")


def histories() -> list[ex.AttackHistory]:
    """Each regime's attack angle from touchdown to just past its first bounce or sink."""
    return [ex.attack_history(ex.throw_scene(SPEED, alpha, IMPACT, spin_rev_s=spin)) for _, alpha, spin, _ in REGIMES]


def figure(path: Path, runs: list[ex.AttackHistory]) -> None:
    """The three attack-angle histories as a PNG, each wetted spell shaded in its colour."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    fig, ax = plt.subplots(figsize=(8.0, 5.0), dpi=120)
    for (label, _, _, reported), run, color in zip(REGIMES, runs, COLORS, strict=True):
        t = run.time_s * 1e3
        ended = "bounces" if run.outcome.bounced else "sinks"
        ax.plot(t, run.attack_deg, color=color, lw=1.8, label=f"{label} ({ended}); published: {reported}")
        ax.plot(t, np.where(run.wetted, run.attack_deg, np.nan), color=color, lw=4.0, alpha=0.35)
    ax.axhline(0.0, color="0.4", lw=0.8)
    ax.set_xlabel("time since touchdown [ms]")
    ax.set_ylabel("attack angle along the motion [deg]")
    ax.set_title(f"A free aluminium disk (R = 2.5 cm) thrown at {SPEED:g} m/s, {IMPACT:g} deg "
                 "(thick: wetted)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=1, frameon=False)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--figure", type=Path, help="draw the three regimes into this figure (.png, .pdf or .svg)")
    args = parser.parse_args(argv)
    check_figure(parser, args.figure, "--figure")
    runs = histories()
    print("| regime | published | attack min / end [deg] | outcome |")
    print("|---|---|---:|---|")
    for (label, _, _, reported), run in zip(REGIMES, runs, strict=True):
        low, _, end = run.outcome.attack_deg
        print(f"| {label} | {reported} | {low:.1f} / {end:.1f} | {'bounces' if run.outcome.bounced else 'sinks'} |")
    if args.figure:
        figure(args.figure, runs)
        print(f"wrote {args.figure}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
