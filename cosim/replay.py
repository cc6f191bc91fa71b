"""Replay from a recording alone.

(a) :func:`replay_component` drives one component with its recorded inputs, reconstructed with the
scheduler's own delivery rule, and compares every output with the recorded one, bit for bit,
reporting the first divergence (time, port, field).

(b) :func:`restart_simulation` rebuilds the whole scene at the nearest recorded checkpoint at or
before a time, optionally with changed settings, ready to run on.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from cosim.codec.json_codec import codec_for
from cosim.component import Component
from cosim.errors import CosimError, RecordingError, StateRestoreError, counted, shortened
from cosim.messages import Message, first_difference
from cosim.record.reader import Recording
from cosim.record.recorder import selected, topic_of
from cosim.scenario import Scene
from cosim.scheduler import Simulation, _Edge, _Slot, gather, gather_start, restore_component, saved_messages
from cosim.timebase import NS_PER_S, exact_seconds


@dataclass
class Divergence:
    """Where a replayed component first disagreed with the recording."""

    time_ns: int
    port: str
    field: str
    expected: str
    got: str

    def __str__(self) -> str:
        return (f"first divergence at t = {self.time_ns / NS_PER_S:.9g} s on port {self.port!r}, "
                f"field {self.field!r}: recorded {self.expected}, replayed {self.got}")


@dataclass
class ReplayReport:
    component: str
    steps: int
    messages_compared: int
    divergence: Divergence | None
    cut_off_ns: int | None = None  # the recording has no final status (the run was cut off): replayed up to here
    step_seconds: float = 0.0  # wall time of the component's steps but the first [s] (that one loads compiled code)

    @property
    def ok(self) -> bool:
        return self.divergence is None

    def per_step_us(self) -> float | None:
        """The component's own cost [us] a step on its recorded inputs, alone (None under two steps)."""
        return self.step_seconds / (self.steps - 1) * 1e6 if self.steps > 1 else None

    def __str__(self) -> str:
        cut = ("" if self.cut_off_ns is None else
               f" (the recording is incomplete: replayed up to its last output, "
               f"t = {exact_seconds(self.cut_off_ns)} s)")
        if self.ok:
            cost = self.per_step_us()
            took = ("" if cost is None else f"; {cost:.3g} us a step" if cost < 1000 else
                    f"; {cost / 1000:.3g} ms a step")
            return (f"{self.component}: {counted(self.steps, 'step')} replayed, "
                    f"{counted(self.messages_compared, 'output')} identical bit for bit{took}{cut}")
        return f"{self.component}: {self.divergence} (after {counted(self.steps, 'step')}){cut}"


def _show(msg: Message | None, field: str) -> str:
    if msg is None:
        return "nothing"
    if field in ("<type>", "<message>"):
        return type(msg).__name__
    text = repr(getattr(msg, field))
    return text if len(text) < 80 else text[:77] + "..."


def _divergence(stamp: int, port: str, field: str, want: Message, got: Message) -> Divergence:
    """Where ``got`` first differs from ``want`` in ``field``: an array field by its first element
    that differs, its index and both values to every digit (numpy's print of two arrays a bit apart
    showed them alike, and a window's over several lines, the report one line a component)."""
    a = getattr(want, field, None) if field not in ("<type>", "<message>", "<encoding>") else None
    b = getattr(got, field, None) if a is not None else None
    if isinstance(a, np.ndarray) and isinstance(b, np.ndarray):
        if a.shape != b.shape:
            return Divergence(stamp, port, field, f"shape {a.shape}", f"shape {b.shape}")
        if a.dtype != b.dtype or a.size == 0:
            return Divergence(stamp, port, field, f"{a.dtype} {a.shape}", f"{b.dtype} {b.shape}")
        # element by element, bit for bit (NaNs of the same bits alike, as the comparison takes them)
        bits_a = np.ascontiguousarray(a).reshape(-1).view(np.uint8).reshape(a.size, -1)
        bits_b = np.ascontiguousarray(b).reshape(-1).view(np.uint8).reshape(b.size, -1)
        differs = np.flatnonzero((bits_a != bits_b).any(axis=1))
        if differs.size:
            index = np.unravel_index(int(differs[0]), a.shape)
            where = ", ".join(str(int(i)) for i in index)
            return Divergence(stamp, port, f"{field}[{where}]", repr(a[index].item()), repr(b[index].item()))
    return Divergence(stamp, port, field, _show(want, field), _show(got, field))


class _RecordedSource:
    """One recorded output channel, revealed to an edge as the live scheduler would have shown it."""

    def __init__(self, messages: list[tuple[int, Message]], every: int, dt_ns: int, before_receiver: bool):
        # publish tick of each message: a step output stamped t was published at tick t/dt - every;
        # t = 0 messages are initial outputs, published before tick 0
        self.pending = [((stamp // dt_ns - every) if stamp else -1, stamp, msg) for stamp, msg in messages]
        self.before = before_receiver
        self.slot = _Slot()
        self.next = 0

    def drop_published_before(self, tick: int) -> None:
        """Leave out the messages published before ``tick``: a restart's slot holds them already."""
        self.pending = [entry for entry in self.pending if entry[0] >= tick]

    def advance(self, tick: int) -> None:
        pending = self.pending
        while self.next < len(pending):
            ptick, stamp, msg = pending[self.next]
            if ptick < tick or (ptick == tick and self.before):
                self.slot.publish(stamp, msg)
                self.next += 1
            else:
                break


def check_replayable(rec: Recording, component: str | None = None) -> None:
    """What keeps every component of ``rec`` (or ``component`` alone) from being replayed, as a
    RecordingError (said once, not once a component): an exchange it needs not recorded, or a
    restart's checkpoint not there."""
    scene = rec.scene()
    if component is None or component in scene.components:  # (one it does not have is said by replay_component)
        _refuse_a_selection(rec, scene, component)
    _restart_checkpoint(rec, scene)


def _refuse_a_selection(rec: Recording, scene: Scene, component: str | None = None) -> None:
    """Refuse (RecordingError) a recording that left out an exchange the replay needs: every one of
    them kept one in ``record.every``, or, of ``record.channels``, a channel it does not match: any
    component's output for the whole replay, ``component``'s own outputs and inputs for its own.
    (Any ``record.channels`` was refused: ``--record '*'``, which keeps every exchange, and a
    selection holding all a component needs.)"""
    if scene.record.every != 1:
        raise RecordingError(f"{rec.path}: cannot replay: the run recorded a selection of its exchanges "
                             f"(record.every {scene.record.every}); replay needs every exchange")
    patterns = scene.record.channels
    if patterns is None:
        return
    if component is None:
        needed = [f"/{name}/{port}" for name in scene.order for port in scene.components[name].cls.outputs]
    else:
        needed = [f"/{component}/{port}" for port in scene.components[component].cls.outputs]
        needed += [f"/{c.source}/{c.source_port}" for c in scene.connections if c.target == component]
    left_out = [topic for topic in dict.fromkeys(needed) if not selected(topic, patterns)]
    if left_out:
        shown = ", ".join(left_out[:3]) + (f" and {len(left_out) - 3} more" if len(left_out) > 3 else "")
        raise RecordingError(f"{rec.path}: cannot replay: the run's record.channels left out {shown}; "
                             "replay needs every exchange it re-runs")


def replay_component(rec: Recording, name: str, component: Component | None = None) -> ReplayReport:
    """Re-run component ``name`` alone on its recorded inputs and compare its outputs bit for bit.

    ``component`` replaces the one the scene would build (e.g. a modified version under test).
    """
    scene = rec.scene()
    if name not in scene.components:
        raise RecordingError(f"{rec.path}: no component {name!r} in the recorded scene "
                             f"(components: {', '.join(scene.order)})")
    _refuse_a_selection(rec, scene, name)
    status = rec.status()
    cfg = scene.components[name]
    comp = component if component is not None else cfg.build()
    dt_ns = scene.dt_ns
    position = {n: i for i, n in enumerate(scene.order)}
    restart = _restart_checkpoint(rec, scene)  # a recording made by a restart (replay --from) begins at its checkpoint

    def channel(component_name: str, port: str, msg_type: type[Message]) -> list[tuple[int, Message]]:
        topic = topic_of(component_name, port)
        if topic not in rec.channels:
            return []
        return rec.messages(topic, msg_type)

    sources: list[_RecordedSource] = []
    plan: list[tuple[str, list[_Edge]]] = []
    topics: dict[str, str] = {}  # input port -> the channel feeding it (the first, for words)
    for port, spec in comp.inputs.items():
        edges = []
        for conn in scene.connections:
            if conn.target != name or conn.target_port != port:
                continue
            topic = topic_of(conn.source, conn.source_port)
            topics.setdefault(port, topic)
            recorded = channel(conn.source, conn.source_port, spec.type)
            # (a channel declared but holding no message, as well as none: the component was fed None,
            # and failed on it as if it had a fault of its own)
            if spec.required and not recorded and restart is None:
                held = sorted(rec.channels)
                shown = ", ".join(held[:6]) + (", ..." if len(held) > 6 else "")
                raise RecordingError(f"{rec.path}: cannot replay {name!r}: its input {port!r} comes from {topic}, "
                                     "which the recording holds no message of (the run ended before its first, "
                                     f"or the attached scene is not the one that made the channels: {shown})")
            source_cfg = scene.components[conn.source]
            src = _RecordedSource(recorded, source_cfg.every, dt_ns, position[conn.source] < position[name])
            sources.append(src)
            edge = _Edge(conn, src.slot, spec.event)
            if restart is not None:  # the port's last messages and the edge's deliveries, as the restart had them
                cp = restart[1]
                src.slot.entries = saved_messages(cp, conn.source, conn.source_port, spec.type)
                edge.undelivered(cp, edge.saved_index(cp, scene.connections.index(conn)), spec.type)
                # what the source published before the checkpoint (a step spanning it, recorded again
                # as the restart began) is in those entries already
                src.drop_published_before(restart[0] // dt_ns)
            edges.append(edge)
        plan.append((port, edges))
        if len(edges) == 1:  # as the simulation tells it (Component.source_steps)
            comp.source_steps[port] = scene.step_of(edges[0].spec.source)

    expected: dict[str, dict[int, Message]] = {
        port: dict(channel(name, port, spec.type)) for port, spec in comp.outputs.items()}
    compared = 0

    def compare(stamp: int, outputs: dict[str, Message], steps: int, cut: bool = False) -> ReplayReport | None:
        """The first output at ``stamp`` that differs from the recorded one; ``cut``: the recording
        was cut inside this step, so an output it holds nothing of is where it ends, not a difference."""
        nonlocal compared
        for port in comp.outputs:
            want = expected[port].get(stamp)
            got = outputs.get(port)
            if want is None and (got is None or cut):
                continue
            compared += 1
            if want is None or got is None:
                return ReplayReport(name, steps, compared, Divergence(
                    stamp, port, "<message>", "nothing" if want is None else type(want).__name__,
                    "nothing" if got is None else type(got).__name__))
            if codec_for(type(got)).encode(got) != codec_for(type(want)).encode(want):
                field = first_difference(want, got) or "<encoding>"
                return ReplayReport(name, steps, compared, _divergence(stamp, port, field, want, got))
        return None

    every = cfg.every
    # a run cut off (killed, its writer gone) left no final status: its recording is replayed up to
    # the component's last recorded output, the last step whose outputs and inputs are all there
    # (a step from tick t ends at t + every: the last one to replay starts at cut_off / dt - every)
    cut_off = None
    if status is None:
        cut_off = max((max(by_time) for by_time in expected.values() if by_time), default=0)
        end_tick, stop_ns = cut_off // dt_ns - every + 1, cut_off
    else:
        end_tick, stop_ns = status.tick, status.time * NS_PER_S
    first_tick = 0
    if restart is None:
        bad = compare(0, comp.start_outputs(), 0)
        if bad:
            bad.cut_off_ns = cut_off
            return bad
        for src in sources:
            src.advance(0)  # the initial outputs (and what steps before this component at tick 0 published)
        # (not checked for gaps: a required input fed by a direct edge has nothing before its source's
        # first step, in the run as here: ping_pong's pong begins without ping's output, and every
        # recording of it was refused as having a gap)
        comp.begin(gather_start(plan))
    else:  # the component as the restart's checkpoint holds it, from its first step after it
        stamp, cp = restart
        try:
            restore_component(comp, cp["components"][name], stamp)
        except StateRestoreError as exc:  # said as the restart of a whole scene says it, the checkpoint named
            raise _cannot_restart(rec, stamp, str(exc)) from None
        first_tick = -(-(stamp // dt_ns) // every) * every
    steps = 0
    seconds = 0.0  # in the component's steps, the first one left out
    clock = time.perf_counter
    for tick in range(first_tick, end_tick, every):
        start, end = tick * dt_ns, (tick + every) * dt_ns
        for src in sources:
            src.advance(tick)
        inputs = gather(plan, start, end)
        _check_recorded(rec, name, comp, inputs, start, topics)
        began = clock()
        outputs = comp.step_gathered(start, end - start, inputs, cfg.on_unstable)
        if steps:
            seconds += clock() - began
        steps += 1
        at_cut = cut_off is not None and end == cut_off  # maybe cut between this step's outputs
        bad = compare(end, outputs, steps, at_cut)
        if bad:
            bad.cut_off_ns = cut_off
            return bad
        if comp.stop_reason is not None and end >= stop_ns:
            break
    return ReplayReport(name, steps, compared, None, cut_off, seconds)


def _restart_checkpoint(rec: Recording, scene: Scene) -> tuple[int, dict] | None:
    """(time [ns], checkpoint) a recording made by a restart began at (its metadata's ``start_ns``,
    the checkpoint recorded then); None for a run from t = 0. A restart whose recording does not
    hold that checkpoint cannot be replayed (RecordingError, saying why it is not there)."""
    if not rec.restart_ns:
        return None
    checkpoint = rec.checkpoint_at(rec.restart_ns)  # (only that one is decoded)
    if checkpoint is None:
        lost = _why_no_checkpoint(rec)
        why = ("recorded without the checkpoint it started from (record.checkpoint_every 0)" if lost is None else
               f"and the checkpoint it started from is not in the file ({lost})")
        raise RecordingError(f"{rec.path}: cannot replay: a restart from t = {exact_seconds(rec.restart_ns)} s, {why}: "
                             "replay the recording it was restarted from")
    # the checkpoint's form is the reader's to check; whether it fits the scene that ran, here (a
    # component or an edge it lacks ended in an internal KeyError or IndexError)
    began = f"the checkpoint at {exact_seconds(rec.restart_ns)} s it restarted from"
    missing = [name for name in scene.order if name not in checkpoint["components"]]
    if missing:
        raise RecordingError(f"{rec.path}: cannot replay: {began} holds no state of {missing[0]!r}, a component of "
                             "the recorded scene")
    if len(checkpoint["edges"]) != len(scene.connections):
        raise RecordingError(f"{rec.path}: cannot replay: {began} holds the deliveries of "
                             f"{len(checkpoint['edges'])} connections, the recorded scene has "
                             f"{len(scene.connections)}")
    return rec.restart_ns, checkpoint


def _why_no_checkpoint(rec: Recording) -> str | None:
    """Why ``rec`` holds no checkpoint where its run records one, as its scene and status say: None
    when it recorded none (record.checkpoint_every 0); else its run failed (a full disk: what was
    not yet on disk is lost), or it was cut off, or, neither said, it was taken out."""
    scene, _ = _recorded_scene(rec)
    if scene is not None and scene.record.checkpoint_every == 0:
        return None
    status = rec.status()
    if status is None:
        return "the recording was cut off: it holds no final status"
    if status.status == "failed":
        return f"its run failed: {shortened(status.reason, 200)}"
    every = f", though its scene records one every {scene.record.checkpoint_every:g} s" if scene is not None else ""
    return f"its run ended {status.status}{every}: it was taken out of the file"


def _check_recorded(rec: Recording, name: str, comp: Component, inputs: dict[str, Message | None], start_ns: int,
                    topics: dict[str, str]) -> None:
    """Refuse a step whose required input the recording holds nothing of at or before its start: a gap
    (a chunk that ``repair`` left out, the first among them) that the component would be fed None
    through, and fail on as if it had a fault of its own (an internal error, exit 1)."""
    for port, spec in comp.inputs.items():
        if spec.required and inputs.get(port) is None and port in topics:
            raise RecordingError(
                f"{rec.path}: cannot replay {name!r} at t = {exact_seconds(start_ns)} s: its input {port!r} "
                f"({topics[port]}) has no message recorded at or before then: the recording has a gap there "
                "(a damaged chunk left out by repair); replay from a checkpoint after it (--from)")


def _cannot_restart(rec: Recording, stamp: int, why: str) -> RecordingError:
    """The checkpoint at ``stamp`` [ns] holds a state this scene's components do not take, ``why``."""
    return RecordingError(f"{rec.path}: cannot restart from the checkpoint at {exact_seconds(stamp)} s: {why}")


def _no_checkpoint(rec: Recording, from_ns: int, stamps: list[int]) -> RecordingError:
    """Why there is no checkpoint at or before ``from_ns`` to restart from, and what to do."""
    times = ", ".join(f"{exact_seconds(s)}" for s in stamps[:10]) or "none"
    if rec.restart_ns and (from_ns < rec.restart_ns or not stamps):
        # a restart's recording begins at its checkpoint: what came before is in the one it came from,
        # and so are the checkpoints of one recorded without any
        began = f"{exact_seconds(rec.restart_ns)} s"
        if stamps:
            hint = (f"this recording is a restart from {began}: restart from the recording it came from, or "
                    f"from {began} or later")
        else:
            lost = _why_no_checkpoint(rec)
            none = "recorded without checkpoints" if lost is None else f"and holds no checkpoint ({lost})"
            hint = f"this recording is a restart from {began}, {none}: restart from the recording it came from"
    elif stamps:
        hint = f"restart from {exact_seconds(stamps[0])} s or later"
    else:
        lost = _why_no_checkpoint(rec)
        hint = ("record with record.checkpoint_every > 0" if lost is None else
                f"the recording holds none ({lost})")
    return RecordingError(f"{rec.path}: no checkpoint at or before t = {exact_seconds(from_ns)} s "
                          f"(checkpoints at [s]: {times}); {hint}")


def _same(a: Any, b: Any) -> bool:
    """Whether two parameter values are equal (arrays element by element)."""
    try:
        return bool(a == b)
    except (ValueError, TypeError):  # arrays, or containers of them: no single truth value
        return repr(a) == repr(b)


def _recorded_scene(rec: Recording) -> tuple[Scene | None, str]:
    """The recorded scene, without a restart's overrides, or (None, why it cannot be loaded: a file it
    names has moved, which a restart's --set may give again)."""
    try:
        return rec.scene(), ""
    except CosimError as exc:
        return None, shortened(str(exc), 200)


def _refuse_start_only_overrides(sim: Simulation, recorded: Scene | None, unread: str, overrides: list[str],
                                 stamp: int) -> None:
    """Refuse an override of what only sets a component's state at t = 0 (its ``start_only_params``):
    a restart takes that state from the checkpoint at ``stamp`` [ns], so the override would do
    nothing. A key naming the parameter (``components.stone.position``) is refused as such; one
    replacing whole components (``components.stone``, ``components``) when a start-only parameter
    of theirs differs from the ``recorded`` one (``unread``: why the recorded scene is None)."""
    for override in overrides:
        key = override.partition("=")[0].strip()
        path = key.split(".")
        if path[0] != "components":
            continue
        if len(path) >= 3:
            if path[1] in sim.components:
                comp, param = sim.components[path[1]], path[2].partition("[")[0]
                if param in comp.start_only_params:
                    raise RecordingError(f"--set {key}: sets {path[1]}'s state at t = 0, which a restart takes "
                                         f"from the checkpoint at {exact_seconds(stamp)} s instead; to change it, "
                                         "run the scene from the start (cosim run)")
            continue
        if recorded is None:
            raise RecordingError(f"--set {key}: replaces whole components, whose values that set the state at "
                                 "t = 0 a restart must compare with the recorded ones, but the recorded scene "
                                 f"cannot be loaded ({unread}); set the values one by one "
                                 "(components.NAME.KEY=VALUE)")
        names = path[1:2] if len(path) == 2 else list(sim.components)
        for name in names:
            if name not in sim.components or name not in recorded.components:
                continue  # a component the recording has none of: the checkpoint holds no state to restore
            was, now = recorded.components[name].params, sim.scene.components[name].params
            changed = sorted(param for param in sim.components[name].start_only_params
                             if not _same(getattr(was, param, None), getattr(now, param, None)))
            if changed:
                verb = "sets" if len(changed) == 1 else "set"
                raise RecordingError(f"--set {key}: changes {name}'s {_changed(was, now, changed)}, which only "
                                     f"{verb} its state at t = 0: a restart takes that state from the checkpoint "
                                     f"at {exact_seconds(stamp)} s instead; keep the recorded values, or run the "
                                     "scene from the start (cosim run)")


def _changed(was: Any, now: Any, names: list[str]) -> str:
    """``start (recorded {...}, given {...})`` for each parameter of ``names``, shortened."""
    return shortened("; ".join(f"{name} (recorded {getattr(was, name, None)!r}, given {getattr(now, name, None)!r})"
                               for name in names), 200)


def _state_times(sim: Simulation, recorded: Scene | None, cp: dict[str, Any], stamp: int) -> dict[str, int]:
    """The time [ns] each component's restored state is at: the end of its step that spans the
    checkpoint at ``stamp`` (a component stepping every few ticks steps from before the checkpoint to
    after it), else the checkpoint's time. That end is the stamp of the step's outputs the checkpoint
    holds (``ahead``); for a component none of whose outputs it holds, the end of its step on the
    recorded grid (its recorded every, the checkpoint's dt). A component whose recorded every cannot
    be read (the recorded scene no longer loads) is left out."""
    times: dict[str, int] = {}
    for when, channel, _ in cp.get("ahead", []):  # (not in checkpoints of older recordings)
        name = channel.partition(".")[0]
        if when > stamp:
            times[name] = max(times.get(name, when), when)
    tick, dt_ns = cp["tick"], cp["dt_ns"]
    for runner in sim.runners:
        if runner.name not in times and recorded is not None and runner.name in recorded.components:
            every = recorded.components[runner.name].every
            times[runner.name] = -(-tick // every) * every * dt_ns
    return times


def _check_step_grids(rec: Recording, sim: Simulation, recorded: Scene | None, cp: dict[str, Any],
                      stamp: int) -> None:
    """Refuse a restart whose dt or every would start a component's steps elsewhere than where its
    restored state is: its state would be stamped with a time it is not at (a step spanning the
    checkpoint already took it past it; a later first step would skip time). Each component's
    first step from the checkpoint on must begin at its state's time."""
    dt_ns = sim.dt_ns
    tick = stamp // dt_ns
    state_times = _state_times(sim, recorded, cp, stamp)
    for runner in sim.runners:
        name, every = runner.name, runner.every
        state_ns = state_times.get(name)
        first_ns = -(-tick // every) * every * dt_ns  # where its first step at or after the checkpoint begins
        if state_ns is None or first_ns == state_ns:
            continue
        spans = " (its step spans the checkpoint)" if state_ns > stamp else ""
        gap = abs(state_ns - first_ns) / 1e6
        what = (f"{gap:g} ms before it, counting that time twice" if first_ns < state_ns else
                f"{gap:g} ms after it, skipping that time")
        fits = _on_grid(rec, recorded, name, state_ns, tick, dt_ns)
        raise RecordingError(
            f"{rec.path}: cannot restart from the checkpoint at {exact_seconds(stamp)} s with dt = "
            f"{exact_seconds(dt_ns)} s: {name} (every {every}, a step of {every * dt_ns / 1e6:g} ms) has its state "
            f"at t = {state_ns / NS_PER_S:.9g} s{spans}, but its first step would begin at t = "
            f"{first_ns / NS_PER_S:.9g} s, {what}; {fits}, or run the scene from t = 0 (cosim run)")


def _on_grid(rec: Recording, recorded: Scene | None, name: str, state_ns: int, tick: int, dt_ns: int) -> str:
    """What to give component ``name`` so that its steps, from the restart's ``tick`` of ``dt_ns``
    on, begin at its state's time ``state_ns``: its recorded step in ticks of this dt, when that
    fits, else the recorded dt and every."""
    if recorded is None or name not in recorded.components:
        return f"give {name} a dt and every whose steps pass through t = {state_ns / NS_PER_S:.9g} s"
    cfg, recorded_dt = recorded.components[name], rec.dt_ns
    span = cfg.every * recorded_dt
    every, rest = divmod(span, dt_ns)
    if not rest and every >= 1 and -(-tick // every) * every * dt_ns == state_ns:
        return (f"give {name} a step whose grid passes through t = {state_ns / NS_PER_S:.9g} s, such as its "
                f"recorded {span / 1e6:g} ms: every {every} with this dt (components.{name}.every={every})")
    return (f"give {name} a step whose grid passes through t = {state_ns / NS_PER_S:.9g} s, such as the "
            f"recorded dt = {exact_seconds(recorded_dt)} s with every {cfg.every}")


def _same_run(key: str) -> bool:
    """Whether an override of ``key`` leaves the run itself as it was: its end, or what is recorded."""
    return key == "until" or key == "record" or key.startswith("record.")


def restart_simulation(rec: Recording, from_ns: int, overrides: list[str] | None = None,
                       observers: list | None = None) -> tuple[Simulation, int]:
    """A simulation of the recorded scene (with ``overrides``) restored at the last checkpoint at or
    before ``from_ns``; returns it with the checkpoint time [ns]."""
    status = rec.status()
    end_ns = round(status.time * NS_PER_S) if status is not None else rec.end_ns
    if from_ns > end_ns:
        # the checkpoint before it would be the run's last: a restart there is not what was asked
        raise RecordingError(f"{rec.path}: --from {exact_seconds(from_ns)} s is after the recorded run's end "
                             f"(t = {exact_seconds(end_ns)} s); restart from a time within it")
    stamps, stamp, cp = rec.checkpoint_at_or_before(from_ns)
    if stamp is None or cp is None:
        raise _no_checkpoint(rec, from_ns, stamps)
    scene = rec.scene(overrides)
    recorded, unread = _recorded_scene(rec)  # what the checkpoint was made with, to compare the overrides with
    sim = Simulation(scene, observers=observers)
    _refuse_start_only_overrides(sim, recorded, unread, overrides or [], stamp)
    try:
        sim.restore(cp)
    except StateRestoreError as exc:  # a component's set_state refused the state it holds, named
        raise _cannot_restart(rec, stamp, str(exc)) from None
    except (ValueError, KeyError, TypeError) as exc:  # (TypeError: a component's state holding a wrong kind of value)
        why = (f"it holds no {exc.args[0]!r}, which this scene's components restore (a component or setting "
               "changed by --set?)" if isinstance(exc, KeyError) else str(exc))
        raise _cannot_restart(rec, stamp, why) from None
    _check_step_grids(rec, sim, recorded, cp, stamp)
    if any(not _same_run(o.partition("=")[0].strip()) for o in overrides or []):
        # another run from here: a stop the original asked for in the checkpoint's tick was asked under
        # its settings (a restart with the stop's own setting changed ended at once, 0 steps), and is
        # asked again on the next step if the new settings still call for it. A later end, or another
        # way of recording, is the same run, which stopped there (--until took a step more)
        sim.stop_reason = None
        for runner in sim.runners:
            runner.comp.stop_reason = None
    return sim, stamp
