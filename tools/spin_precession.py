"""How far each contact turns the spin axis of the thin slate thrown free, at a range of spins
(docs/validation.md, section 2).

    python tools/spin_precession.py                                  # the table on stdout (about 5 s)
    python tools/spin_precession.py --markdown docs/validation.md    # also rewrite its section
    python tools/spin_precession.py --throws                         # skips of 120 free throws (under a minute)
    python tools/spin_precession.py --lake                           # the lake's throw free (~1 min)

The held skip's throw (scenarios/held_skip.yaml: the 6 mm slate at 20 deg) with its attitude free
and a spin about its axis, on a pond 4 m wide. For each spin: the skips; per contact, the turn of
the spin axis about the vertical (the azimuth of its tilt, degrees), its tilt from the vertical
after the contact, and the lever arm of the water's torque: the part of the torque impulse across
the axis over the force impulse along it (mm), the distance from the centre at which the planing
load acts on average.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from components.rigid.quaternion import body_axis  # noqa: E402
from cosim.docsection import replace_section  # noqa: E402
from cosim.scenario import load  # noqa: E402
from cosim.scheduler import BaseObserver, Simulation  # noqa: E402
from tools.options import check_figure, check_output, description, save_figure  # noqa: E402

SPINS = [10.0, 14.0, 20.0, 30.0, 45.0, 65.0]  # [rev/s]
CONTACTS_SHOWN = 3
MERGE_GAP = 0.01  # [s] a dry spell shorter than this inside a contact is a flicker, not a bounce


@dataclass
class Contact:
    """One wetted spell of the stone: its start and end [s], the force and torque impulses [N s],
    [N m s] and the axis before and after (unit vectors)."""

    start: float
    end: float = math.nan
    force: np.ndarray = field(default_factory=lambda: np.zeros(3))
    torque: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axis_before: np.ndarray | None = None
    axis_after: np.ndarray | None = None
    spin_before: float = math.nan  # angular momentum about the axis [kg m^2/s]
    spin_after: float = math.nan
    tilt_min: float = math.nan  # the axis's smallest angle from the vertical while wetted [deg]


class ContactLog(BaseObserver):
    """Collects the coupler's wrench over each wetted spell and the stone's axis around it."""

    def __init__(self, dt: float):
        self.dt = dt
        self.contacts: list[Contact] = []
        self.axis = np.array([0.0, 0.0, 1.0])
        self.spin = math.nan
        self.wetted = False

    def on_exchange(self, time_ns: int, component: str, port: str, msg) -> None:
        t = time_ns * 1e-9
        if component == "stone" and port == "state":
            self.axis = np.asarray(body_axis(msg.orientation), dtype=float)
            self.spin = float(msg.inertia[2] * np.dot(msg.angular_velocity, self.axis))
            last = self.contacts[-1] if self.contacts else None
            if last is not None and self.wetted:
                last.tilt_min = min(last.tilt_min, tilt_deg(self.axis))
            if last is not None and last.axis_after is None and not self.wetted and t - last.end >= MERGE_GAP:
                last.axis_after, last.spin_after = self.axis, self.spin
        elif component == "coupler" and port == "contact":
            if msg.wetted and not self.wetted:
                last = self.contacts[-1] if self.contacts else None
                if last is not None and t - last.end < MERGE_GAP:
                    last.end, last.axis_after = math.nan, None  # a flicker: the same contact goes on
                else:
                    self.contacts.append(Contact(t, axis_before=self.axis, spin_before=self.spin,
                                                 tilt_min=tilt_deg(self.axis)))
            elif not msg.wetted and self.wetted:
                self.contacts[-1].end = t
            self.wetted = msg.wetted
        elif component == "coupler" and port == "wrench" and self.wetted:
            self.contacts[-1].force += msg.force * self.dt
            self.contacts[-1].torque += msg.torque * self.dt


def azimuth_deg(axis: np.ndarray) -> float:
    """Direction [deg] of the axis's horizontal part (where the face leans), 0 for a nose-up throw."""
    return math.degrees(math.atan2(axis[1], -axis[0]))


def tilt_deg(axis: np.ndarray) -> float:
    """Angle [deg] of the axis from the vertical (the face's angle to the horizontal)."""
    return math.degrees(math.acos(max(-1.0, min(1.0, float(axis[2])))))


def free_throw_scene(spin_rev_s: float, *overrides: str):
    """The held skip's throw with a free attitude and ``spin_rev_s``, on a pond wide enough (4 m) for
    the curve the spin gives, without viewer channels; ``overrides`` as ``cosim run --set``."""
    sets = ["components.stone.lock_attitude=false", f"components.stone.spin={2 * math.pi * spin_rev_s!r}",
            "components.stone.position=[0.3, 2.0, 0.15]", "components.pond.ny=400", "record.visual_rate=0",
            *overrides]
    return load(ROOT / "scenarios" / "held_skip.yaml", sets)


def free_throw(spin_rev_s: float) -> tuple[int, list[Contact]]:
    """Skips and contacts of the thin slate thrown free at ``spin_rev_s``."""
    return logged_run(free_throw_scene(spin_rev_s))


def logged_run(scene) -> tuple[int, list[Contact]]:
    """Skips and contacts of ``scene`` run to its end."""
    log = ContactLog(scene.dt)
    sim = Simulation(scene, observers=[log])
    sim.run()
    return sim.components["stages"].track.skips, log.contacts


LAKE_SPINS = (65.0, 150.0)  # [rev/s] the experiments' spin, and more than twice it


def lake_throw(spin_rev_s: float, *overrides: str) -> tuple[int, list[Contact]]:
    """Skips and contacts of scenarios/lake.yaml's throw (the 6 mm slate at 18 m/s) with its
    attitude free and ``spin_rev_s``, on the lake made 24 m wide so that no curving throw leaves it."""
    return logged_run(load(ROOT / "scenarios" / "lake.yaml",
                           ["components.stone.lock_attitude=false",
                            f"components.stone.spin={2 * math.pi * spin_rev_s!r}", "components.lake.ny=2400",
                            "components.lake.origin_y=-12.0", "record.visual_rate=0", *overrides]))


def lake_table() -> str:
    """Per contact of the lake's throw, free at LAKE_SPINS, with every effect and with the pressure
    alone: what turns the axis."""
    rows = [header("spin [rev/s] | effects | skips")]
    for spin in LAKE_SPINS:
        for label, overrides in (("all", ()), ("pressure alone", ('components.coupler.effects=["pressure"]',))):
            skips, contacts = lake_throw(spin, *overrides)
            rows.append(f"| {spin:g} | {label} | {skips} | " + contact_cells(contacts) + " |")
    return "\n".join(rows)


def axis_moved_deg(c: Contact) -> float:
    """Angle [deg] between the axis before and after a contact: how far the spin's angular momentum
    turned (its turn about the vertical is this over the sine of the tilt, larger where the tilt is small)."""
    assert c.axis_before is not None and c.axis_after is not None
    return math.degrees(math.acos(max(-1.0, min(1.0, float(np.dot(c.axis_before, c.axis_after))))))


def lever_m(c: Contact) -> float:
    """Lever arm [m] of the water's torque: torque impulse across the axis over force impulse along it."""
    n = c.axis_before
    along = float(np.dot(c.force, n))
    across = c.torque - np.dot(c.torque, n) * n
    return float(np.linalg.norm(across)) / along if along > 0 else math.nan


class AttitudeTrace(BaseObserver):
    """The stone's axis at every state it publishes until ``until`` [s], and whether it is wetted."""

    def __init__(self, until: float):
        self.until = until
        self.times: list[float] = []
        self.axes: list[np.ndarray] = []
        self.wet: list[bool] = []
        self.wetted = False

    def on_exchange(self, time_ns: int, component: str, port: str, msg) -> None:
        t = time_ns * 1e-9
        if component == "coupler" and port == "contact":
            self.wetted = bool(msg.wetted)
        elif component == "stone" and port == "state" and t <= self.until:
            self.times.append(t)
            self.axes.append(np.asarray(body_axis(msg.orientation), dtype=float))
            self.wet.append(self.wetted)


def first_contact_trace(spin_rev_s: float, until: float = 0.16) -> AttitudeTrace:
    """The thin slate's axis, thrown free, from its release through its first contact (0.074-0.12 s)."""
    trace = AttitudeTrace(until)
    Simulation(free_throw_scene(spin_rev_s, f"until={until!r}"), observers=[trace]).run()
    return trace


FIGURE_SPINS = [10.0, 14.0, 30.0, 65.0]  # [rev/s]


def figure(path: Path, spins: list[float] = FIGURE_SPINS) -> None:
    """The axis through the first contact at each spin, as a PNG: its tilt from the vertical against
    time, and the path of its tip seen from above (a lean of 20 deg towards -x, the back of the
    throw, before the contact)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_t, ax_p) = plt.subplots(1, 2, figsize=(10.0, 4.3), dpi=120)
    colors = ["#c0392b", "#e67e22", "#1f5f8b", "#27ae60"]
    for spin, color in zip(spins, colors, strict=False):
        trace = first_contact_trace(spin)
        t = np.array(trace.times) * 1e3
        axes = np.array(trace.axes)
        wet = np.array(trace.wet)
        ax_t.plot(t, [tilt_deg(a) for a in axes], color=color, lw=1.6, label=f"{spin:g} rev/s")
        tip = np.degrees(np.arcsin(np.clip(axes[:, :2], -1.0, 1.0)))  # the tip's lean along x and y [deg]
        ax_p.plot(tip[:, 0], tip[:, 1], color=color, lw=1.0, alpha=0.5)
        ax_p.plot(np.where(wet, tip[:, 0], np.nan), np.where(wet, tip[:, 1], np.nan), color=color, lw=2.2,
                  label=f"{spin:g} rev/s")
        ax_p.plot(tip[-1, 0], tip[-1, 1], "o", color=color, ms=4)
    wetted = [k for k, w in enumerate(trace.wet) if w]
    if wetted:
        ax_t.axvspan(trace.times[wetted[0]] * 1e3, trace.times[wetted[-1]] * 1e3, color="#9ecae1", alpha=0.35,
                     lw=0, label=f"first contact ({spins[-1]:g} rev/s)")
    ax_t.set_xlabel("time [ms]")
    ax_t.set_ylabel("tilt of the axis from the vertical [deg]")
    ax_t.set_title("Tilt through the first contact", fontsize=10)
    ax_t.grid(alpha=0.3)
    ax_t.legend(fontsize=8)
    ring = np.linspace(0.0, 2.0 * math.pi, 200)
    ax_p.plot(20.0 * np.cos(ring), 20.0 * np.sin(ring), color="0.6", ls=":", lw=1.0, label="tilt 20 deg")
    ax_p.plot(0.0, 0.0, "+", color="0.3")
    ax_p.set_aspect("equal")
    ax_p.set_xlabel("lean of the axis along the throw (x) [deg]")
    ax_p.set_ylabel("lean across it (y) [deg]")
    ax_p.set_title("Path of the axis seen from above (thick: wetted; dot: 0.16 s)", fontsize=10)
    ax_p.grid(alpha=0.3)
    ax_p.legend(fontsize=8, loc="upper right")
    fig.suptitle("Thin slate thrown free (R = 5 cm, 6 mm, 8 m/s, attack 20 deg): the water's torque turns "
                 "the spin axis", fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)
    plt.close(fig)


def contact_row(c: Contact) -> str:
    """'turn about the vertical / axis moved / tilt: lowest, after / lever' of one contact."""
    if c.axis_after is None:
        return "never leaves the water"
    turn = (azimuth_deg(c.axis_after) - azimuth_deg(c.axis_before) + 180.0) % 360.0 - 180.0
    return (f"{turn:+.0f} deg (moved {axis_moved_deg(c):.0f}), tilt {c.tilt_min:.0f} then "
            f"{tilt_deg(c.axis_after):.0f} deg, lever {lever_m(c) * 1e3:.0f} mm")


def header(first: str) -> str:
    """The table's two header lines: ``first`` (its leading columns, "|"-separated), then the
    contacts' columns."""
    head = "axis turn (moved), tilt lowest then after, lever"
    contacts = " | ".join(f"contact {k + 1}: {head}" for k in range(CONTACTS_SHOWN))
    return f"| {first} | {contacts} |\n|" + "---|" * (first.count("|") + 1 + CONTACTS_SHOWN)


def contact_cells(contacts: list[Contact]) -> str:
    """The first CONTACTS_SHOWN contacts' cells, "|"-separated (empty ones after the last)."""
    cells = [contact_row(c) for c in contacts[:CONTACTS_SHOWN]]
    return " | ".join(cells + [""] * (CONTACTS_SHOWN - len(cells)))


def table(spins: list[float]) -> str:
    rows = [header("spin [rev/s] | skips")]
    for spin in spins:
        skips, contacts = free_throw(spin)
        rows.append(f"| {spin:g} | {skips} | " + contact_cells(contacts) + " |")
    return "\n".join(rows)


# the throws of the survey: (radius [m], thickness [m], speed [m/s], release, attack [deg], spin [rev/s]);
# release is ("angle", deg below the horizontal, from 6 cm) or ("height", m, thrown level)
SURVEY = ([(r, e, u, ("angle", b), a, 14.0) for r, e, u, b, a in itertools.product(
              (0.05, 0.07), (0.006, 0.012), (8.0, 12.0), (3.0, 8.0), (10.0, 20.0, 30.0))]
          + [(0.05, e, u, ("height", h), a, 12.0) for e, u, h, a in itertools.product(
              (0.006, 0.009), (8.0, 11.0, 14.0), (0.05, 0.1, 0.2), (10.0, 15.0, 20.0, 25.0))])


def survey_throw(throw: tuple) -> int:
    """Skips of the slate thrown free as ``throw`` (a SURVEY entry) over a 20 m x 6 m pond."""
    radius, thickness, speed, (kind, value), attack, spin = throw
    if kind == "angle":
        height, vx, vz = 0.06, speed * math.cos(math.radians(value)), -speed * math.sin(math.radians(value))
    else:
        height, vx, vz = value, speed, 0.0
    sets = ["components.stone.lock_attitude=false", f"components.stone.spin={2 * math.pi * spin!r}",
            f"components.stone.radius={radius!r}", f"components.stone.thickness={thickness!r}",
            f"components.stone.position=[0.3, 3.0, {height!r}]", f"components.stone.velocity=[{vx!r}, 0, {vz!r}]",
            f"components.stone.tilt_deg={attack!r}", "components.pond.nx=2000", "components.pond.ny=600",
            "record.visual_rate=0", "until=4"]
    sim = Simulation(load(ROOT / "scenarios" / "held_skip.yaml", sets))
    sim.run()
    return sim.components["stages"].track.skips


def survey(workers: int = 2) -> str:
    """How many times each SURVEY throw skips, counted."""
    with ProcessPoolExecutor(workers) as pool:
        counts = Counter(pool.map(survey_throw, SURVEY))
    return (f"{len(SURVEY)} free throws (slate of R = 5 or 7 cm, 6-12 mm thick, 8-14 m/s, attack 10-30 deg, "
            "released 3-8 deg below the horizontal at 14 rev/s or level from 5-20 cm at 12 rev/s): "
            + ", ".join(f"{n} skip {k} time{'s' if k != 1 else ''}" for k, n in sorted(counts.items())))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=description(__doc__))
    # one of four things per run: the table (and its section), the survey, the figure, the lake's table
    ap.add_argument("--markdown", type=Path, help="rewrite the spin-precession section of this page")
    what = ap.add_mutually_exclusive_group()
    what.add_argument("--throws", action="store_true", help="count the skips of the survey's free throws instead")
    what.add_argument("--figure", type=Path,
                      help="draw the axis through the first contact into this figure (.png, .pdf or .svg) instead")
    what.add_argument("--lake", action="store_true",
                      help="the same table for the lake's throw, with every effect and with the pressure alone, "
                           "instead")
    args = ap.parse_args(argv)
    if args.markdown and (args.throws or args.figure or args.lake):  # (it was left as it was, without a word)
        other = "--throws" if args.throws else "--figure" if args.figure else "--lake"
        ap.error(f"--markdown rewrites the section of the thin slate's table, which {other} does not make")
    check_output(ap, args.markdown, "--markdown", text=True, sections=("spin-precession",))
    check_figure(ap, args.figure, "--figure")
    if args.lake:
        print(lake_table())
        return 0
    if args.throws:
        print(survey())
        return 0
    if args.figure:
        figure(args.figure)
        print(f"wrote {args.figure}")
        return 0
    text = table(SPINS)
    print(text)
    if args.markdown:
        replace_section(args.markdown, "spin-precession",
                        "The thin slate thrown free (`python tools/spin_precession.py`): per contact, the turn of "
                        "the spin axis about the vertical and, in brackets, the angle it moved through (the turn "
                        "of the spin's angular momentum; the turn about the vertical is that over the sine of "
                        "the tilt, so it is largest where the tilt dips), the axis's tilt from the vertical at "
                        "its lowest during the contact and after it, and the lever arm of the water's torque "
                        "(torque impulse across the axis over force impulse along it).\n\n" + text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
