"""The magic angle: the model's critical speed U_min(alpha) beside Clanet, Hersen & Bocquet (2004).

    python tools/validate_magic_angle.py                         # table on stdout, figure
    python tools/validate_magic_angle.py --markdown docs/validation.md   # also (re)write its table
    python tools/validate_magic_angle.py --quick                 # fewer angles, coarser bisection

The experiment (Nature 427, 29, 2004; Rosellini et al., J. Fluid Mech. 543, 137, 2005): an aluminium
disk (R = 2.5 cm, e = 2.75 mm, 2700 kg/m^3) spun at 65 rev/s, so its attitude hardly changes during
contact, thrown at the water with impact angle beta = 20 deg (velocity below the horizontal) and
attack angle alpha (face nose-up). Below a critical speed U_min(alpha) it does not bounce; U_min is
lowest, about 2.5 m/s, near alpha = 20 deg (the "magic angle") and rises on both sides.

Here the spin is represented by ``lock_attitude`` (the high-spin limit). For each alpha the critical
speed is bisected between a speed that sinks and one that bounces, two ways:

* **coupler**: the WaterCoupler alone, driven with a locked body moved by its held wrench
  (semi-implicit Euler at 50 us) over a fresh, still 5 mm patch every step (no waves, no
  displacement: the force law by itself);
* **co-simulation**: the full scene, RigidBody + WaterSurface (5 mm columns) + WaterCoupler (all
  five effects) + StageMonitor, through the scheduler, as any scene runs.

A throw bounces when the stone leaves the water moving up after its first contact (coupler), or
when the stage monitor records a fly-away before a sink (co-simulation). U_min is the speed above
which every throw bounces; a few slower throws can bounce too (listed), since a stone that does not
take off at once can plane along the surface instead.
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

from components.coupler import WaterCoupler, WaterCouplerParams  # noqa: E402
from components.coupler.fixtures import body, pitched, still_water  # noqa: E402
from cosim.docsection import replace_section  # noqa: E402
from cosim.scenario import loads  # noqa: E402
from cosim.scheduler import Simulation  # noqa: E402

RADIUS = 0.025  # [m] Clanet et al.'s aluminium disk
THICKNESS = 0.00275  # [m]
ALUMINIUM = 2700.0  # [kg/m^3]
BETA_DEG = 20.0  # [deg] impact angle
GRAVITY = 9.81  # [m/s^2]
CLEARANCE = 5e-4  # [m] the lowest point starts this far above the water
COSIM_DROP = 0.01  # [m] and, in the co-simulation, this much higher (see _start)
PATCH_CELL = 0.005  # [m] water columns of both ways
COUPLER_DT = 5e-5  # [s] step of the coupler-only integration
SCENE_DT = 1e-4  # [s] base step of the co-simulation (the coupler substeps where it must)
SPEED_LO, SPEED_HI = 1.0, 6.0  # [m/s] bisection bracket

# Published: Clanet, Hersen & Bocquet, Nature 427, 29 (2004), the minimum of the critical speed of
# the 5 cm aluminium disk at beta = 20 deg, near alpha = 20 deg (physics.md: 2.5-2.6 m/s). The curve
# rises on both sides; its other points are not reproduced here (they are read off a plot).
PUBLISHED_ALPHA_DEG = 20.0
PUBLISHED_U_MIN = (2.5, 2.6)  # [m/s]

ALPHAS = [5.0, 7.5, 10.0, 12.5, 15.0, 17.5, 20.0, 22.5, 25.0, 27.5, 30.0, 35.0, 40.0, 45.0]
COSIM_ALPHAS = [5.0, 10.0, 15.0, 20.0, 25.0, 30.0, 40.0, 45.0]
QUICK_ALPHAS = [5.0, 10.0, 20.0, 30.0, 45.0]
QUICK_COSIM_ALPHAS = [10.0, 20.0, 30.0]


def _start(speed: float, alpha_deg: float, drop: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Centre [m] and velocity [m/s] of a throw that meets the water at ``speed`` and beta.

    The lowest point starts CLEARANCE + ``drop`` above the water, with the vertical speed that
    gravity brings to U sin(beta) over the drop: the full co-simulation drops from 1 cm so that the
    water has delivered its first patch (a few water steps) before the stone arrives.
    """
    alpha, beta = math.radians(alpha_deg), math.radians(BETA_DEG)
    height = CLEARANCE + drop
    x = np.array([0.0, 0.0, RADIUS * math.sin(alpha) + 0.5 * THICKNESS * math.cos(alpha) + height])
    vz = math.sqrt(max((speed * math.sin(beta)) ** 2 - 2.0 * GRAVITY * drop, 0.0))
    v = np.array([speed * math.cos(beta), 0.0, -vz])
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


SCENE = """
name: magic_angle_throw
dt: {dt}
until: 1.0
on_unstable: substep
components:
  stone:
    type: RigidBody
    shape: disk
    radius: {radius}
    thickness: {thickness}
    density: {density}
    position: [{x[0]}, {x[1]}, {x[2]}]
    velocity: [{v[0]}, {v[1]}, {v[2]}]
    tilt_deg: {alpha}
    lock_attitude: true
  pond:
    type: WaterSurface
    nx: {nx}
    ny: {ny}
    cell: {cell}
    depth: 0.3
    origin_x: {ox}
    origin_y: {oy}
    boundary: absorbing
    every: {water_every}
  coupler:
    type: WaterCoupler
    effects: [{effects}]
  stages:
    type: StageMonitor
    stop_after: 0.0
connections:
  - stone.state -> coupler.body
  - pond.patch -> coupler.water
  - {{from: coupler.wrench, to: stone.wrench, delay: 1, initial: {{force: [0, 0, 0], torque: [0, 0, 0]}}}}
  - {{from: coupler.occupied, to: pond.occupied, delay: 1, initial: {{i0: 0, j0: 0, b: []}}}}
  - {{from: coupler.request, to: pond.request, delay: 1, initial: {{x_min: 1, x_max: 0, y_min: 1, y_max: 0}}}}
  - stone.state -> stages.body
  - coupler.contact -> stages.water
"""


ALL_EFFECTS = ["displacement", "buoyancy", "pressure", "friction", "wave_drag"]
NO_DISPLACEMENT = ALL_EFFECTS[1:]


def throw_scene(speed: float, alpha_deg: float, cell: float = PATCH_CELL, effects: list[str] = ALL_EFFECTS):
    """The full co-simulation of one throw: a 0.8 m x 0.2 m pond of ``cell`` columns under the disk."""
    x, v = _start(speed, alpha_deg, drop=COSIM_DROP)
    length, width = 0.8, 0.2  # [m] the contact lasts a few centimetres of travel
    nx, ny = round(length / cell), round(width / cell)
    wave_speed = math.sqrt(GRAVITY * 0.3)
    water_every = max(1, math.floor(0.5 * cell / wave_speed / SCENE_DT))  # c dt / s <= 0.5
    text = SCENE.format(dt=SCENE_DT, radius=RADIUS, thickness=THICKNESS, density=ALUMINIUM, x=x.tolist(),
                        v=v.tolist(), alpha=alpha_deg, nx=nx, ny=ny, cell=cell, ox=-0.1 + 0.5 * cell,
                        oy=-0.5 * width + 0.5 * cell, water_every=water_every, effects=", ".join(effects))
    return loads(text, source="magic_angle_throw")


def bounces_cosim(speed: float, alpha_deg: float, effects: list[str] = ALL_EFFECTS) -> bool:
    """The full co-simulation: True when the stage monitor records a fly-away before a sink."""
    sim = Simulation(throw_scene(speed, alpha_deg, effects=effects))
    sim.initialize()
    stages = sim.components["stages"]
    end = sim.scene.until_ns
    while sim.time_ns < end:
        sim.step()
        if stages.track.skips:
            return True
        if stages.stage is not None and stages.stage.name == "SINK":
            return False
    return False


def critical_speed(bounces: Callable[[float, float], bool], alpha_deg: float, step: float,
                   tol: float) -> tuple[float, list[float]]:
    """The speed [m/s] above which every throw bounces, and the slower speeds that bounce too.

    The speeds SPEED_LO, SPEED_LO + step, ..., SPEED_HI are all tried (a throw need not bounce at
    every speed above one that does: a stone can also plane without taking off); the critical speed
    is then bisected to ``tol`` between the fastest one that does not bounce and the next. NaN if
    even SPEED_HI does not bounce.
    """
    grid = np.round(np.arange(SPEED_LO, SPEED_HI + 0.5 * step, step), 6)
    results = [bounces(float(u), alpha_deg) for u in grid]
    if not results[-1]:
        return math.nan, []
    fails = [float(u) for u, ok in zip(grid, results, strict=True) if not ok]
    if not fails:
        return float(grid[0]), []
    lo = fails[-1]
    windows = [float(u) for u, ok in zip(grid, results, strict=True) if ok and u < lo]
    hi = lo + step
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        if bounces(mid, alpha_deg):
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi), windows


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
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
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
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer angles and a coarser search")
    parser.add_argument("--figure", type=Path, default=ROOT / "docs" / "figures" / "magic_angle.png")
    parser.add_argument("--markdown", type=Path, help="rewrite the magic-angle table in this markdown file")
    args = parser.parse_args(argv)
    alphas = QUICK_ALPHAS if args.quick else ALPHAS
    cosim_alphas = QUICK_COSIM_ALPHAS if args.quick else COSIM_ALPHAS
    step = 0.2 if args.quick else 0.1
    tol = 0.05 if args.quick else 0.01
    runs = [
        ("coupler", alphas, bounces_coupler),
        ("co-simulation", cosim_alphas, bounces_cosim),
        ("co-simulation, displacement off", cosim_alphas,
         lambda u, a: bounces_cosim(u, a, effects=NO_DISPLACEMENT)),
    ]
    results = [(label, list(al), curve(fn, al, step, tol, label)) for label, al, fn in runs]
    text = table(results, step)
    text += (f"\n\nSpeeds tried every {step:g} m/s from {SPEED_LO:g} to {SPEED_HI:g} m/s, then bisection to "
             f"{tol:g} m/s; water columns of {PATCH_CELL * 1e3:g} mm.")
    print(text)
    labels = {"coupler": "model: coupler alone, locked disk, still water",
              "co-simulation": "model: full co-simulation, all five effects",
              "co-simulation, displacement off": "model: full co-simulation, displacement off"}
    plot(args.figure, [(labels[label], al, values) for label, al, (values, _) in results])
    print(f"figure: {args.figure}", file=sys.stderr)
    if args.markdown is not None:
        replace_section(args.markdown, "magic-angle", text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
