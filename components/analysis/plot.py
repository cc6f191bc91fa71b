"""``cosim plot``: PNG figures of a recorded run.

- ``trajectory.png``: side view (x, z) of the body's path coloured by stage, the water line, and
  the touchdown of each skip, with the path seen from above (x, y) beneath it when it leaves its
  line sideways (a spinning stone curves); for a body that stays in place (a drop, a bounce) its
  height over time instead, with each ground contact marked;
- ``motion.png``: speed and attack angle over time, on the stage spans;
- ``energy.png``: kinetic and potential energy, the energy dissipated by the water and the ground
  (when those are recorded), and their sum;
- ``contacts.png``: the forces during each contact (water effects per coupler, total wrenches,
  ground normal and friction), over the time since touchdown.

A recording of water alone (no body: a wave pulse, a drop's ripples) gets ``water.png`` instead:
the highest crest and lowest trough, the change of the water's volume and its lattice energy over
time.

Figures are built on :class:`matplotlib.figure.Figure` directly (no pyplot state, Agg output).
Each ``figure_*`` function returns the figure, so tests can check what was drawn.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from components.analysis.data import (
    RunData,
    StageTrack,
    contact_spans,
    iter_fields,
    load_run,
    scene_publishes,
    topics_of,
    warn_ended_early,
    water_rest_level,
)
from components.analysis.style import STAGE_LABELS, WATER_LINE_COLOR, stage_color
from components.messages import BodyState, GroundContact, Shape, StageId, WaterContact, WaterField
from components.rigid.quaternion import body_axis
from cosim.record.output import (
    move_together,
    named_for,
    new_temporary,
    output_folder,
    refuse_read_only,
    remove_quietly,
    written_whole,
)
from cosim.record.reader import Recording
from cosim.record.recorder import component_of

MAX_CONTACTS = 8  # contacts shown in contacts.png (the first ones)
CONTACT_MARGIN = 0.2  # [fraction of the contact duration] shown before and after each contact
FIGSIZE = (10.0, 4.5)  # [in]
WRENCH_COLORS = ["k", "tab:purple", "tab:olive", "tab:cyan"]  # one per wrench channel (a coupler's, a gust's)
BOUNCE_G = 4.0  # [g] a disk bounces once the water's push passes about this (Tang et al. 2021)
SIDE_VIEW_MIN_TRAVEL = 0.5  # [fraction of the height range] of horizontal travel for a side view
TOP_VIEW_MIN_SPREAD = 0.01  # [m] sideways spread of the path from which it is also drawn from above
PATH_COLOR = "#404040"  # the path without a stage monitor


def _stage_legend(ax, stages: list[int], also: bool = False) -> None:
    """A legend of the stages met, and with ``also`` of the lines and markers drawn on ``ax`` with a
    label (the water level, the ground contacts)."""
    handles = [Patch(color=stage_color(s), label=STAGE_LABELS[StageId(s)] if s >= 0 else "before the first stage")
               for s in sorted(set(stages))]
    if also:
        handles += [h for h in ax.get_legend_handles_labels()[0] if not h.get_label().startswith("_")]
    if handles:
        ax.legend(handles=handles, loc="upper right", fontsize="small", ncols=min(3, len(handles)))


def _shade_stages(ax, run: RunData) -> None:
    if run.stages is None:
        return
    for start, end, stage in run.stages.spans(run.end):
        ax.axvspan(start, end, color=stage_color(stage), alpha=0.12, linewidth=0)


def stage_per_sample(run: RunData) -> np.ndarray:
    """The stage in force at each recorded body state (-1 without a stage monitor)."""
    if run.stages is None or not len(run.stages.t):
        return np.full(len(run.body.t), -1)
    stages = run.stages.at(run.body.t)
    # the monitor publishes its first stage at the end of its first step: the states before that
    # (the initial one) are in that stage, not in an unknown one
    stages[stages < 0] = run.stages.stage[0]
    return stages


def against_time(run: RunData) -> bool:
    """Whether the path is drawn as height over time rather than as a side view: when it travels
    horizontally less than :data:`SIDE_VIEW_MIN_TRAVEL` of its height range (a drop or a bounce in
    place, whose side view would be a vertical line)."""
    pos = run.body.position
    travel = float(np.ptp(np.hypot(pos[:, 0] - pos[0, 0], pos[:, 1] - pos[0, 1])))
    return travel < SIDE_VIEW_MIN_TRAVEL * max(float(np.ptp(pos[:, 2])), 2 * run.body.radius)


def side_axis(run: RunData) -> int:
    """The horizontal axis of the side view: 0 (x), or 1 (y) for a path that spans more of y than
    of x (seen along x, its side view would be a vertical line)."""
    pos = run.body.position
    return 1 if float(np.ptp(pos[:, 1])) > float(np.ptp(pos[:, 0])) else 0


def from_above(run: RunData) -> bool:
    """Whether the path is also drawn seen from above: a side view along x whose path spreads
    sideways (y) by :data:`TOP_VIEW_MIN_SPREAD` or more."""
    return (not against_time(run) and side_axis(run) == 0
            and float(np.ptp(run.body.position[:, 1])) >= TOP_VIEW_MIN_SPREAD)


def figure_trajectory(run: RunData) -> Figure:
    """The path, one segment per pair of states, coloured by the stage at its start (one colour
    without a stage monitor): a side view x-z (y-z for a path along y, :func:`side_axis`), or the
    height over time for a body that stays in place (:func:`against_time`). The water line is
    drawn when the run has water, each ground contact's start is marked when it has a ground. A
    path that curves sideways is drawn seen from above too, in a second panel beneath
    (:func:`from_above`)."""
    body = run.body
    above = from_above(run)
    fig = Figure(figsize=(FIGSIZE[0], FIGSIZE[1] * 1.5) if above else FIGSIZE, layout="constrained")
    ax = fig.add_subplot(2, 1, 1) if above else fig.add_subplot()
    by_time = against_time(run)
    axis = side_axis(run)
    path = np.column_stack([body.t if by_time else body.position[:, axis], body.position[:, 2]])
    stages = stage_per_sample(run)
    segments = np.stack([path[:-1], path[1:]], axis=1)
    colors = [stage_color(s) for s in stages[:-1]] if run.stages is not None else PATH_COLOR
    ax.add_collection(LineCollection(segments, colors=colors, linewidths=2.0))
    has_water = bool(run.contacts or run.field_topics)
    if has_water:
        ax.axhline(run.rest_level, color=WATER_LINE_COLOR, linewidth=1.0, linestyle="--", label="water level")
    for skip in run.skips:
        at = (skip.touchdown_time if by_time else skip.touchdown_x if axis == 0
              else float(np.interp(skip.touchdown_time, body.t, body.position[:, 1])))
        ax.axvline(at, color="0.6", linewidth=0.6, linestyle=":")
        ax.annotate(f"skip {skip.index}", (at, run.rest_level), textcoords="offset points",
                    xytext=(2, -12), fontsize="x-small", color="0.35")
    touches = _ground_touches(run)
    if len(touches):
        i = np.clip(np.searchsorted(body.t, touches), 0, len(body.t) - 1)
        ax.plot(path[i, 0], path[i, 1], "v", color="0.25", markersize=5, linestyle="none",
                label=f"ground contact ({len(touches)})")
    ax.autoscale_view()
    zmin, zmax = float(np.min(path[:, 1])), float(np.max(path[:, 1]))
    if has_water:
        zmin, zmax = min(zmin, run.rest_level), max(zmax, run.rest_level)
    pad = 0.08 * max(zmax - zmin, 2 * body.radius)
    ax.set_ylim(zmin - pad, zmax + pad)
    ax.set_xlabel("time [s]" if by_time else "xy"[axis] + " [m]")
    ax.set_ylabel("z [m]")
    view = "height over time" if by_time else "side view"
    # the monitor's own count (a restart's recording holds the skips after its checkpoint only)
    skips = max(len(run.skips), int(run.stages.skips[-1]) if run.stages is not None and len(run.stages.skips) else 0)
    by_stage = f" by stage ({skips} skip{'' if skips == 1 else 's'})" if run.stages is not None else ""
    ax.set_title(f"{run.scene}: {view} of {body.name}{by_stage}")
    if run.stages is not None:
        _stage_legend(ax, stages.tolist(), also=True)
    elif has_water or len(touches):
        ax.legend(loc="upper right", fontsize="small")
    ax.grid(True, alpha=0.3)
    if above:
        _draw_from_above(fig.add_subplot(2, 1, 2, sharex=ax), run, colors)
    return fig


def _draw_from_above(ax, run: RunData, colors) -> None:
    """The path x-y into ``ax`` in the side view's ``colors``, each skip's touchdown marked; y to
    its own scale (a curve of centimetres over metres of travel would not show at equal scales)."""
    body = run.body
    xy = body.position[:, :2]
    ax.add_collection(LineCollection(np.stack([xy[:-1], xy[1:]], axis=1), colors=colors, linewidths=2.0))
    for skip in run.skips:
        y = float(np.interp(skip.touchdown_time, body.t, xy[:, 1]))
        ax.plot(skip.touchdown_x, y, "o", color="0.3", markersize=4)
        # rounded first, as the run's summary does: a turn smaller than the last digit is +0.0, not -0.0
        ax.annotate(f"{round(skip.heading_deg, 1) + 0.0:+.1f} deg", (skip.touchdown_x, y), textcoords="offset points",
                    xytext=(3, 4), fontsize="x-small", color="0.35")
    ax.autoscale_view()
    lo, hi = float(np.min(xy[:, 1])), float(np.max(xy[:, 1]))
    pad = 0.1 * (hi - lo)
    ax.set_ylim(lo - pad, hi + pad)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    skips = ": each skip's touchdown and its heading after it" if run.skips else ""
    ax.set_title(f"seen from above (y to its own scale){skips}", fontsize="medium")
    ax.grid(True, alpha=0.3)


def _ground_touches(run: RunData) -> np.ndarray:
    """Times [s] at which the body's ground contacts begin (the first ground's reports)."""
    if not run.grounds:
        return np.zeros(0)
    g = run.grounds[0]
    return np.array([start for start, _ in _spans(g.in_contact, g.t)])


def figure_motion(run: RunData) -> Figure:
    """Speed and attack angle over time."""
    body = run.body
    fig = Figure(figsize=(FIGSIZE[0], FIGSIZE[1] * 1.3), layout="constrained")
    ax_speed, ax_angle = fig.subplots(2, 1, sharex=True)
    for ax in (ax_speed, ax_angle):
        _shade_stages(ax, run)
        ax.grid(True, alpha=0.3)
    ax_speed.plot(body.t, body.speed, color="k", linewidth=1.2)
    ax_speed.set_ylabel("speed [m/s]")
    ax_speed.set_title(f"{run.scene}: {body.name}")
    ax_angle.plot(body.t, body.attack_deg, color="k", linewidth=1.2)
    ax_angle.set_ylabel("attack angle [deg]\n(along the motion, nose up +)")
    if body.attitude_locked:
        # held or scripted: a script turns the face (scripted_skim's 15 deg to 0), which "held" denied
        title = ("attitude held (lock_attitude, the high-spin limit): the face keeps its tilt to the horizontal"
                 if _axis_kept(body.orientation) else
                 "attitude scripted (scripted_tilt_deg): the face turns as its keyframes say, not as the water would")
        ax_angle.set_title(title, fontsize="small")
    ax_angle.set_xlabel("time [s]")
    if run.stages is not None:
        _stage_legend(ax_speed, run.stages.stage.tolist())
    return fig


def energy_terms(run: RunData) -> dict[str, np.ndarray]:
    """Energy terms [J] at the body's sample times: kinetic, potential, dissipated by each water
    coupler and each ground (held between their reports), and the total."""
    body = run.body
    terms = {"kinetic": body.kinetic, "potential": body.potential}
    for c in run.contacts:
        terms[f"dissipated by water ({c.topic})"] = _hold(c.t, c.dissipated, body.t)
    # a ground's impulse reaches the body over a delayed edge, in its next step: what the ground
    # reports as dissipated at t leaves the body's kinetic energy at its next state (summed at t, the
    # total jumped by the impact's loss at every bounce). Where the report a step before the body's
    # state is not recorded (one message in ten kept), the latest one is the nearest to it.
    for g in run.grounds:
        terms[f"dissipated by ground ({g.topic})"] = _hold_a_step_before(g.t, g.dissipated, body.t, run.step)
    # a wrench from anything but a water coupler (whose work is its dissipation, above) does work on
    # the body: the force held over each of the body's steps along its move, taken off the total
    couplers = {component_of(c.topic) for c in run.contacts}
    for w in run.wrenches:
        if component_of(w.topic) in couplers or len(body.t) < 2:
            continue
        force = np.stack([_hold(w.t, w.force[:, k], body.t[:-1], before=0.0) for k in range(3)], axis=1)
        work = np.concatenate([[0.0], np.cumsum(np.einsum("ij,ij->i", force, np.diff(body.position, axis=0)))])
        terms[f"work done on it by {w.topic}, taken off"] = -work
    terms["total"] = np.sum(list(terms.values()), axis=0)
    return terms


def _reports_contacts(rec: Recording) -> bool:
    """Whether the recorded scene has a component that reports contacts (water or ground); True when
    its scene cannot be read."""
    return scene_publishes(rec, (WaterContact, GroundContact))


def _hold_a_step_before(t: np.ndarray, values: np.ndarray, at: np.ndarray, step: float) -> np.ndarray:
    """:func:`_hold` at ``at - step`` where a value was recorded exactly then, else at ``at``."""
    earlier = _hold(t, values, at - step)
    idx = np.searchsorted(t, at - step + 1e-9, side="right") - 1
    recorded = (idx >= 0) & (np.abs(t[np.clip(idx, 0, None)] - (at - step)) <= 1e-9) if len(t) else idx >= 0
    return np.where(recorded, earlier, _hold(t, values, at))


def _hold(t: np.ndarray, values: np.ndarray, at: np.ndarray, before: float | None = None) -> np.ndarray:
    """The last value at or before each time of ``at``; before the first, ``before``, else the first
    (a running total a restart's recording picks up where its checkpoint left it: it read 0 until
    its first report, then jumped); 0 without any."""
    if not len(t):
        return np.zeros(len(at))
    idx = np.searchsorted(t, at, side="right") - 1
    held = values[np.clip(idx, 0, None)]
    return held if before is None else np.where(idx >= 0, held, before)


def figure_energy(run: RunData) -> Figure:
    """The energy budget over time."""
    fig = Figure(figsize=FIGSIZE, layout="constrained")
    ax = fig.add_subplot()
    _shade_stages(ax, run)
    styles = {"kinetic": ("C0", "-"), "potential": ("C2", "-"), "total": ("k", "--")}
    for i, (name, values) in enumerate(energy_terms(run).items()):
        color, style = styles.get(name, (f"C{3 + i}", "-"))
        ax.plot(run.body.t, values, color=color, linestyle=style, linewidth=1.3, label=name)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("energy [J]")
    title = f"{run.scene}: energy budget of {run.body.name}"
    if run.unbooked:  # (its total then falls or rises by what is not counted: said, not left to guess)
        title += f"\nthe total leaves out {' and '.join(run.unbooked)}"
    ax.set_title(title)
    ax.legend(loc="best", fontsize="small")
    ax.grid(True, alpha=0.3)
    return fig


# stages that end a contact: in the air, or on the solid ground out of the water
OUT_OF_THE_WATER = (StageId.APPROACH, StageId.FLY_AWAY, StageId.LEFT_POND, StageId.GROUND)


def contact_intervals(run: RunData) -> list[tuple[float, float]]:
    """(start, end) [s] of each contact: the stage monitor's skips (the durations the run's summary
    gives) and then, after the last skip, the wetted spans of the first water coupler, else (its
    reports not recorded) the hit/slide stage spans; without skips, the wetted spans, else ground
    contact spans, else the hit/slide stage spans. Wetted spans are contacts as the monitor counts
    them (:func:`_wetted_spans`)."""
    if run.skips:
        skips = sorted(run.skips, key=lambda s: s.index)
        spans = [(float(s.touchdown_time), float(s.touchdown_time + s.contact_time)) for s in skips]
        # (without the coupler's reports, the glide after the last skip was left out: the stages say it)
        later = _wetted_spans(run) if run.contacts else _stage_spans(run)
        spans += [span for span in later if span[0] > spans[-1][1]]
        return spans
    if run.contacts:
        return _wetted_spans(run)
    if run.grounds:
        g = run.grounds[0]
        return _spans(g.in_contact, g.t)
    return _stage_spans(run)


def _stage_spans(run: RunData) -> list[tuple[float, float]]:
    """(start, end) [s] of each run of hit and slide stages (none without a stage monitor), the last
    one lasting to the run's end."""
    if run.stages is None:
        return []
    spans, current = [], None
    for start, end, stage in run.stages.spans(run.end):
        if stage in (StageId.HIT, StageId.SLIDE):
            current = (current[0] if current else start, end)
        elif current is not None:
            spans.append(current)
            current = None
    return [*spans, current] if current else spans


def _wetted_spans(run: RunData) -> list[tuple[float, float]]:
    """The wetted spans of the first water coupler (:func:`_spans`), each begun when the stage monitor
    says its hit began (:func:`_hit_start`), joined into the contacts the monitor counts
    (:func:`_as_the_monitor_counts`)."""
    c = run.contacts[0]
    spans = []
    for (start, end), (first, _) in zip(_spans(c.wetted, c.t), contact_spans(c.wetted, c.t), strict=True):
        if first > 0:
            start = _hit_start(run, float(c.t[first - 1]), start)
        spans.append((start, end))
    return _as_the_monitor_counts(run, spans)


def _still_going_on(run: RunData, end: float) -> bool:
    """Whether a contact found to end at ``end`` [s] was still going on when the recording ends: it
    lasts to the body's last state, or to the last report of the channel its spans are read from (the
    first water coupler's, else the first ground's) while that still reports contact. A recording
    that keeps one message in ten keeps each channel's last at a step of its own: a contact of the
    coupler's last report, 3 ms before the stone's last state, was drawn as ended."""
    if end >= run.body.t[-1] - 1e-9:
        return True
    source = ((run.contacts[0].t, run.contacts[0].wetted) if run.contacts else
              (run.grounds[0].t, run.grounds[0].in_contact) if run.grounds else None)
    if source is None or not len(source[0]):
        return False
    t, flags = source
    return bool(flags[-1]) and end >= float(t[-1]) - 1e-9


def _hit_start(run: RunData, dry: float, wet: float) -> float:
    """When the contact first reported wetted at ``wet`` [s], its last report before dry at ``dry``,
    began: the stage monitor's hit after ``dry`` and at or before ``wet`` (its stage changes are all
    kept), else ``wet``. A recording that keeps one message in ten dated the held skip's glide from
    its first kept wetted report, 0.7600 s, for the monitor's hit at 0.7585 s."""
    if run.stages is None:
        return wet
    # (a nanosecond's slack: the monitor's float time of a hit at the wetted report itself)
    hits = run.stages.t[(run.stages.stage == StageId.HIT) & (run.stages.t > dry) & (run.stages.t <= wet + 1e-9)]
    return min(float(hits[0]), wet) if len(hits) else wet


def _as_the_monitor_counts(run: RunData, spans: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Wetted ``spans`` joined into the contacts the stage monitor counts, when it was recorded: two
    spans are one contact unless the stone was out of the water (approach, fly-away, left the pond, on
    the ground) at some time in the dry gap between them. The monitor keeps a contact going while the
    stone is dry but still skimming or coming down (docs/stages.md): the glide at the end of a throw,
    one contact to the monitor, was drawn as several (held_skip: 78 ms from 0.758 s, then 1392 ms from
    0.847 s)."""
    if run.stages is None or len(spans) < 2:
        return spans
    joined = [spans[0]]
    for start, end in spans[1:]:
        if _out_of_the_water_between(run.stages, joined[-1][1], start):
            joined.append((start, end))
        else:
            joined[-1] = (joined[-1][0], end)
    return joined


def _out_of_the_water_between(stages: StageTrack, t0: float, t1: float) -> bool:
    """Whether the stage monitor had the stone out of the water (airborne, or on the solid ground) at
    some time from ``t0`` up to (not at) ``t1`` [s]: the stage in force at ``t0`` or any it changed to
    before ``t1``."""
    first = max(0, int(np.searchsorted(stages.t, t0, side="right")) - 1)
    last = int(np.searchsorted(stages.t, t1, side="left"))
    return any(int(stage) in OUT_OF_THE_WATER for stage in stages.stage[first:last])


def _spans(flags: np.ndarray, t: np.ndarray) -> list[tuple[float, float]]:
    """(start, end) [s] of each run of true ``flags`` at times ``t``: from its first report in
    contact to its first report out of it (an impact reported in one step lasts that step, not 0)."""
    return [(float(t[a]), float(t[min(b + 1, len(t) - 1)])) for a, b in contact_spans(flags, t)]


def _axis_kept(orientation: np.ndarray) -> bool:
    """Whether the body's axis stays where it began over ``orientation`` (n, 4) (w, x, y, z): a held
    attitude's does (its spin turns it about that axis only), a script's turns."""
    axis = np.stack(body_axis(orientation.T), axis=1)  # (each of w, x, y, z a column of states)
    return bool(len(axis) == 0 or np.abs(axis - axis[0]).max() <= 1e-9)


def _motion_direction(run: RunData, t: float) -> np.ndarray:
    """The body's horizontal direction of motion (2,) at ``t`` [s] (its last state before), +x when
    it moves straight up or down."""
    i = max(0, int(np.searchsorted(run.body.t, t, side="right")) - 1)
    v = run.body.velocity[i, :2] if len(run.body.t) else np.zeros(2)
    speed = float(np.hypot(*v))
    return v / speed if speed > 0.0 else np.array([1.0, 0.0])


def figure_contacts(run: RunData) -> Figure | None:
    """Forces during each contact (the first :data:`MAX_CONTACTS`), each titled with its peak (the
    water's largest vertical force over the body's weight under its own gravity, ``run.gravity``, in
    that g, as the stage monitor reports it) and drawn against the level a disk bounces above
    (BOUNCE_G), or None without contacts or without a channel of forces to draw (a recording that
    left them out)."""
    every = contact_intervals(run)
    intervals = every[:MAX_CONTACTS]
    if not intervals or not (run.contacts or run.grounds or run.wrenches):
        return None
    # a restart's first skip record is not skip 1: contacts are numbered as the run's skips are, and
    # without a skip record in it, after the skips its monitor had counted (a glide after the fourth
    # skip, restarted, was "contact 1")
    first = min((r.index for r in run.skips), default=None)
    if first is None:
        first = 1 + (int(run.stages.skips[max(0, np.searchsorted(run.stages.t, intervals[0][0], "right") - 1)])
                     if run.stages is not None and len(run.stages.t) else 0)
    cols = min(2, len(intervals))
    rows = -(-len(intervals) // cols)
    fig = Figure(figsize=(FIGSIZE[0], 2.8 * rows + 0.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False).ravel())
    for k, (ax, (start, end)) in enumerate(zip(axes, intervals, strict=False)):
        pad = CONTACT_MARGIN * max(end - start, 1e-3)
        # the margins never reach into the neighbouring contacts (their force peaks are not this one's)
        before = start - intervals[k - 1][1] if k > 0 else math.inf
        after = intervals[k + 1][0] - end if k + 1 < len(intervals) else math.inf
        lo, hi = start - min(pad, 0.5 * before), end + min(pad, 0.5 * after)

        def window(t: np.ndarray, lo: float = lo, hi: float = hi) -> np.ndarray:
            return (t >= lo) & (t <= hi)

        # the body's own gravity, the monitor's unit of peak_g (a run on Mars was drawn against 9.81)
        weight = run.body.mass * run.gravity
        along = _motion_direction(run, start)  # the horizontal forces are drawn along the motion
        peak = 0.0  # the water's largest vertical force over the weight during the contact [g]
        for c in run.contacts:
            m = window(c.t)
            ms = (c.t[m] - start) * 1e3
            during = (c.t >= start) & (c.t <= end)
            if during.any() and weight > 0.0:  # (a weightless body has no peak in g)
                vertical = (c.buoyancy + c.pressure + c.friction + c.wave_drag)[during, 2]
                peak = max(peak, float(vertical.max()) / weight)
            # (along x alone, a throw along +y lost its drag: flat at 0)
            effects = (("pressure z", c.pressure[m, 2], "-"), ("buoyancy z", c.buoyancy[m, 2], "-"),
                       ("friction along the motion", c.friction[m, :2] @ along, "--"),
                       ("wave drag along the motion", c.wave_drag[m, :2] @ along, "--"))
            for name, values, style in effects:
                if np.any(values):
                    ax.plot(ms, values, style, linewidth=1.2, label=name)
        for w, color in zip(run.wrenches, WRENCH_COLORS * len(run.wrenches), strict=False):
            m = window(w.t)
            ms = (w.t[m] - start) * 1e3
            ax.plot(ms, w.force[m, 2], color=color, linewidth=1.0, label=f"{w.topic} z")
            ax.plot(ms, w.force[m, :2] @ along, color=color, linewidth=1.0, linestyle=":",
                    label=f"{w.topic} along the motion")
        # a skip's own record has the monitor's peak over every step: a thinned recording's samples miss it
        # (and, of a restart begun in the contact, the steps before the restart too)
        record = next((r for r in run.skips if start - 1e-9 <= r.touchdown_time <= end + 1e-9), None)
        if record is not None:
            peak = float(record.peak_g)
        for g in run.grounds:
            m = window(g.t)
            ms = (g.t[m] - start) * 1e3
            dots = "o" if m.sum() < 5 else None  # an impact is a step or two: points, not an invisible line
            # each report's force is held over its step (an impulse spread over one step), not ramped
            ax.plot(ms, g.normal[m], linewidth=1.2, marker=dots, drawstyle="steps-post",
                    label=f"ground normal ({g.topic})")
            ax.plot(ms, g.friction[m], linewidth=1.2, linestyle="--", marker=dots, drawstyle="steps-post",
                    label=f"ground friction ({g.topic})")
        ax.axvspan(0.0, (end - start) * 1e3, color="0.9", zorder=0)
        ax.axhline(0.0, color="0.5", linewidth=0.6)
        if run.contacts and run.body.shape == Shape.DISK and weight > 0.0:
            ax.axhline(BOUNCE_G * weight, color="tab:red", linewidth=0.8, linestyle="-.",
                       label=f"{BOUNCE_G:g} M g: a disk bounces above about this (Tang et al. 2021)")
        peak_text = f", peak {peak:.1f} g" if run.contacts and weight > 0.0 else ""
        # a contact still going on when the recording ends lasted at least this long, not this long
        going_on = _still_going_on(run, end)
        ends = ("+ (cut off)" if run.cut_off else "+ (to the run's end)") if going_on else ""
        touchdown = run.touchdown_before if k == 0 and run.touchdown_before is not None and \
            start <= run.body.t[0] + run.step + 1e-9 else None
        if touchdown is None:
            # (to 0.1 ms, as the summary gives touchdowns: on half-millisecond steps stored a hair below
            # the half, 0.8415 s read 0.841 at three places)
            ax.set_title(f"contact {first + k}: t = {start:.4f} s, {1e3 * (end - start):.1f} ms{ends}{peak_text}",
                         fontsize="small")
            ax.set_xlabel("time since touchdown [ms]")
        else:  # a restart that began in this contact: its touchdown before the recording's first state
            restart = run.restart if run.restart is not None else float(run.body.t[0])
            # the whole contact's peak when a skip record gives it, else the samples' after the restart
            peak_when = "" if record is not None or not run.contacts else " after the restart"
            ax.set_title(f"contact {first + k}: touchdown t = {touchdown:.4f} s, restart t = {restart:.4f} s;\n"
                         f"{1e3 * (end - touchdown):.1f} ms{ends}{peak_text}{peak_when}", fontsize="small")
            # (the panel's time runs from its interval's start: the touchdown when a skip record dates
            # it, else the restart; it said "since the restart" from the touchdown, 24 ms before it)
            since_touchdown = abs(start - touchdown) <= run.step + 1e-9
            ax.set_xlabel(f"time since the {'touchdown' if since_touchdown else 'restart'} [ms]")
        ax.set_ylabel("force [N]")
        ax.grid(True, alpha=0.3)
    # one legend below the panels: inside the first it hid its force peak (the reference skip's 79 N)
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside lower center", fontsize="x-small", ncols=min(3, len(handles)))
    for ax in axes[len(intervals):]:
        ax.set_visible(False)
    shown = (f"the first {len(intervals)} of its {len(every)} contacts" if len(every) > len(intervals)
             else "each contact")
    fig.suptitle(f"{run.scene}: forces during {shown}")
    return fig


WATER_FIGURE = "water.png"  # the one figure of a run with water alone

FIGURES = {
    "trajectory.png": figure_trajectory,
    "motion.png": figure_motion,
    "energy.png": figure_energy,
    "contacts.png": figure_contacts,
}


def figure_water(rec: Recording, topic: str) -> Figure:
    """The water of one WaterField channel over time: its highest crest and lowest trough above the
    rest level [mm], the change of its volume relative to the first field, and its lattice energy
    (:mod:`components.water.diagnostics`: in a closed basin without losses it oscillates about
    the explicit step's invariant and never drifts; it falls as waves leave through
    absorbing edges)."""
    rest = water_rest_level(rec, topic)
    rows = [(t, float(f.height.max()) - rest, float(f.height.min()) - rest, f.volume, f.energy)
            for t, f in iter_fields(rec, topic)]
    t, crest, trough, volume, energy = (np.array(column) for column in zip(*rows, strict=True))
    fig = Figure(figsize=(FIGSIZE[0], 1.6 * FIGSIZE[1]), layout="constrained")
    ax_wave, ax_volume, ax_energy = fig.subplots(3, 1, sharex=True)
    ax_wave.plot(t, crest * 1000, color="#1f5fa8", label="highest crest")
    ax_wave.plot(t, trough * 1000, color="#7fa8d8", label="lowest trough")
    ax_wave.axhline(0.0, color=WATER_LINE_COLOR, linewidth=0.8)
    ax_wave.set_ylabel("above rest [mm]")
    ax_wave.legend(loc="upper right", fontsize="small")
    ax_wave.set_title(f"{rec.metadata.get('scene', rec.path.stem)}: {topic}")
    ax_volume.plot(t, (volume - volume[0]) / volume[0] if volume[0] else volume - volume[0], color="#404040")
    ax_volume.set_ylabel("volume change [-]")
    ax_energy.plot(t, energy, color="#b03030")
    ax_energy.set_ylabel("lattice energy [J]")
    ax_energy.set_xlabel("t [s]")
    return fig


def plot_run(recording: str | Path, out_dir: str | Path, *, body: str | None = None,
             dpi: int = 120) -> tuple[list[Path], list[tuple[str, str]]]:
    """Write the figures of a recording into ``out_dir``; returns (written paths, [(name, why skipped)])."""
    out_dir = Path(out_dir)
    rec = Recording(recording)  # opened (and its CRCs checked) once, for either set of figures
    fields = topics_of(rec, WaterField)
    if body is None and fields and not topics_of(rec, BodyState):  # water alone
        with output_folder(out_dir):
            path = out_dir / WATER_FIGURE
            _save(figure_water(rec, fields[0]), path, dpi)
        why = ("the recording holds no body's state (its channels were left out: --record)"
               if scene_publishes(rec, (BodyState,)) else "no body in this run")
        return [path], [(", ".join(FIGURES), why + _removed_from_before(out_dir, list(FIGURES)))]
    run = load_run(rec, body)
    warn_ended_early(rec, "the figures")  # figures of what there is, said to end where the run did
    figures: dict[Path, Figure] = {}
    skipped = []
    for name, make in FIGURES.items():
        fig = make(run)
        if fig is None:
            # a run without contacts, or a recording that left their channels out (--record)
            why = ("no contact in this run" if run.contacts or run.grounds
                   else "the recording holds no contact channel (WaterContact or GroundContact)"
                   if _reports_contacts(rec) else "the scene has neither water nor ground to touch")
            skipped.append((name, why))
            continue
        figures[out_dir / name] = fig
    with output_folder(out_dir):
        _save_together(figures, dpi)
    skipped = [(name, why + _removed_from_before(out_dir, [name])) for name, why in skipped]
    water_alone = _removed_from_before(out_dir, [WATER_FIGURE])  # (of an earlier water-alone recording)
    if water_alone:
        skipped.append((WATER_FIGURE, "drawn for a recording of water alone" + water_alone))
    return list(figures), skipped


def _removed_from_before(out_dir: Path, names: list[str]) -> str:
    """Remove the figures ``names`` an earlier plot left in ``out_dir``, which this one did not draw
    (its recording has no contacts, or no body): beside the new figures they looked part of the new
    set. What is said of them: '' when there was none."""
    removed, left = [], []
    for name in names:
        try:
            refuse_read_only(out_dir / name)  # (as a figure drawn is not put over it)
        except PermissionError:
            left.append(f"{name} (read-only)")
            continue
        try:
            (out_dir / name).unlink()
        except FileNotFoundError:
            continue
        except OSError as exc:  # (a folder of that name, a folder it may not remove from: left, and said)
            left.append(f"{name} ({exc.strerror})")
            continue
        removed.append(name)
    return ((f"; the {', '.join(removed)} there from an earlier plot removed" if removed else "")
            + (f"; the {', '.join(left)} there from before left as it is" if left else ""))


def _save_together(figures: dict[Path, Figure], dpi: int) -> None:
    """Write each figure as the PNG at its path, all of them or none: each is drawn into a temporary
    file beside its path first, and they are moved into place once all are drawn, so a plot cut short
    (Ctrl-C, a full disk) or a figure that cannot be put in place (its name taken by a folder) leaves
    the folder as it was, not a set that looks finished with some figures from before. An OSError
    names the figure, not its temporary file."""
    staged: list[tuple[Path, Path]] = []  # (temporary file, figure)
    try:
        for path, fig in figures.items():
            # a new file of a unique name: a fixed one (energy.png.tmp) was written over and removed,
            # whatever it held (a recording so named, the one plotted, was lost)
            tmp = new_temporary(path)
            staged.append((tmp, path))
            try:
                fig.savefig(tmp, dpi=dpi, format="png")
            except OSError as exc:
                raise named_for(exc, tmp, path) from None
        move_together(staged)
    finally:
        for tmp, _ in staged:
            remove_quietly(tmp)  # (moved already, unless the plot failed)


def _save(fig: Figure, path: Path, dpi: int) -> None:
    """Write ``fig`` as the PNG ``path``, whole or not at all (a full disk leaves no truncated
    picture); an OSError names ``path``."""
    with written_whole(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
