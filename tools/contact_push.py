"""How hard the water pushes in each contact, as an instantaneous peak and as a sensor averaging it.

    python tools/contact_push.py            # the table of docs/validation.md section 2c (about 2-3 min)

Tang et al. (2021) give a bounce condition on the vertical acceleration a disk's on-board inertial
module measured, whose sampling and filtering are not in what was read here. The stage monitor's
``SkipRecord.peak_g`` is the model's instantaneous peak of the water's vertical force over the
weight, one value per base step. This tool gives that peak beside the largest mean over a sliding
window of 5, 10 and 20 ms (what a sensor sampling or filtering that coarsely would read), for every
contact of the throws `tools/validate_targets.py` compares with Tang et al.'s condition: the held and
reference skips, Clanet's aluminium disk held at 5, 6 and 7 m/s (alpha 15 and 20 deg, beta 10
and 15 deg), and the magic-angle throws' steep first contacts (``PEAK_THROWS``,
``STEEP_PEAK_THROWS``). Each contact is marked as one the stone bounced off or one it surfed on
until it sank.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from components.analysis import experiments as ex  # noqa: E402
from components.stages import _vertical_water_force  # noqa: E402
from cosim.scenario import Scene, load  # noqa: E402
from cosim.scheduler import Simulation  # noqa: E402
from tools.options import description  # noqa: E402
from tools.validate_targets import PEAK_THROWS, STEEP_PEAK_THROWS  # noqa: E402

WINDOWS = (0.005, 0.010, 0.020)  # [s] the sensor-like averaging windows


def window_peak(push: np.ndarray, dt: float, window: float) -> float:
    """The largest mean of ``push`` (one value per step of ``dt`` [s]) over ``window`` [s] of
    consecutive steps (round(window / dt) of them, at least one); the mean of all of it when the
    contact is shorter than the window."""
    n = max(1, round(window / dt))
    if push.size < n:
        return float(push.mean())
    sums = np.cumsum(np.concatenate(([0.0], push)))
    return float((sums[n:] - sums[:-n]).max() / n)


def contact_pushes(scene: Scene) -> list[tuple[str, np.ndarray, float]]:
    """Every contact of ``scene``'s stone whose outcome is known, in order: ("bounce" or "surf", the
    water's vertical force over the weight at each step of the contact [g], the step [s])."""
    sim = Simulation(scene)
    monitor = sim.components["stages"]
    log: list[tuple[bool, float]] = []
    inner = monitor._step_impl
    steps: list[float] = []  # the monitor's step [s]

    def step(t, dt, inputs):
        outputs = inner(t, dt, inputs)
        water, body = inputs.get("water"), inputs.get("body")
        weight = float(body.mass) * monitor.params.gravity
        log.append((monitor.track.in_contact, _vertical_water_force(water) / weight if water is not None else 0.0))
        steps.append(dt)
        return outputs

    monitor._step_impl = step
    sim.run()
    contacts, current = [], None
    for touching, push in log:
        if touching:
            current = [] if current is None else current
            current.append(push)
        elif current is not None:
            contacts.append(current)
            current = None
    if current is not None:
        contacts.append(current)
    sank = monitor.stage is not None and monitor.stage.name == "SINK" and math.isnan(monitor.left_at)
    dt = steps[0] if steps else sim.dt_ns * 1e-9
    out = []
    for k, pushes in enumerate(contacts):
        if k < len(monitor.records):
            out.append(("bounce", np.array(pushes), dt))
        elif k == len(contacts) - 1 and sank:
            out.append(("surf", np.array(pushes), dt))
    return out


def _scene(key: tuple) -> tuple[str, Scene]:
    if len(key) == 1:
        return key[0], load(ROOT / "scenarios" / f"{key[0]}.yaml", ["record.visual_rate=0"])
    speed, alpha, beta = key
    if key in STEEP_PEAK_THROWS:
        return (f"aluminium disk {speed} m/s, alpha {alpha:g}, beta {beta:g} deg (steep)",
                ex.throw_scene(*key, cell=0.01))
    return (f"aluminium disk {speed} m/s, alpha {alpha:g}, beta {beta:g} deg",
            ex.throw_scene(*key, cell=0.01, until=3.0, length=8.0))


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.parse_args(argv)  # no options: --help, and a refusal of anything else
    print("| throw | contact | peak [g] | " + " | ".join(f"{w * 1e3:g} ms mean [g]" for w in WINDOWS) + " |")
    print("|---|---|---:|" + "---:|" * len(WINDOWS))
    for key in (*PEAK_THROWS, *STEEP_PEAK_THROWS):
        name, scene = _scene(key)
        for kind, push, dt in contact_pushes(scene):
            means = " | ".join(f"{window_peak(push, dt, w):.1f}" for w in WINDOWS)
            print(f"| {name} | {kind} | {push.max():.1f} | {means} |")


if __name__ == "__main__":
    main()
