"""The magic angle of the force law alone: the WaterCoupler's critical speed U_min(alpha) for the
Clanet/Rosellini disk over still water, without the rest of the co-simulation.

    python tools/validate_magic_angle.py                                 # table on stdout
    python tools/validate_magic_angle.py --markdown docs/validation.md   # also (re)write its section
    python tools/validate_magic_angle.py --quick                         # fewer angles, coarser search

The disk (R = 2.5 cm, e = 2.75 mm, 2700 kg/m^3) with its attitude held (the 65 rev/s high-spin limit)
is moved by the coupler's held wrench (semi-implicit Euler at 50 us) over a fresh, still 5 mm patch
every step: no waves, no displacement, the pressure law and its companions by themselves, as in
Rosellini et al.'s model. A throw bounces when the disk leaves the water moving up after its first
contact. The default model, the full co-simulation with every effect, is in tools/validate_targets.py.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from components.analysis import experiments  # noqa: E402
from components.coupler import WaterCoupler, WaterCouplerParams  # noqa: E402
from components.coupler.fixtures import body, pitched, still_water  # noqa: E402
from cosim.docsection import replace_section  # noqa: E402
from tools.options import check_figure, check_output, description, save_figure  # noqa: E402

RADIUS = 0.025  # [m] Clanet et al.'s aluminium disk
THICKNESS = 0.00275  # [m]
ALUMINIUM = 2700.0  # [kg/m^3]
BETA_DEG = 20.0  # [deg] impact angle
GRAVITY = 9.81  # [m/s^2]
CLEARANCE = 5e-4  # [m] the lowest point starts this far above the water
PATCH_CELL = 0.005  # [m] water columns of both ways
COUPLER_DT = 5e-5  # [s] step of the coupler-only integration
SPEED_LO, SPEED_HI = 1.0, 6.0  # [m/s] bisection bracket

# Published: Clanet, Hersen & Bocquet, Nature 427, 29 (2004), the minimum of the critical speed of
# the 5 cm aluminium disk at beta = 20 deg, near alpha = 20 deg (physics.md: 2.5-2.6 m/s). The curve
# rises on both sides; its other points are not reproduced here (they are read off a plot).
PUBLISHED_ALPHA_DEG = 20.0
PUBLISHED_U_MIN = (2.5, 2.6)  # [m/s]

ALPHAS = [5.0, 7.5, 10.0, 12.5, 15.0, 17.5, 20.0, 22.5, 25.0, 27.5, 30.0, 35.0, 40.0, 45.0]
QUICK_ALPHAS = [5.0, 10.0, 20.0, 30.0, 45.0]


def _start(speed: float, alpha_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Centre [m] with the lowest point CLEARANCE above the water, and velocity [m/s] at beta."""
    alpha, beta = math.radians(alpha_deg), math.radians(BETA_DEG)
    x = np.array([0.0, 0.0, RADIUS * math.sin(alpha) + 0.5 * THICKNESS * math.cos(alpha) + CLEARANCE])
    v = np.array([speed * math.cos(beta), 0.0, -speed * math.sin(beta)])
    return x, v


def bounces_coupler(speed: float, alpha_deg: float) -> bool:
    """The coupler alone: True when the locked disk leaves still water moving up after first contact."""
    coupler = WaterCoupler("c", WaterCouplerParams())
    q = pitched(math.radians(alpha_deg))
    mass = body(radius=RADIUS, thickness=THICKNESS, density=ALUMINIUM).mass
    x, v = _start(speed, alpha_deg)
    force = np.zeros(3)
    dt_ns = round(COUPLER_DT * 1e9)
    touched = False
    for k in range(40000):
        v = v + (force / mass + np.array([0.0, 0.0, -GRAVITY])) * COUPLER_DT
        x = x + v * COUPLER_DT
        state = body(position=x, orientation=q, velocity=v, radius=RADIUS, thickness=THICKNESS,
                     density=ALUMINIUM, attitude_locked=True)
        centre = (round(x[0] / PATCH_CELL) * PATCH_CELL, 0.0)
        out = coupler.step(k * dt_ns, dt_ns, {"body": state, "water": still_water(PATCH_CELL, 0.06, centre=centre)},
                           on_unstable="substep")
        force = out["wrench"].force if "wrench" in out else force
        contact = out.get("contact")
        if contact is None:
            continue
        touched = touched or contact.wetted
        if touched and not contact.wetted:
            return bool(v[2] > 0)
        if contact.submerged_fraction >= 0.999:
            return False
    return False


def critical_speed(bounces: Callable[[float, float], bool], alpha_deg: float, step: float,
                   tol: float) -> tuple[float, list[float]]:
    """The speed [m/s] above which every throw bounces, and the slower speeds that bounce too
    (:func:`components.analysis.experiments.critical_speed` with the force law's own bounce)."""
    return experiments.critical_speed(alpha_deg, lo=SPEED_LO, hi=SPEED_HI, step=step, tol=tol, bounce=bounces)


def curve(bounces, alphas, step, tol, label):
    values, windows = [], []
    for alpha in alphas:
        t0 = time.perf_counter()
        u, below = critical_speed(bounces, alpha, step, tol)
        values.append(u)
        windows.append(below)
        extra = f"; also bounces at {', '.join(f'{w:g}' for w in below)} m/s" if below else ""
        print(f"  {label}: alpha {alpha:4.1f} deg  U_min {u:.3f} m/s{extra}  ({time.perf_counter() - t0:.1f} s)",
              file=sys.stderr)
    return np.array(values), windows


def plot(path: Path, series: list[tuple[str, list[float], np.ndarray]]) -> None:
    """The curves of ``series`` (label, alphas, U_min) beside the published minimum, as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.6, 4.4), dpi=120)
    lo, hi = PUBLISHED_U_MIN
    ax.axhspan(lo, hi, color="#f2c14e", alpha=0.35, lw=0,
               label=f"published minimum {lo}-{hi} m/s (Clanet et al. 2004)")
    ax.axvline(PUBLISHED_ALPHA_DEG, color="#b8860b", ls=":", lw=1.2, label="published magic angle, 20 deg")
    styles = [dict(marker="o", ls="-", color="#1f5f8b"),
              dict(marker="s", ls="--", color="#c0392b", mfc="none", mew=1.6),
              dict(marker="^", ls=":", color="#2e8b57", mfc="none", mew=1.6)]
    top = 6.0
    for (label, alphas, values), style in zip(series, styles, strict=False):
        ax.plot(alphas, values, label=label, ms=6, **style)
        top = max(top, float(np.nanmax(values)) + 0.5)
    ax.set_xlabel("attack angle alpha [deg]")
    ax.set_ylabel("critical speed U_min [m/s]")
    ax.set_title("Magic angle: aluminium disk R = 2.5 cm, e = 2.75 mm, beta = 20 deg", fontsize=10)
    ax.set_xlim(0, 50)
    ax.set_ylim(0, top)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7.5, loc="lower center", ncol=1)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def _windows(below: list[float], step: float) -> str:
    """Speeds that bounce below the critical one, as ranges ("2.0, 2.3-2.5")."""
    spans: list[list[float]] = []
    for u in below:
        if spans and u - spans[-1][1] < 1.5 * step:
            spans[-1][1] = u
        else:
            spans.append([u, u])
    return ", ".join(f"{a:.1f}" if a == b else f"{a:.1f}-{b:.1f}" for a, b in spans)


def table(series: list[tuple[str, list[float], tuple[np.ndarray, list[list[float]]]]], step: float) -> str:
    """A markdown table of U_min per alpha, one column per series, and the slower bouncing throws."""
    alphas = sorted({a for _, al, _ in series for a in al})
    head = "| alpha [deg] | " + " | ".join(f"U_min, {label} [m/s]" for label, _, _ in series)
    lines = [head + " | slower throws that bounce too [m/s] |",
             "|---:|" + "---:|" * len(series) + ":---|"]
    for alpha in alphas:
        cells, notes = [], []
        for label, al, (values, windows) in series:
            if alpha in al:
                k = al.index(alpha)
                cells.append(f"{values[k]:.2f}")
                if windows[k]:
                    notes.append(f"{label}: {_windows(windows[k], step)}")
            else:
                cells.append("")
        lines.append(f"| {alpha:g} | " + " | ".join(cells) + f" | {'; '.join(notes)} |")
    lines.append("")
    minima = []
    for label, al, (values, _) in series:
        k = int(np.nanargmin(values))
        minima.append(f"{values[k]:.2f} m/s at alpha = {al[k]:g} deg ({label})")
    lines.append(f"Model minimum: {'; '.join(minima)}.")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--quick", action="store_true", help="fewer angles and a coarser search")
    parser.add_argument("--figure", type=Path, help="also draw the curve in this figure (.png, .pdf or .svg)")
    parser.add_argument("--markdown", type=Path, help="rewrite the magic-angle table in this markdown file")
    args = parser.parse_args(argv)
    check_figure(parser, args.figure, "--figure")
    check_output(parser, args.markdown, "--markdown", text=True, sections=("magic-angle",))
    alphas = QUICK_ALPHAS if args.quick else ALPHAS
    step = 0.2 if args.quick else 0.1
    tol = 0.05 if args.quick else 0.01
    runs = [("force law alone", alphas, bounces_coupler)]
    results = [(label, list(al), curve(fn, al, step, tol, label)) for label, al, fn in runs]
    text = table(results, step)
    text += (f"\n\nSpeeds tried every {step:g} m/s from {SPEED_LO:g} to {SPEED_HI:g} m/s, then bisection to "
             f"{tol:g} m/s; water columns of {PATCH_CELL * 1e3:g} mm.")
    print(text)
    if args.figure is not None:
        plot(args.figure, [("force law alone, held disk, still water", al, values)
                           for _, al, (values, _) in results])
        print(f"figure: {args.figure}", file=sys.stderr)
    if args.markdown is not None:
        replace_section(args.markdown, "magic-angle", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
