"""How much vertical speed a held disk's planing contacts give back, in a point model of the planing
law, with and without a lag of the water piled up ahead of the face (docs/validation.md, section 2).

    python tools/planing_lag.py          # about 10 s
    python tools/planing_lag.py --exit   # and the lag on the way out only
    python tools/planing_lag.py --held-angle   # and the impact angle held through each contact

Not the co-simulation: the disk's attitude is held, the water flat and still, and only the two laws
that decide a bounce act on it, the coupler's planing pressure 1/2 rho C_L |u| (u.n) S and its skin
friction 1/2 rho C_f |u| u_t S on the wetted segment S of the lower face (components/coupler/
forces.py), besides gravity. It reproduces the co-simulation's single contacts closely (the
aluminium disk at 3.5 m/s, alpha = beta = 20 deg: a 37 ms contact and a steepest bouncing impact of
40 deg, against 36.8 ms and 40 deg in the validation table), so it shows cheaply what a change of
the law would do before the co-simulation is changed.

The lag. The water a planing face meets rises ahead of it (Wagner 1932: in two dimensions the
wetted width is pi/2 times the geometric one), and the measured C_L holds that rise for a contact
as it comes. The rise is made of water the face met while the flow crossed the wetted length, so it
follows the depth with a delay of about that crossing time; Hewitt, Balmforth & McElwaine (J. Fluid
Mech. 669, 2011) found such a time-varying rise ahead of a planing paddle to be what keeps it
skipping. Here the depth the law reads is d + kappa (d_lag - d), d_lag relaxing towards d over
ell / U (ell the wetted length along the face, U the horizontal speed), kappa = pi/2 - 1.

The lag on the way out only (``--exit``): the entry as the law has it, and while the face rises the
water it pushed up falls away over the same crossing time, the depth read then d + kappa
max(d_held - d, 0), d_held the depth the face went to, relaxing towards d over ell / U.

The impact angle held (``--held-angle``): the law's normal speed read as |u| sin(alpha + beta_in),
beta_in the angle the disk met the water at, through the whole contact, as in the models that take
U and beta to stay as they were at the impact (Bocquet 2003's elastic contact, where the lift follows
the depth alone). The law as the coupler has it reads the normal speed as it is, so a face going
in is pushed harder than one coming out: the heave damping that gives back part of the vertical
speed. Held, the contact gives back nearly all of it, and the magic angle goes: the lowest speed
that bounces falls to about 1 m/s, at about 10 deg (docs/validation.md, section 2).
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from components.coupler.forces import (  # noqa: E402
    C_FRICTION,
    C_LIFT,
    GRAVITY,
    RHO_WATER,
    friction_factor,
    pressure_magnitude,
    segment_area,
)
from tools.options import description  # noqa: E402

WAGNER_RISE = math.pi / 2.0 - 1.0  # the 2-D pile-up ahead of a flat face over its geometric depth [-]
DT = 2e-5  # [s] the point model's step (semi-implicit Euler)


@dataclass(frozen=True)
class Disk:
    radius: float  # [m]
    thickness: float  # [m]
    density: float  # [kg/m^3]

    @property
    def mass(self) -> float:
        return self.density * math.pi * self.radius ** 2 * self.thickness


MAGIC_DISK = Disk(0.025, 0.00275, 2700.0)  # Clanet et al.'s aluminium disk
REFERENCE_STONE = Disk(0.05, 0.015, 2650.0)  # scenarios/skip.yaml's slate


@dataclass
class Contact:
    t_in: float  # [s]
    t_out: float
    vx_in: float  # [m/s]
    vz_in: float  # [m/s], negative going down
    vx_out: float
    vz_out: float


def throw(disk: Disk, speed: float, impact_deg: float, attack_deg: float, rise: float = 0.0,
          t_end: float = 3.0, exit_only: bool = False, held_angle: bool = False) -> tuple[list[Contact], str]:
    """The held disk thrown at ``speed`` [m/s], ``impact_deg`` below the horizontal, nose up by
    ``attack_deg``, touching the water at once: its contacts, and how it ended ("bounced on",
    "sank": its whole face under, "planes": a contact longer than a second, or "flying" at t_end).
    ``rise``: the pile-up's share kappa (0: the coupler's law as it is); ``exit_only``: lagged only
    while the face rises; ``held_angle``: the normal speed the law reads keeps the direction of the
    touchdown through each contact (the module's text)."""
    a = math.radians(attack_deg)
    nx, nz = math.sin(a), -math.cos(a)  # the lower face's outward normal (nose up along +x)
    mass = disk.mass
    vx, vz = speed * math.cos(math.radians(impact_deg)), -speed * math.sin(math.radians(impact_deg))
    depth = lagged = t = 0.0  # depth [m] of the lowest point under the surface
    contacts: list[Contact] = []
    entry: tuple[float, float, float] | None = None
    held_sin = 0.0  # sin(alpha + beta) at the contact's touchdown (held_angle)
    while t < t_end:
        if not rise:
            read = depth
        elif exit_only:
            read = depth + rise * max(lagged - depth, 0.0) if vz > 0.0 else depth
        else:
            read = depth + rise * (lagged - depth)
        fx = fz = 0.0
        if read > 0.0:
            wetted = min(read / math.sin(a), 2.0 * disk.radius)
            area = segment_area(disk.radius, wetted)
            speed_now = math.hypot(vx, vz)
            un = vx * nx + vz * nz
            if entry is None:
                held_sin = un / speed_now
            law_un = speed_now * held_sin if held_angle else un
            p = pressure_magnitude(speed_now, law_un, RHO_WATER, C_LIFT, 0.0)  # 0 unless the face advances
            fx, fz = -p * area * nx, -p * area * nz
            friction = friction_factor(speed_now, RHO_WATER, C_FRICTION) * area
            fx -= friction * (vx - un * nx)
            fz -= friction * (vz - un * nz)
            if entry is None:
                entry = (t, vx, vz)
            if depth / math.sin(a) > 2.0 * disk.radius + disk.thickness:
                return contacts, "sank"
        elif entry is not None:
            contacts.append(Contact(entry[0], t, entry[1], entry[2], vx, vz))
            entry = None
            if vz <= 0.0:
                return contacts, "sank"
        if rise and exit_only:
            if vz <= 0.0:
                lagged = max(depth, 0.0)  # going in: the depth as it is, held once the face rises
            else:
                wetted = max(min(max(lagged, 1e-9) / math.sin(a), 2.0 * disk.radius), 1e-6)
                lagged += (depth - lagged) * min(DT * max(vx, 1e-6) / wetted, 1.0)
        elif rise and depth > 0.0:
            wetted = max(min(depth / math.sin(a), 2.0 * disk.radius), 1e-6)
            lagged += (depth - lagged) * min(DT * max(vx, 1e-6) / wetted, 1.0)
        elif depth <= 0.0:
            lagged = 0.0
        vx += fx / mass * DT
        vz += (fz / mass - GRAVITY) * DT
        depth -= vz * DT
        t += DT
        if entry is not None and t - entry[0] > 1.0:
            return contacts, "planes"
    return contacts, "flying"


def bounces(disk: Disk, speed: float, impact_deg: float, attack_deg: float, rise: float,
            exit_only: bool = False, held_angle: bool = False) -> bool:
    return bool(throw(disk, speed, impact_deg, attack_deg, rise, t_end=0.5, exit_only=exit_only,
                      held_angle=held_angle)[0])


def u_min(attack_deg: float, rise: float, exit_only: bool = False, held_angle: bool = False) -> float:
    """The magic-angle disk's lowest speed [m/s] that bounces at beta = 20 deg (bisected between
    0.5 and 6 m/s)."""
    lo, hi = 0.5, 6.0
    for _ in range(24):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if bounces(MAGIC_DISK, mid, 20.0, attack_deg, rise, exit_only, held_angle) else (mid, hi)
    return hi


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--exit", action="store_true", help="also the variant with the rise lagged on the way out only")
    parser.add_argument("--held-angle", action="store_true",
                        help="also the variant with the impact angle held through each contact")
    args = parser.parse_args(argv)
    variants = [("the coupler's law", 0.0, False, False),
                (f"with the lagged rise, kappa = {WAGNER_RISE:.2f}", WAGNER_RISE, False, False)]
    if args.exit:
        variants.append((f"with the rise lagged on the way out only, kappa = {WAGNER_RISE:.2f}", WAGNER_RISE,
                         True, False))
    if args.held_angle:
        variants.append(("with the impact angle held through each contact", 0.0, False, True))
    for label, rise, exit_only, held_angle in variants:
        options = dict(exit_only=exit_only, held_angle=held_angle)
        single, _ = throw(MAGIC_DISK, 3.5, 20.0, 20.0, rise, t_end=0.5, **options)
        steepest = max(b for b in range(20, 70, 5) if bounces(MAGIC_DISK, 3.5, b, 20.0, rise, **options))
        contacts, _ = throw(REFERENCE_STONE, 11.0, 6.0, 8.0, rise, **options)
        given_back = [-c.vz_out / c.vz_in for c in contacts]
        flights = [b.t_in - a.t_out for a, b in itertools.pairwise(contacts)]
        ratios = [b / a for a, b in itertools.pairwise(flights)]
        losses = [c.vx_in ** 2 + c.vz_in ** 2 - c.vx_out ** 2 - c.vz_out ** 2 for c in contacts]
        print(f"{label}:")
        contact_ms = 1e3 * (single[0].t_out - single[0].t_in)
        print(f"  magic-angle disk, 3.5 m/s, alpha = beta = 20 deg: contact {contact_ms:.1f} ms, "
              f"steepest bouncing impact {steepest} deg")
        print("  U_min [m/s] at alpha = 10, 15, 20, 25, 30, 40 deg: "
              + ", ".join(f"{u_min(alpha, rise, **options):.2f}" for alpha in (10, 15, 20, 25, 30, 40)))
        print(f"  reference stone held, 11 m/s, 6 deg down, attack 8 deg: {len(contacts)} contacts; vertical speed "
              "given back " + ", ".join(f"{g:.2f}" for g in given_back[:6]))
        print("    each flight over the one before: " + ", ".join(f"{r:.2f}" for r in ratios[:6])
              + "; V^2 lost per contact [m^2/s^2]: " + ", ".join(f"{v:.1f}" for v in losses[:6]))


if __name__ == "__main__":
    main()
