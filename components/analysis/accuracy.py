"""``cosim bench accuracy SCENE.yaml``: a work-precision study of a throw against a fine reference run.

Every variant is the scene with a few ``--set``-style overrides, run without a recording (output
None, no progress bar) and compared with one reference run, finer in every setting the study varies:

- *base step*: dt times 1/8 .. 10, the water's step (and any other multi-rate component's) held in
  seconds through its ``every``;
- *integrator*: ``semi_implicit_euler`` and ``rk4`` against the scene's own (``verlet`` by default);
- *water*: the other model (``wave`` / ``shallow_water``), cells twice as large (nx, ny halved, same
  domain), half the water step, and (on a flat bed) ``airy``, water with its dispersion;
- *coupling*: Gauss-Seidel (the scene: the coupler reads the body's state of this step) against
  all-delayed edges (Jacobi: the coupler reads the body and the water of the previous step);
- *effects*: each of the coupler's effects switched off in turn.

The reference takes a sixteenth of the base step (a quarter with ``--quick``) and, unless
``--quick``, water cells and water step halved. Errors, over the time both runs cover: the largest
distance between the stone's positions at equal times (the reference interpolated linearly at the
variant's sample times, which lie on its own grid when the steps divide); the skip count; the
largest difference of the skip distances (skips both runs made); the largest difference of the
stone's mechanical energy, in % of its initial energy. Wall time is the simulation loop's, best of
``--repeats`` interleaved rounds, reported as a ratio to the fastest run of the same study (the
machine is shared, so only ratios measured together mean anything).

Output: a markdown table (printed, and written into the ``accuracy-table`` section of
``DIR/accuracy.md``, between ``<!-- accuracy-table:begin -->`` and ``<!-- accuracy-table:end -->``,
leaving the rest of the page alone) and a log-log figure ``DIR/figures/accuracy.png``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shlex
import sys
import time
from dataclasses import dataclass, field, replace
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np

from cosim.cli import positive_int, run_until_ns
from cosim.docsection import replace_section, section_problem
from cosim.record.output import nearest_existing, output_folder, refuse_read_only, written_whole

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2
SECTION = "accuracy-table"
FIGURE = Path("figures") / "accuracy.png"
QUICK_UNTIL = 0.4  # [s] --quick: the first skip and the next touchdown of the reference skip
REFERENCE_STEP = Fraction(1, 16)  # the reference's base step, as a fraction of the scene's
QUICK_REFERENCE_STEP = Fraction(1, 4)
# The reference integrates with semi-implicit Euler: a coupled body receives its wrench held over each
# step from the state at the step's start, which turns velocity Verlet (and RK4: both are exact for a
# constant force) into a first-order method, while semi-implicit Euler then forms a leapfrog with the
# coupler; measured on the reference skip its step error is 14-24 times smaller at equal dt.
REFERENCE_INTEGRATOR = "semi_implicit_euler"
STEPS = tuple(Fraction(f) for f in ("1/8", "1/4", "2/5", "1/2", "1", "2", "4", "5", "10"))  # kept if rates divide
QUICK_STEPS = tuple(Fraction(f) for f in ("1/2", "1", "2", "5"))
OTHER_INTEGRATOR_STEPS = tuple(Fraction(f) for f in ("1/8", "2/5", "1", "2"))
INTEGRATORS = ("verlet", "semi_implicit_euler", "rk4")  # the first other one is the quick study's
WATER_MODELS = ("wave", "shallow_water")
GROUP_STYLE = {  # marker and colour of each group in the figure
    "base step": ("o", "#4c72b0"),
    "integrator": ("s", "#dd8452"),
    "water": ("^", "#55a868"),
    "coupling": ("D", "#c44e52"),
    "effects": ("v", "#8172b3"),
}


class StudyError(ValueError):
    """A scene the study cannot vary (no rigid body, a rate that does not divide, ...)."""


def _yaml_float(x: float) -> str:
    """``x`` exactly, in a form YAML reads as a float (YAML 1.1 wants a dot: ``5.0e-05``, not ``5e-05``)."""
    text = repr(float(x))
    mantissa, e, exponent = text.partition("e")
    if e and "." not in mantissa:
        text = f"{mantissa}.0e{exponent}"
    return text


# --- the plan ----------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Variant:
    """One run of the study: its group, a short name and the overrides that make it (``shown``: how
    the table shows them, when the overrides themselves are too long to read)."""

    group: str
    name: str
    overrides: tuple[str, ...] = ()
    shown: str = ""

    @property
    def settings(self) -> str:
        return self.shown or " ".join(self.overrides)


@dataclass
class Roles:
    """Which components of the scene play which part (names; water, coupler, monitor may be None)."""

    body: str
    water: str | None
    coupler: str | None
    monitor: str | None


def find_roles(scene: Any) -> Roles:
    """The body, water, coupler and stage monitor of a validated scene, by component class."""
    from components.coupler import WaterCoupler
    from components.rigid_body import RigidBody
    from components.stages import StageMonitor
    from components.water import WaterSurface

    def first(cls: type) -> str | None:
        return next((name for name, cfg in scene.components.items() if issubclass(cfg.cls, cls)), None)

    body = first(RigidBody)
    if body is None:
        raise StudyError("the scene has no RigidBody: the study follows a stone's trajectory")
    return Roles(body, first(WaterSurface), first(WaterCoupler), first(StageMonitor))


def _step_overrides(scene: Any, factor: Fraction) -> list[str] | None:
    """Overrides for a base step of ``factor`` times the scene's, holding every multi-rate
    component's step in seconds; None when a rate would not be a whole number of base steps."""
    dt_ns = Fraction(scene.dt_ns) * factor
    if dt_ns.denominator != 1:
        return None
    sets = [f"dt={_yaml_float(float(dt_ns) / 1e9)}"]
    for name, cfg in scene.components.items():
        if cfg.every == 1:
            continue
        every = Fraction(cfg.every) / factor
        if every.denominator != 1:
            return None
        sets.append(f"components.{name}.every={int(every)}")
    return sets


def _water_cell_overrides(scene: Any, water: str, ratio: Fraction) -> list[str] | None:
    """Overrides for water cells ``ratio`` times the scene's over the same domain (nx, ny scaled and
    the centre of cell (0, 0) moved so the grid's lower edges stay); None if nx, ny would not divide."""
    p = scene.components[water].params
    nx, ny = Fraction(p.nx) / ratio, Fraction(p.ny) / ratio
    if nx.denominator != 1 or ny.denominator != 1:
        return None
    cell = p.cell * float(ratio)
    shift = 0.5 * (cell - p.cell)
    return [f"components.{water}.cell={_yaml_float(cell)}", f"components.{water}.nx={int(nx)}",
            f"components.{water}.ny={int(ny)}", f"components.{water}.origin_x={_yaml_float(p.origin_x + shift)}",
            f"components.{water}.origin_y={_yaml_float(p.origin_y + shift)}"]


def _delayed_edge(scene: Any, source: str, port: str, target: str, target_port: str,
                  initial: Any) -> str | None:
    """The override turning the direct edge ``source.port -> target.target_port`` into a delayed one
    whose initial value is ``initial`` (a message); None if there is no such direct edge."""
    from cosim.codec.json_codec import codec_for

    for index, edge in enumerate(scene.connections):
        if (edge.source, edge.source_port, edge.target, edge.target_port) == (source, port, target, target_port):
            if edge.delay:
                return None
            spec = {"from": f"{source}.{port}", "to": f"{target}.{target_port}", "delay": 1,
                    "initial": codec_for(type(initial)).to_dict(initial)}
            return f"connections.{index}={json.dumps(spec)}"
    return None


def _series(scene: Any, factors: tuple[Fraction, ...]) -> list[tuple[Fraction, list[str]]]:
    """(factor, overrides) for the base steps ``factors`` times the scene's that keep every rate whole."""
    out = []
    for factor in factors:
        sets = _step_overrides(scene, factor)
        if sets is not None:
            out.append((factor, sets))
    return out


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:g} ms"


def plan(scene: Any, quick: bool = False) -> tuple[Variant, list[Variant]]:
    """The reference and the variants for ``scene`` (a validated Scene)."""
    roles = find_roles(scene)
    own = scene.components[roles.body].params.integrator
    step = QUICK_REFERENCE_STEP if quick else REFERENCE_STEP
    ref_sets = _step_overrides(scene, step)
    if ref_sets is None:
        raise StudyError(f"dt = {scene.dt:g} s cannot be divided by {step.denominator} with the components' "
                         "rates kept whole (each 'every' times the division must stay a whole number)")
    reference_sets = list(ref_sets)
    if not quick:
        reference_sets.append(f"components.{roles.body}.integrator={REFERENCE_INTEGRATOR}")
        if roles.water is not None:
            finer = _water_cell_overrides(scene, roles.water, Fraction(1, 2))
            every = Fraction(scene.components[roles.water].every) / step / 2  # half the water step
            if finer is not None and every.denominator == 1:
                reference_sets = [s for s in reference_sets if not s.startswith(f"components.{roles.water}.every=")]
                reference_sets += [*finer, f"components.{roles.water}.every={int(every)}",
                                   f"components.{roles.water}.on_unstable=substep"]
    reference = Variant("reference", "reference", tuple(reference_sets))

    variants: list[Variant] = []
    for factor, sets in _series(scene, QUICK_STEPS if quick else STEPS):
        name = f"{own}, dt = {_ms(scene.dt * float(factor))}" + (" (the scene)" if factor == 1 else "")
        variants.append(Variant("base step", name, tuple(sets) if factor != 1 else ()))
    others = [i for i in INTEGRATORS if i != own]
    for integrator in others[:1] if quick else others:  # quick: the first other of verlet, semi-implicit
        for factor, sets in _series(scene, (Fraction(1),) if quick else OTHER_INTEGRATOR_STEPS):
            name = f"{integrator}, dt = {_ms(scene.dt * float(factor))}"
            chosen = f"components.{roles.body}.integrator={integrator}"
            variants.append(Variant("integrator", name, (*(sets if factor != 1 else ()), chosen)))
    if roles.water is not None:
        w = roles.water
        params = scene.components[w].params
        model, every = params.model, scene.components[w].every
        other = next(m for m in WATER_MODELS if m != model)
        water_step = scene.dt * every
        variants.append(Variant("water", f"{other}, {params.cell * 100:g} cm cells",
                                (f"components.{w}.model={other}",)))
        coarse = _water_cell_overrides(scene, w, Fraction(2))
        if coarse is not None:
            cells = f"{params.cell * 200:g} cm cells"
            variants.append(Variant("water", f"{model}, {cells}", tuple(coarse)))
            if not quick:
                variants.append(Variant("water", f"{other}, {cells}", (f"components.{w}.model={other}", *coarse)))
        if not quick:
            if every % 2 == 0:
                variants.append(Variant("water", f"{model}, water step {_ms(water_step / 2)}",
                                        (f"components.{w}.every={every // 2}",)))
            implicit = "shallow_water"
            sets = () if model == implicit else (f"components.{w}.model={implicit}",)
            variants.append(Variant("water", f"{implicit}, water step {_ms(water_step * 2)}",
                                    (*sets, f"components.{w}.every={every * 2}")))
            if model != "airy" and not replace(params, model="airy").check():
                # water's own dispersion (each wave at its speed) against the one-speed height field,
                # where the water's own rules admit it (a flat bed, no set wave speed)
                variants.append(Variant("water", f"airy (dispersive), {params.cell * 100:g} cm cells",
                                        (f"components.{w}.model=airy",)))
    if roles.coupler is not None:
        components = scene.instantiate()
        jacobi = [_delayed_edge(scene, roles.body, "state", roles.coupler, "body",
                                components[roles.body].initial_outputs()["state"])]
        if roles.water is not None:
            jacobi.append(_delayed_edge(scene, roles.water, "patch", roles.coupler, "water",
                                        components[roles.water].initial_outputs()["patch"]))
        sets = tuple(s for s in jacobi if s is not None)
        if sets:
            edges = " and ".join(s.split("=", 1)[0] for s in sets)
            variants.append(Variant("coupling", "all edges delayed (Jacobi)", sets,
                                    f"{edges}: delay 1, initial value the source's t = 0 output"))
        effects = list(scene.components[roles.coupler].params.effects)
        for effect in (effects if not quick else effects[-2:-1]):
            rest = [e for e in effects if e != effect]
            variants.append(Variant("effects", f"without {effect}",
                                    (f"components.{roles.coupler}.effects=[{', '.join(rest)}]",)))
    return reference, variants


# --- running ----------------------------------------------------------------------------------------

@dataclass
class Trace:
    """What one run of a variant gave: the stone's states, skips, end and wall time."""

    t: np.ndarray  # (n,) [s]
    position: np.ndarray  # (n, 3) [m]
    energy: np.ndarray  # (n,) kinetic + potential [J]
    skips: int
    distances: list[float]
    outcome: str
    status: str
    reason: str
    end: float  # [s]
    takeoffs: list[float] = field(default_factory=list)  # the end of each skip [s]
    walls: list[float] = field(default_factory=list)

    @property
    def wall(self) -> float:
        return min(self.walls)


def _recorder(body: str):
    from cosim.scheduler import BaseObserver

    class StoneStates(BaseObserver):
        """Keeps the body's published states (a cheap observer: one comparison per message)."""

        def __init__(self) -> None:
            self.rows: list[tuple[int, Any]] = []

        def on_exchange(self, time_ns: int, component: str, port: str, msg: Any) -> None:
            if component == body and port == "state":
                self.rows.append((time_ns, msg))

    return StoneStates()


def run_variant(scene_path: str | Path, variant: Variant, until: float | None) -> Trace:
    """One run of ``variant`` (no recording), with the stone's trajectory and the monitor's figures."""
    from cosim.runner import run_scene
    from cosim.scenario import load
    from cosim.scheduler import Simulation

    sets = list(variant.overrides) + ([f"until={_yaml_float(until)}"] if until is not None else [])
    scene = load(scene_path, overrides=sets)
    roles = find_roles(scene)
    states = _recorder(roles.body)
    sim = Simulation(scene, observers=[states])
    outcome = run_scene(scene, None, progress=False, simulation=sim)
    result = outcome.result
    if result.status == "interrupted":  # Ctrl-C ends the study, not only this run (a cut-short run is no result)
        raise KeyboardInterrupt
    rows = states.rows
    t = np.array([stamp / 1e9 for stamp, _ in rows])
    position = np.array([msg.position for _, msg in rows])
    energy = np.array([msg.kinetic_energy + msg.potential_energy for _, msg in rows])
    skips, distances, final, takeoffs = 0, [], "none", []
    if roles.monitor is not None:
        monitor = sim.components[roles.monitor]
        records = getattr(monitor, "records", [])
        skips, distances = len(records), [float(r.distance) for r in records]
        takeoffs = [float(r.touchdown_time + r.contact_time) for r in records]
        final = str(monitor.metrics().get("outcome", "none"))
    # the loop's own time: a kernel compiled in this run (its first contact comes after the warm-up's
    # 0.02 s; a kernel source changed since the cache was written) is a one-off cost, not the variant's
    # (a cold cache put 57 s of compiling into the reference's 0.7 s and its wall ratios 180x off)
    return Trace(t, position, energy, skips, distances, final, result.status, result.reason,
                 result.time_ns / 1e9, takeoffs, [result.wall_s - result.compile_s])


# --- comparing ----------------------------------------------------------------------------------------

@dataclass
class Row:
    """A variant's figures against the reference."""

    variant: Variant
    trace: Trace
    wall_ratio: float = math.nan
    trajectory: float = math.nan  # [m], over the time both runs cover
    trajectory_skips: float = math.nan  # [m], to the end of the last skip both runs made
    skip_diff: int = 0
    distance: float = math.nan  # [m]
    energy: float = math.nan  # [% of the initial energy]


def _position_error(trace: Trace, ref: Trace, until: float) -> float:
    """Largest distance [m] between the two runs' positions at the trace's sample times up to ``until``."""
    keep = trace.t <= until + 1e-12
    if not keep.any():
        return math.nan
    t = trace.t[keep]
    at_ref = np.column_stack([np.interp(t, ref.t, ref.position[:, k]) for k in range(3)])
    return float(np.max(np.linalg.norm(trace.position[keep] - at_ref, axis=1)))


def compare(trace: Trace, ref: Trace) -> dict[str, float]:
    """A trace's errors against the reference: trajectory over the common span and over the skips
    (to the later end of the last skip both runs made) [m], skip count difference, skip distance error
    over those skips [m], energy error [% of the initial energy]."""
    span = min(trace.end, ref.end)
    keep = trace.t <= span + 1e-12
    e0 = abs(ref.energy[0]) if ref.energy.size and ref.energy[0] != 0 else 1.0
    energy = math.nan
    if keep.any():
        energy = float(np.max(np.abs(trace.energy[keep] - np.interp(trace.t[keep], ref.t, ref.energy)))) / e0 * 100
    common = min(len(trace.distances), len(ref.distances))
    skips_span = min(span, max(trace.takeoffs[common - 1], ref.takeoffs[common - 1])) if common else math.nan
    distance = (max(abs(a - b) for a, b in zip(trace.distances[:common], ref.distances[:common], strict=True))
                if common else math.nan)
    return {"trajectory": _position_error(trace, ref, span),
            "trajectory_skips": _position_error(trace, ref, skips_span) if math.isfinite(skips_span) else math.nan,
            "skip_diff": trace.skips - ref.skips, "distance": distance, "energy": energy}


@dataclass
class Study:
    """A finished study: the scene, the reference row first, then the variants' rows."""

    scene_path: str
    quick: bool
    rows: list[Row]
    command: str = ""
    until: float | None = None

    @property
    def reference(self) -> Row:
        return self.rows[0]

    def group(self, name: str) -> list[Row]:
        return [r for r in self.rows if r.variant.group == name]


def _check_until_covers_a_step(until: float, dt: float, variants: list[Variant], given: bool = True) -> None:
    """Refuse an end ``until`` [s] shorter than the base step of a variant (the scene's ``dt`` [s] or
    the one its ``dt=`` override sets): said before any run, of ``--until`` (``given``) or of the
    scene's own ``until``, where the variant's load blamed the scene file's ``until`` at a dt not
    the scene's (the variant's)."""
    for variant in variants:
        step = next((float(o.split("=", 1)[1]) for o in variant.overrides if o.startswith("dt=")), dt)
        if until < step * (1.0 - 1e-9):
            said = f"--until {until:g} s" if given else f"the scene's until, {until:g} s,"
            raise StudyError(f"{said} is shorter than one base step of the variant {variant.name!r} "
                             f"(dt = {step:g} s): give --until of at least {step:g} s")


def run_study(scene_path: str | Path, *, quick: bool = False, repeats: int = 2, until: float | None = None,
              log: Any = None) -> Study:
    """Plan, warm up, run every variant ``repeats`` times (interleaved) and compare with the reference."""
    from cosim.scenario import load

    scene = load(scene_path)
    reference, variants = plan(scene, quick)
    if until is None and quick:
        until = min(QUICK_UNTIL, scene.until_ns / 1e9)
    everything = [reference, *variants]
    _check_until_covers_a_step(scene.until_ns / 1e9 if until is None else until, scene.dt, everything,
                               given=until is not None)

    def say(text: str) -> None:
        if log is not None:
            print(text, file=log, flush=True)

    # compiled kernels load (or compile) on first use: one short run of each variant, untimed
    warm = min(0.02, until if until is not None else scene.until_ns / 1e9)
    for variant in everything:
        run_variant(scene_path, variant, warm)
    traces: dict[int, Trace] = {}
    for round_ in range(repeats):
        for k, variant in enumerate(everything):
            trace = run_variant(scene_path, variant, until)
            if k in traces:
                traces[k].walls += trace.walls
            else:
                traces[k] = trace
            say(f"[{round_ + 1}/{repeats}] {variant.group}: {variant.name}: {trace.status} at "
                f"{trace.end:.3f} s, wall {trace.walls[0]:.2f} s")
    rows = [Row(v, traces[k]) for k, v in enumerate(everything)]
    fastest = min(r.trace.wall for r in rows)
    ref = rows[0].trace
    for row in rows:
        row.wall_ratio = row.trace.wall / fastest
        for key, value in compare(row.trace, ref).items():
            setattr(row, key, value)
    return Study(str(scene_path), quick, rows, until=until)


# --- reporting ----------------------------------------------------------------------------------------

def _num(value: float, scale: float = 1.0, digits: int = 3) -> str:
    if value is None or not math.isfinite(value):
        return "-"
    v = value * scale
    return "0" if v == 0 else f"{v:.{digits}g}"


def table(study: Study) -> str:
    """The markdown table: one row per run, the reference first."""
    ref = study.reference.trace
    lines = [
        "| group | variant | wall (x fastest) | trajectory error, skips [mm] | trajectory error, whole run [mm] "
        f"| skips (ref {ref.skips}) | skip distance error [mm] | energy error [% of E0] | end | settings |",
        "|---|---|---:|---:|---:|---:|---:|---:|---|---|",
    ]
    for row in study.rows:
        tr = row.trace
        skips = f"{tr.skips}" + (f" ({row.skip_diff:+d})" if row.skip_diff else "")
        end = f"{tr.outcome}, {tr.end:.3g} s" if tr.status != "failed" else f"failed at {tr.end:.3g} s"
        settings = f"`{row.variant.settings}`" if row.variant.settings else "(the scene)"
        lines.append(f"| {row.variant.group} | {row.variant.name} | {row.wall_ratio:.2f} | "
                     f"{_num(row.trajectory_skips, 1e3)} | {_num(row.trajectory, 1e3)} | {skips} | "
                     f"{_num(row.distance, 1e3)} | {_num(row.energy)} | {end} | {settings} |")
    return "\n".join(lines)


def section(study: Study) -> str:
    """The generated section of accuracy.md: how it was made, the table and the figure."""
    ref = study.reference
    span = f"until {study.until:g} s" if study.until is not None else "to the scene's end"
    return "\n".join([
        f"Generated by `{study.command}`" if study.command else "",
        "",
        f"Scene `{study.scene_path}`, {'quick study' if study.quick else 'full study'}, {span}. "
        f"Reference: `{ref.variant.settings}`; it ended {ref.trace.outcome} at {ref.trace.end:.3g} s "
        f"after {ref.trace.skips} skips. 'Skips' errors run to the end of the last skip both runs made. "
        f"Wall times: best of {len(ref.trace.walls)} interleaved "
        "rounds, as a ratio to the fastest run of this study (the fastest took "
        f"{min(r.trace.wall for r in study.rows):.3g} s).",
        "",
        table(study),
        "",
        f"![Error against wall time]({FIGURE.as_posix()})",
    ]).strip()


PANELS = (("trajectory_skips", 1e3, "trajectory error over the skips [mm]"),
          ("trajectory", 1e3, "trajectory error over the whole run [mm]"),
          ("distance", 1e3, "skip distance error [mm]"),
          ("energy", 1.0, "energy error [% of the initial energy]"))
SERIES_COLORS = {"verlet": "#4c72b0", "semi_implicit_euler": "#dd8452", "rk4": "#8c8c8c"}


def _series_rows(study: Study) -> dict[str, list[Row]]:
    """The base-step and integrator rows by integrator (each a work-precision curve over dt)."""
    series: dict[str, list[Row]] = {}
    for row in study.group("base step") + study.group("integrator"):
        series.setdefault(row.variant.name.split(",")[0], []).append(row)
    return series


def figure(study: Study, path: str | Path, dpi: int = 100) -> Path:
    """Log-log panels of each error against the wall-time ratio: one curve per integrator over the base
    step (points labelled with dt, * the scene's), markers for the water, coupling and effects variants;
    the reference (error 0) as a dotted vertical line at its wall time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(2, 2, figsize=(13, 9.5), constrained_layout=True)
    series = _series_rows(study)
    plain = FuncFormatter(lambda v, _: f"{v:g}")
    for ax, (attr, scale, label) in zip(axes.flat, PANELS, strict=True):
        def shown(rows: list[Row], attr: str = attr) -> list[Row]:
            return [r for r in rows if math.isfinite(getattr(r, attr)) and getattr(r, attr) > 0]

        for name, rows in series.items():
            rows = sorted(shown(rows), key=lambda r: r.wall_ratio)
            if not rows:
                continue
            color = SERIES_COLORS.get(name, "#4c72b0")
            x = [r.wall_ratio for r in rows]
            y = [getattr(r, attr) * scale for r in rows]
            ax.plot(x, y, "o-", color=color, lw=1, ms=5, label=f"{name} over dt", zorder=3)
            for r, xi, yi in zip(rows, x, y, strict=True):
                dt = r.variant.name.split("dt = ")[-1].replace(" (the scene)", "*")
                ax.annotate(dt, (xi, yi), textcoords="offset points", xytext=(3, 3), fontsize=6.5, color=color)
        for group in ("water", "coupling", "effects"):
            marker, color = GROUP_STYLE[group]
            rows = shown(study.group(group))
            if not rows:
                continue
            ax.scatter([r.wall_ratio for r in rows], [getattr(r, attr) * scale for r in rows], marker=marker,
                       color=color, s=34, label=group, zorder=4)
            for r in rows:
                ax.annotate(r.variant.name.replace("all edges delayed ", ""), (r.wall_ratio, getattr(r, attr) * scale),
                            textcoords="offset points", xytext=(4, -7), fontsize=6, color=color)
        ax.axvline(study.reference.wall_ratio, color="k", lw=0.8, ls=":")
        ax.annotate("reference", (study.reference.wall_ratio, 0.03), xycoords=("data", "axes fraction"),
                    rotation=90, fontsize=8, ha="right", va="bottom")
        ax.set_xscale("log")
        ax.set_yscale("log")
        for axis in (ax.xaxis, ax.yaxis):  # 1, 2, 5, 10, 20, ... written plainly
            axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
            axis.set_major_formatter(plain)
            axis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("wall time / fastest run of the study")
        ax.set_ylabel(label)
        ax.grid(True, which="both", lw=0.3, alpha=0.5)
    if axes[1, 0].get_legend_handles_labels()[0]:  # none when no run made a skip: no empty legend (and its warning)
        axes[1, 0].legend(loc="lower left", fontsize=8)
    fig.suptitle(f"Work-precision of {Path(study.scene_path).name} against the reference run "
                 f"({'quick' if study.quick else 'full'} study; * = the scene's base step)", fontsize=10)
    with written_whole(Path(path)) as tmp:  # a failed write leaves no truncated picture
        fig.savefig(tmp, dpi=dpi, format="png")
    plt.close(fig)
    return path


def write(study: Study, out_dir: str | Path) -> tuple[Path, Path]:
    """The figure (DIR/figures/accuracy.png) and the table section of DIR/accuracy.md."""
    out_dir = Path(out_dir)
    page = out_dir / "accuracy.md"
    # the folders made here go again if the writing fails or is interrupted (it left DIR and
    # DIR/figures empty), as a plot's do
    with output_folder((out_dir / FIGURE).parent):
        png = figure(study, out_dir / FIGURE)
        replace_section(page, SECTION, section(study))
    return page, png


# --- the command --------------------------------------------------------------------------------------

def register(subparsers: argparse._SubParsersAction) -> None:
    """``cosim bench MODE ...``; the ``accuracy`` mode is this module's."""
    bench = subparsers.add_parser("bench", help="benchmarks and studies (accuracy: work-precision of a scene)")
    modes = bench.add_subparsers(dest="mode", required=True, parser_class=type(bench))
    p = modes.add_parser(
        "accuracy", help="error against wall time over base step, integrator, water model and resolution, "
                         "coupling order and effects, against a fine reference run")
    p.add_argument("scene", help="scene YAML file (a throw with a RigidBody, e.g. scenarios/skip.yaml)")
    p.add_argument("--quick", action="store_true",
                   help=f"smoke test: the first {QUICK_UNTIL:g} s (or the scene's until, if sooner), a reference at "
                        "dt/4 with the scene's integrator and water, fewer variants, one round")
    p.add_argument("-o", "--output", metavar="DIR", default="runs/accuracy",
                   help="writes DIR/figures/accuracy.png and the table section of DIR/accuracy.md "
                        "(default runs/accuracy; docs/ for the documentation)")
    p.add_argument("--repeats", type=positive_int, help="timed rounds per variant (default 2; 1 with --quick)")
    p.add_argument("--until", type=_until_seconds, metavar="T",
                   help=f"end time of every run [s] (default: the scene's until; with --quick, {QUICK_UNTIL:g} s "
                        "or the scene's until, if sooner)")
    p.add_argument("-q", "--quiet", action="store_true", help="no line per run on stderr")
    p.set_defaults(func=cmd_accuracy)


def _until_seconds(text: str) -> float:
    """``--until T`` [s], bounded as ``cosim run --until`` is: checked before the study's warm-up runs,
    where the scene's own ``until`` check would name the scene file for it."""
    return run_until_ns(text) / 1e9


def output_folder_problem(out_dir: Path) -> str | None:
    """Why the study could not write into ``out_dir`` (its figure and page), or None: the folder, or
    the nearest of its parents that exists, must be a folder this process may write in."""
    here = nearest_existing(out_dir)
    if here is None:
        return None
    if not here.is_dir():
        return ("not a folder; cosim bench accuracy writes a folder (-o DIR)" if here == out_dir
                else f"cannot be made: {here} is a file, not a folder")
    if not os.access(here, os.W_OK | os.X_OK):
        return f"cannot be written: no permission to write in {here}"
    page, png = out_dir / "accuracy.md", out_dir / FIGURE
    for made in (page, png):
        if made.exists() and not made.is_file():
            return f"{made} is not a file"
        if made.is_file() and not os.access(made, os.W_OK):
            return f"{made} cannot be written: no permission"
        try:  # by its permission bits too: root may write anything, and the study's end refused it then
            refuse_read_only(made)
        except PermissionError:
            return f"{made} is read-only; it is not replaced"
    if page.is_file():
        try:
            misplaced = section_problem(page.read_text(encoding="utf-8"), SECTION)
            if misplaced:
                return f"{page}: {misplaced}"
        except UnicodeDecodeError as exc:
            return f"{page} is not UTF-8 text (byte {exc.start}); its section could not be written into it"
        except OSError as exc:
            return f"{page} cannot be read ({exc.strerror or exc})"
    return None


def cmd_accuracy(args: argparse.Namespace) -> int:
    from cosim.errors import ScenarioError

    repeats = args.repeats or (1 if args.quick else 2)
    problem = output_folder_problem(Path(args.output))
    if problem is not None:  # said before the study's minutes of runs, not after them
        print(f"error: {args.output}: {problem}", file=sys.stderr)
        return EXIT_BAD_INPUT
    started = time.perf_counter()
    try:
        study = run_study(args.scene, quick=args.quick, repeats=repeats, until=args.until,
                          log=None if args.quiet else sys.stderr)
    except (ScenarioError, StudyError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    study.command = shlex.join(["cosim", *sys.argv[1:]]) if sys.argv[1:2] == ["bench"] else \
        shlex.join(["cosim", "bench", "accuracy", args.scene, *(["--quick"] if args.quick else []),
                    "-o", args.output])
    page, png = write(study, args.output)
    print(table(study))
    print(f"wrote {png} and the '{SECTION}' section of {page} ({time.perf_counter() - started:.0f} s)")
    failed = [r.variant.name for r in study.rows if r.trace.status == "failed"]
    if study.reference.trace.status == "failed":
        print(f"error: the reference run failed: {study.reference.trace.reason}", file=sys.stderr)
        return EXIT_FAILED
    if failed:
        print(f"note: {len(failed)} variant(s) failed (rows kept): {', '.join(failed)}", file=sys.stderr)
    return EXIT_OK
