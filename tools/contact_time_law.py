"""The contact time of Rosellini et al.'s force law alone, against the attack angle (docs/validation.md).

    python tools/contact_time_law.py        # the law's tau(alpha) beside the co-simulation's (~15 s)

A point model of the held disk: the face at a fixed attack angle alpha meets a flat, still surface;
the water pushes along the face's normal with F = 1/2 rho C_L V^2 S sin(alpha + gamma) (Rosellini
et al. 2005, eq. 4.2; gamma the angle the disk moves down at, V its speed), S the circular segment of
the face below the surface (its chord a depth d / sin(alpha) from the trailing edge); gravity, nothing
else. The contact lasts from touchdown until the trailing edge leaves the surface moving up. No
friction, waves, displacement or buoyancy: what the law itself makes of the angle.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from components.analysis import experiments as ex  # noqa: E402
from components.coupler.forces import C_LIFT  # noqa: E402
from tools.options import angle_deg, description, positive_float  # noqa: E402

RHO = 1000.0  # [kg/m^3] water
GRAVITY = ex.GRAVITY  # [m/s^2]
STEP = 1e-6  # [s] semi-implicit Euler step of the point model
ANGLES = (5.0, 7.0, 10.0, 12.5, 15.0, 20.0, 25.0, 30.0, 40.0)  # [deg] attack angles shown


def segment_area(radius: float, length: float) -> float:
    """Area [m^2] of the part of a disk of ``radius`` [m] within ``length`` [m] of its edge (a circular
    segment; the whole disk from 2 radius on)."""
    length = min(max(length, 0.0), 2.0 * radius)
    h = radius - length
    return radius * radius * math.acos(h / radius) - h * math.sqrt(max(radius * radius - h * h, 0.0))


def law_contact(speed: float, alpha_deg: float, beta_deg: float, *, radius: float = ex.RADIUS,
                thickness: float = ex.THICKNESS, density: float = ex.ALUMINIUM) -> tuple[float, bool]:
    """(contact time [s], bounced) of the point model for a disk thrown at ``speed`` [m/s], impact angle
    ``beta_deg`` below the horizontal and attack angle ``alpha_deg`` [deg] held. Not bounced: still in
    the water after 0.5 s, or 5 cm under."""
    mass = density * math.pi * radius * radius * thickness
    alpha = math.radians(alpha_deg)
    ux, uz = speed * math.cos(math.radians(beta_deg)), -speed * math.sin(math.radians(beta_deg))
    z = t = 0.0  # [m] height of the trailing edge above the surface; [s] time since touchdown
    while True:
        wet = segment_area(radius, -z / math.sin(alpha)) if z < 0.0 else 0.0
        force = 0.0
        if wet > 0.0:
            gamma = math.atan2(-uz, ux)
            force = 0.5 * RHO * C_LIFT * (ux * ux + uz * uz) * wet * math.sin(alpha + gamma)
        uz += (force * math.cos(alpha) / mass - GRAVITY) * STEP
        ux -= force * math.sin(alpha) / mass * STEP
        z += uz * STEP
        t += STEP
        if z >= 0.0 and uz > 0.0:
            return t, True
        if t > 0.5 or z < -0.05:
            return t, False


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--speed", type=positive_float, default=3.5, help="[m/s] (default %(default)s)")
    parser.add_argument("--beta", type=angle_deg(0.0, 90.0), default=20.0,
                        help="impact angle, between 0 and 90 [deg] (default %(default)s)")
    args = parser.parse_args(argv)
    print(f"| alpha [deg] | the law alone [ms] | the co-simulation [ms] |  (U = {args.speed:g} m/s, "
          f"beta = {args.beta:g} deg)")
    print("|---:|---:|---:|")
    for alpha in ANGLES:
        tau, bounced = law_contact(args.speed, alpha, args.beta)
        run = ex.run_throw(ex.throw_scene(args.speed, alpha, args.beta))
        law = f"{tau * 1e3:.1f}" if bounced else "no bounce"
        cosim = f"{run.contact_s * 1e3:.1f}" if run.bounced else "no bounce"
        print(f"| {alpha:g} | {law} | {cosim} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
