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

from cosim.codec.json_codec import codec_for
from cosim.component import Component
from cosim.errors import RecordingError
from cosim.messages import Message, first_difference
from cosim.record.reader import Recording
from cosim.record.recorder import topic_of
from cosim.scheduler import Simulation, _Edge, _Slot, gather, gather_start, restore_component, saved_messages
from cosim.timebase import NS_PER_S


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
               f" (the recording is incomplete: replayed up to its last output, t = {self.cut_off_ns / NS_PER_S:g} s)")
        if self.ok:
            cost = self.per_step_us()
            took = ("" if cost is None else f"; {cost:.3g} us a step" if cost < 1000 else
                    f"; {cost / 1000:.3g} ms a step")
            return (f"{self.component}: {self.steps} steps replayed, {self.messages_compared} outputs "
                    f"identical bit for bit{took}{cut}")
        return f"{self.component}: {self.divergence} (after {self.steps} steps){cut}"


def _show(msg: Message | None, field: str) -> str:
    if msg is None:
        return "nothing"
    if field in ("<type>", "<message>"):
        return type(msg).__name__
    text = repr(getattr(msg, field))
    return text if len(text) < 80 else text[:77] + "..."


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


def replay_component(rec: Recording, name: str, component: Component | None = None) -> ReplayReport:
    """Re-run component ``name`` alone on its recorded inputs and compare its outputs bit for bit.

    ``component`` replaces the one the scene would build (e.g. a modified version under test).
    """
    scene = rec.scene()
    if name not in scene.components:
        raise RecordingError(f"{rec.path}: no component {name!r} in the recorded scene "
                             f"(components: {', '.join(scene.order)})")
    if scene.record.every != 1 or scene.record.channels is not None:
        raise RecordingError(f"{rec.path}: cannot replay: the run recorded a selection of its exchanges "
                             "(record.channels / record.every); replay needs every exchange")
    status = rec.status()
    cfg = scene.components[name]
    comp = component if component is not None else cfg.build()
    dt_ns = scene.dt_ns
    position = {n: i for i, n in enumerate(scene.order)}
    restart = _restart_checkpoint(rec)  # a recording made by a restart (replay --from) begins at its checkpoint

    def channel(component_name: str, port: str, msg_type: type[Message]) -> list[tuple[int, Message]]:
        topic = topic_of(component_name, port)
        if topic not in rec.channels:
            return []
        return rec.messages(topic, msg_type)

    sources: list[_RecordedSource] = []
    plan: list[tuple[str, list[_Edge]]] = []
    for port, spec in comp.inputs.items():
        edges = []
        for conn in scene.connections:
            if conn.target != name or conn.target_port != port:
                continue
            topic = topic_of(conn.source, conn.source_port)
            if spec.required and topic not in rec.channels:
                held = sorted(rec.channels)
                shown = ", ".join(held[:6]) + (", ..." if len(held) > 6 else "")
                raise RecordingError(f"{rec.path}: cannot replay {name!r}: its input {port!r} comes from {topic}, "
                                     "which the recording holds no message of (the run ended before its first, "
                                     f"or the attached scene is not the one that made the channels: {shown})")
            source_cfg = scene.components[conn.source]
            src = _RecordedSource(channel(conn.source, conn.source_port, spec.type), source_cfg.every, dt_ns,
                                  position[conn.source] < position[name])
            sources.append(src)
            edge = _Edge(conn, src.slot, spec.event)
            if restart is not None:  # the port's last messages and the edge's deliveries, as the restart had them
                cp = restart[1]
                src.slot.entries = saved_messages(cp, conn.source, conn.source_port, spec.type)
                edge.last_delivered = cp["edges"][scene.connections.index(conn)]
                # what the source published before the checkpoint (a step spanning it, recorded again
                # as the restart began) is in those entries already
                src.drop_published_before(restart[0] // dt_ns)
            edges.append(edge)
        plan.append((port, edges))

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
                return ReplayReport(name, steps, compared,
                                    Divergence(stamp, port, field, _show(want, field), _show(got, field)))
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
        comp.begin(gather_start(plan))
    else:  # the component as the restart's checkpoint holds it, from its first step after it
        stamp, cp = restart
        restore_component(comp, cp["components"][name])
        first_tick = -(-(stamp // dt_ns) // every) * every
    steps = 0
    seconds = 0.0  # in the component's steps, the first one left out
    clock = time.perf_counter
    for tick in range(first_tick, end_tick, every):
        start, end = tick * dt_ns, (tick + every) * dt_ns
        for src in sources:
            src.advance(tick)
        inputs = gather(plan, start, end)
        began = clock()
        outputs = comp.step(start, end - start, inputs, cfg.on_unstable)
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


def _restart_checkpoint(rec: Recording) -> tuple[int, dict] | None:
    """(time [ns], checkpoint) a recording made by a restart began at (its metadata's ``start_ns``,
    the checkpoint recorded then); None for a run from t = 0. A restart recorded without
    checkpoints cannot be replayed (RecordingError)."""
    if not rec.restart_ns:
        return None
    checkpoint = rec.checkpoint_at(rec.restart_ns)  # (only that one is decoded)
    if checkpoint is None:
        raise RecordingError(f"{rec.path}: cannot replay: a restart from t = {rec.restart_ns / NS_PER_S:g} s, "
                             "recorded without the checkpoint it started from (record.checkpoint_every 0): replay "
                             "the recording it was restarted from")
    return rec.restart_ns, checkpoint


def restart_simulation(rec: Recording, from_ns: int, overrides: list[str] | None = None,
                       observers: list | None = None) -> tuple[Simulation, int]:
    """A simulation of the recorded scene (with ``overrides``) restored at the last checkpoint at or
    before ``from_ns``; returns it with the checkpoint time [ns]."""
    status = rec.status()
    end_ns = round(status.time * NS_PER_S) if status is not None else rec.end_ns
    if from_ns > end_ns:
        # the checkpoint before it would be the run's last: a restart there is not what was asked
        raise RecordingError(f"{rec.path}: --from {from_ns / NS_PER_S:g} s is after the recorded run's end "
                             f"(t = {end_ns / NS_PER_S:g} s); restart from a time within it")
    checkpoints = rec.checkpoints()
    usable = [(stamp, cp) for stamp, cp in checkpoints if stamp <= from_ns]
    if not usable:
        times = ", ".join(f"{s / NS_PER_S:g}" for s, _ in checkpoints[:10]) or "none"
        raise RecordingError(f"{rec.path}: no checkpoint at or before t = {from_ns / NS_PER_S:g} s "
                             f"(checkpoints at [s]: {times}); record with record.checkpoint_every > 0")
    stamp, cp = usable[-1]
    scene = rec.scene(overrides)
    sim = Simulation(scene, observers=observers)
    for override in overrides or []:
        key = override.partition("=")[0].strip()
        path = key.split(".")
        if len(path) >= 3 and path[0] == "components" and path[1] in sim.components:
            comp, param = sim.components[path[1]], path[2].partition("[")[0]
            if param in comp.start_only_params:
                raise RecordingError(f"--set {key}: sets {path[1]}'s state at t = 0, "
                                     f"which a restart takes from the checkpoint at {stamp / NS_PER_S:g} s instead; "
                                     "to change it, run the scene from the start (cosim run)")
    try:
        sim.restore(cp)
    except (ValueError, KeyError) as exc:
        why = (f"it holds no {exc.args[0]!r}, which this scene's components restore (a component or setting "
               "changed by --set?)" if isinstance(exc, KeyError) else str(exc))
        raise RecordingError(f"{rec.path}: cannot restart from the checkpoint at {stamp / NS_PER_S:g} s: "
                             f"{why}") from None
    return sim, stamp
