"""The master algorithm: a fixed base step, multi-rate components, Gauss-Seidel exchange.

Tick k covers [t_k, t_{k+1}] with t_k = k * dt_ns. A component with ``every = m`` steps on ticks
where k % m == 0, from t_k to t_{k+m}; its outputs are stamped t_{k+m} (the logical end of its step).
Within a tick, components run in topological order of the direct edges. What an input receives:

- a direct edge: the newest source output published so far and stamped at or before the END of the
  receiver's step (Gauss-Seidel: a source that ran earlier in this tick is seen at its new time; a
  receiver stepping less often steps in its span's first tick, so it holds the output of its source's
  step in that tick). If none is stamped that early yet (a slower source at start-up), its oldest
  output is held (events wait instead).
- a delayed edge (``delay: 1``): the newest output stamped at or before the START of the receiver's
  step, ignoring the t = 0 initial outputs; before the first one, the edge's ``initial`` value.
- an ``event`` input receives each message exactly once, by the same rule (stamped by the end of
  its step, or by its start on a delayed edge, where the t = 0 output gives way to ``initial``): a
  receiver stepping less often than its source receives the sum of the messages since its last step
  (an additive type: contact impulses; the scene refuses a type that is not), where it received only
  the last and the others were lost; otherwise the value is held. A t = 0 event of a type that cannot
  be summed is refused as the run starts where the source's first step's reaches the same step.
- an additive port fed by several edges receives the sum of their values.

The rule depends only on stamps, so replaying a component from a recording reconstructs exactly the
inputs it received. Each output port keeps its last two messages, which is all the rule ever needs
for a held value (one source publishes at most once per tick); each event edge keeps, besides, the
messages it has not delivered yet, and a checkpoint keeps them too.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass
from typing import Any, Protocol

from cosim.codec.json_codec import codec_for, decode_state
from cosim.component import Component, substep_count
from cosim.errors import SimulationError, StateRestoreError
from cosim.jit_time import compile_timer
from cosim.messages import Message
from cosim.scenario import Connection, Scene
from cosim.timebase import NS_PER_S, exact_seconds, ticks_reaching


class Observer(Protocol):
    """Lifecycle callbacks; every method is optional (see :class:`BaseObserver`)."""

    def on_initialized(self, sim: Simulation) -> None: ...
    def on_exchange(self, time_ns: int, component: str, port: str, msg: Message) -> None: ...
    def on_event(self, time_ns: int, component: str, kind: str, detail: str) -> None: ...
    def on_step_complete(self, sim: Simulation) -> None: ...
    def on_finished(self, sim: Simulation, result: RunResult) -> None: ...


class BaseObserver:
    """An observer that ignores every event; subclass and override what you need."""

    def on_initialized(self, sim: Simulation) -> None:
        pass

    def on_exchange(self, time_ns: int, component: str, port: str, msg: Message) -> None:
        pass

    def on_event(self, time_ns: int, component: str, kind: str, detail: str) -> None:
        pass

    def on_step_complete(self, sim: Simulation) -> None:
        pass

    def on_finished(self, sim: Simulation, result: RunResult) -> None:
        pass


@dataclass
class RunResult:
    """How a run ended: status ``ok`` | ``stopped`` | ``failed`` | ``interrupted``."""

    status: str
    reason: str
    tick: int
    time_ns: int
    wall_s: float
    component_steps: int
    error: SimulationError | None = None
    compile_s: float = 0.0  # of wall_s, compiling JIT kernels not yet in their on-disk cache (once)
    start_tick: int = 0  # where this run started: 0, or a restored checkpoint's tick
    start_ns: int = 0  # [ns] the time of that tick

    @property
    def simulated_ns(self) -> int:
        """Simulated time of this run [ns], from its start (a checkpoint's time after a restart)."""
        return self.time_ns - self.start_ns

    @property
    def steps(self) -> int:
        """Base steps this run took, from its start."""
        return self.tick - self.start_tick

    @property
    def real_time_factor(self) -> float:
        """Simulated seconds per wall-clock second of simulating (the one-time compiling left out)."""
        wall = self.wall_s - self.compile_s
        return (self.simulated_ns / NS_PER_S) / wall if wall > 0 else math.inf


class Interrupted(Exception):
    """Raised from a signal handler to end a run cleanly (Ctrl-C, SIGTERM)."""


_KEPT = 2  # messages a port keeps: the newest, and the one before for a delayed edge


class _Slot:
    """The last two messages published on one output port, as (stamp_ns, message) pairs, and the
    event edges it feeds (each keeps what it has not delivered yet)."""

    __slots__ = ("entries", "listeners")

    def __init__(self) -> None:
        self.entries: list[tuple[int, Message]] = []
        self.listeners: list[_Edge] = []

    def publish(self, stamp: int, msg: Message) -> None:
        entries = self.entries
        entries.append((stamp, msg))
        if len(entries) > _KEPT:
            del entries[0]
        for edge in self.listeners:
            edge.queue.append((stamp, msg))


class _Edge:
    __slots__ = ("delayed", "event", "initial", "last_delivered", "queue", "slot", "spec")

    def __init__(self, spec: Connection, slot: _Slot, event: bool):
        self.spec = spec
        self.slot = slot
        self.delayed = spec.delay == 1
        self.event = event
        self.initial = spec.initial
        self.last_delivered = -1
        # an event edge's messages published and not delivered yet (stamp_ns, message), oldest first
        self.queue: list[tuple[int, Message]] = []
        if event:
            slot.listeners.append(self)

    def key(self) -> str:
        """The connection as written (source, target, delay): what a checkpoint files the edge under."""
        return str(self.spec)

    def saved_index(self, cp: dict[str, Any], position: int) -> int | None:
        """Where a checkpoint holds this edge's deliveries: under its connection, or, in one saved
        before edges were keyed, at its ``position`` among the scene's connections when they number
        the same; None: it holds none (a connection the saved run did not have)."""
        keys = cp.get("edge_keys")
        if keys is not None:
            return keys.index(self.key()) if self.key() in keys else None
        return position if len(cp["edges"]) > position else None

    def undelivered(self, cp: dict[str, Any], index: int, msg_type: type[Message]) -> None:
        """After a restore from ``cp``, where this is edge ``index``: what it last delivered and, of an
        event edge, what it has not delivered yet: the queue the checkpoint saved, or in one saved
        before queues were (its port's last two messages then), what the slot holds past the last
        delivery."""
        self.last_delivered = cp["edges"][index]
        if not self.event:
            return
        queues = cp.get("queues")
        if queues is not None and len(queues) == len(cp["edges"]):
            self.queue = [(stamp, codec_for(msg_type).decode(payload.encode())) for stamp, payload in queues[index]]
        else:
            self.queue = [entry for entry in self.slot.entries if entry[0] > self.last_delivered]

    def pick(self, start: int, end: int) -> Message | None:
        if self.event:
            return self._pick_event(start, end)
        entries = self.slot.entries
        if self.delayed:
            # the newest message stamped in (0, start]; usually the last of the slot's two (returned
            # at once: every input of every step comes here)
            if entries:
                last = entries[-1]
                if 0 < last[0] <= start:
                    return last[1]
            for entry in reversed(entries):
                if 0 < entry[0] <= start:
                    return entry[1]
            return self.initial
        # the newest message stamped by ``end``; usually the last of the slot's two
        if entries:
            last = entries[-1]
            if last[0] <= end:
                return last[1]
        for entry in reversed(entries):
            if entry[0] <= end:
                return entry[1]
        # start-up of a slower source: hold its first value
        return entries[0][1] if entries else None

    def _pick_event(self, start: int, end: int) -> Message | None:
        """Every message not delivered yet that the rule reaches, summed (one, usually): those
        stamped by ``end`` (direct) or in (0, ``start``] (delayed, whose t = 0 output gives way to
        ``initial``, delivered once before the first). A receiver stepping every k ticks of its
        source's one takes the k impulses of its step at once, as the momentum they carry."""
        queue = self.queue
        if self.delayed:
            limit = start
            while queue and queue[0][0] <= 0:  # (the source's initial output: ``initial`` stands for it)
                del queue[0]
        else:
            limit = end
        n = 0
        while n < len(queue) and queue[n][0] <= limit:
            n += 1
        if n == 0:
            if self.delayed and self.initial is not None and self.last_delivered < 0:
                self.last_delivered = 0
                return self.initial
            return None
        due = queue[:n]
        del queue[:n]
        self.last_delivered = due[-1][0]
        if not due[-1][1].additive:  # (the scene refuses a slower receiver of such a type: at most the
            return due[-1][1]       # source's t = 0 output and its first step's come together)
        total = due[0][1]
        for _, msg in due[1:]:
            total = total + msg
        return total

    def at_start(self) -> Message | None:
        """The value this edge holds at t = 0, before the first step, without delivering it: the
        edge's ``initial`` (delayed), else the source's initial output; None for an event."""
        if self.event:
            return None
        if self.delayed:
            return self.initial
        return next((msg for stamp, msg in reversed(self.slot.entries) if stamp <= 0), None)


class _Runner:
    """A component with its precomputed input plan and output slots (keeps the tick loop lean)."""

    __slots__ = ("comp", "every", "most_substeps", "name", "on_unstable", "plan", "slots", "substeps_seen")

    def __init__(self, comp: Component, every: int, on_unstable: str):
        self.comp = comp
        self.name = comp.name
        self.every = every
        self.on_unstable = on_unstable
        self.plan: list[tuple[str, list[_Edge]]] = []
        self.slots: dict[str, _Slot] = {port: _Slot() for port in comp.outputs}
        self.substeps_seen = 1
        self.most_substeps = 1  # the most substeps one of its steps took (on_unstable: substep)


def _check_event_at_start(runner: _Runner, port: str, msg: Message, every: dict[str, int]) -> None:
    """A message published at t = 0 on ``port`` reaches a direct event edge at the receiver's first
    step; so does the source's first step's, when the source steps as often as the receiver (``every``:
    each component's, in base steps; a slower receiver of such a type is refused as the scene loads). A
    type that cannot be summed would deliver only the later one, so such an edge is refused as the
    run starts (a delayed edge's ``initial`` stands for the t = 0 output instead)."""
    if msg.additive:
        return
    for edge in runner.slots[port].listeners:
        if not edge.delayed and runner.every <= every[edge.spec.target]:
            raise SimulationError(
                runner.name, 0,
                f"it publishes a {type(msg).__name__} at t = 0 on {port!r}, which reaches the event input "
                f"{edge.spec.target}.{edge.spec.target_port} together with its first step's, and a "
                f"{type(msg).__name__} cannot be summed: one would be lost; publish no event at t = 0, or "
                f"give the connection a delay (its initial then stands for t = 0)")


def gather(plan: list[tuple[str, list[_Edge]]], start: int, end: int) -> dict[str, Message | None]:
    """The inputs of a step from ``start`` to ``end`` [ns]: each port's edge value, summed over
    several edges (additive ports), None where nothing is delivered. (:meth:`Simulation.step` does
    the same inline.)"""
    return {port: edges[0].pick(start, end) if len(edges) == 1 else _sum_of(edges, start, end)
            for port, edges in plan}


def _sum_of(edges: list[_Edge], start: int, end: int) -> Message | None:
    """The sum of what several edges into one (additive) port deliver for a step from ``start`` to
    ``end`` [ns]; None where none delivers anything."""
    total = None
    for edge in edges:
        value = edge.pick(start, end)
        if value is not None:
            total = value if total is None else total + value
    return total


def _substeps_said(n: int) -> str:
    """``n`` substeps in words ("1 substep", "3 substeps")."""
    return f"{substep_count(n)} substep{'' if n == 1 else 's'}"


def restore_component(comp: Component, saved: dict[str, Any], time_ns: int) -> None:
    """Put ``comp`` back as a checkpoint saved it (``saved``: its entry under ``components``; ``time_ns``:
    the checkpoint's time): its state, its steps so far, the substeps its last step took (a restart
    said again that a component substepping all along took 2 substeps) and a stop it asked for in the
    tick the checkpoint closes (a restart from a stopped run's last checkpoint ran on past the stop).
    Its ``set_state`` refusing the state (a ValueError, KeyError or TypeError) raises
    :class:`StateRestoreError` naming the component; failing otherwise, it is the component's failure
    at ``time_ns``, as its ``get_state`` failing is (a RuntimeError of a user's set_state was an
    internal error, and a KeyError named no component)."""
    unsaved = saved.get("unsaved")
    if unsaved:
        # said, not refused: the attributes may be no state at all (a log of what it was given, a cache)
        warnings.warn(f"component {comp.name!r} changed {_attributes(unsaved)} between steps before this "
                      f"checkpoint but saves no state (its get_state the base one): it restarts as set up, "
                      f"not as it was, and the run from here differs from the original wherever those "
                      f"attributes decide its outputs", stacklevel=2)
    state = saved["state"]
    state = decode_state(state) if isinstance(state, (bytes, str)) else state
    try:
        comp.set_state(state)
    except (ValueError, KeyError, TypeError) as exc:  # the state is not one it takes
        raise StateRestoreError(comp.name, exc) from exc
    except (KeyboardInterrupt, SimulationError):
        raise
    except BaseException as exc:  # (sys.exit() too, as in a step)
        comp.status = "failed"
        raise SimulationError(comp.name, time_ns, f"restoring its saved state failed: {type(exc).__name__}: "
                              f"{exc}") from exc
    comp.step_count = saved["step_count"]
    comp.last_substeps = int(saved.get("substeps", 1))  # (not in checkpoints of older recordings)
    comp.last_stable_step = float(saved.get("stable_step", math.inf))
    comp.stop_reason = saved.get("stop_reason")
    comp.status = "initialized"


def saved_messages(cp: dict[str, Any], component: str, port: str, msg_type: type[Message]) -> list[tuple[int, Message]]:
    """The last messages of output ``component.port`` a checkpoint holds, as (stamp [ns], message)."""
    return [(stamp, codec_for(msg_type).decode(payload.encode()))
            for stamp, payload in cp["slots"].get(f"{component}.{port}", [])]


def _attributes(names: list[str]) -> str:
    """Attribute names as said: "its attribute total", "its attributes a, b"."""
    return f"its attribute{'s' if len(names) > 1 else ''} {', '.join(names)}"


def gather_start(plan: list[tuple[str, list[_Edge]]]) -> dict[str, Message | None]:
    """The inputs at t = 0 (:meth:`cosim.component.Component.start_inputs`): each port's edge value
    then, summed over several edges as :func:`gather` does."""
    inputs: dict[str, Message | None] = {}
    for port, edges in plan:
        total = None
        for edge in edges:
            value = edge.at_start()
            if value is not None:
                total = value if total is None else total + value
        inputs[port] = total
    return inputs


class Simulation:
    """Runs a validated scene's components on the master clock and tells observers what happens."""

    # A Ctrl-C ends a run as "interrupted", its observers told (a recording closed with that status),
    # and run() returns. A program that goes on to report what runs measured (the tools writing the
    # docs' figures) sets this, so that the interruption then goes on to it: a benchmark cut short by
    # Ctrl-C wrote its cut-short run's times into the page, as measured, exit 0.
    raise_interrupts = False

    def __init__(self, scene: Scene, components: dict[str, Component] | None = None,
                 observers: list[Any] | None = None):
        self.scene = scene
        self.components = components if components is not None else scene.instantiate()
        self.dt_ns = scene.dt_ns
        self.tick = 0
        self.observers: list[Any] = list(observers or [])
        self.stop_reason: str | None = None
        self._unsaved_said: set[str] = set()  # the components said to keep a state they do not save
        self.interrupt_reason: str | None = None
        self._initialized = False
        self.last_result: RunResult | None = None  # of the last run(), also one that raised
        self.runners = [_Runner(self.components[name], scene.components[name].every,
                                scene.components[name].on_unstable) for name in scene.order]
        by_name = {r.name: r for r in self.runners}
        self.edges: list[_Edge] = []
        for runner in self.runners:
            for port, spec in runner.comp.inputs.items():
                feeding = [c for c in scene.connections if c.target == runner.name and c.target_port == port]
                if not feeding:
                    runner.plan.append((port, []))
                    continue
                edges = [_Edge(c, by_name[c.source].slots[c.source_port], spec.event) for c in feeding]
                self.edges.extend(edges)
                runner.plan.append((port, edges))
                runner.comp.input_sources[port] = [c.source for c in feeding]
                if len(feeding) == 1:
                    runner.comp.source_steps[port] = scene.step_of(feeding[0].source)
        # edges were appended runner by runner; keep a canonical order for checkpoints
        self.edges.sort(key=lambda e: scene.connections.index(e.spec))
        self._read_ports = {(e.spec.source, e.spec.source_port) for e in self.edges}
        # a restart's messages published before its checkpoint and stamped after it (the outputs of a
        # step that spans the checkpoint's time), told to the observers as the run begins again
        self._ahead: list[tuple[int, str, str, Message]] = []

    # --- time -------------------------------------------------------------------------------------

    @property
    def time_ns(self) -> int:
        return self.tick * self.dt_ns

    def request_stop(self, reason: str) -> None:
        """End the run after the current tick (observers may call this, e.g. a stop condition)."""
        self.stop_reason = reason

    def interrupt(self, reason: str) -> None:
        """End the run after the current tick with status ``interrupted`` (safe from a signal handler:
        the tick in progress completes, so every observer sees whole ticks only)."""
        self.interrupt_reason = reason

    # --- lifecycle --------------------------------------------------------------------------------

    def initialize(self) -> None:
        """Tell observers the run starts; at tick 0, publish the components' initial outputs at t = 0."""
        if self._initialized:
            return
        self._initialized = True
        for obs in self.observers:
            obs.on_initialized(self)
        for stamp, name, port, msg in self._ahead:
            for obs in self.observers:
                obs.on_exchange(stamp, name, port, msg)
        self._ahead = []
        if self.tick == 0:
            every = {runner.name: runner.every for runner in self.runners}
            for runner in self.runners:
                outputs = runner.comp.start_outputs()  # t = 0 values obey the same rules as step outputs
                for port, msg in outputs.items():
                    runner.slots[port].publish(0, msg)
                    for obs in self.observers:
                        obs.on_exchange(0, runner.name, port, msg)
                    _check_event_at_start(runner, port, msg, every)
            for runner in self.runners:
                runner.comp.begin(gather_start(runner.plan))

    def step(self) -> None:
        """Advance one base tick."""
        k = self.tick
        dt_ns = self.dt_ns
        start = k * dt_ns
        observers = self.observers
        for runner in self.runners:
            every = runner.every
            if k % every:
                continue
            span = every * dt_ns
            end = start + span
            comp = runner.comp
            # gather() inline for the usual port, fed by one edge (a call less for every step)
            inputs: dict[str, Message | None] = {}
            for port, edges in runner.plan:
                inputs[port] = edges[0].pick(start, end) if len(edges) == 1 else _sum_of(edges, start, end)
            outputs = comp.step_gathered(start, span, inputs, runner.on_unstable)
            slots = runner.slots
            for port, msg in outputs.items():
                # _Slot.publish inline (a call less for every output of every step)
                slot = slots[port]
                entries = slot.entries
                entries.append((end, msg))
                if len(entries) > _KEPT:
                    del entries[0]
                listeners = slot.listeners
                if listeners:
                    for edge in listeners:
                        edge.queue.append((end, msg))
            if observers:
                for port, msg in outputs.items():
                    for obs in observers:
                        obs.on_exchange(end, runner.name, port, msg)
            if comp.last_substeps != runner.substeps_seen:
                runner.substeps_seen = comp.last_substeps
                runner.most_substeps = max(runner.most_substeps, comp.last_substeps)
                # (the bound that set the count, as the step began: asked after it, the coupler of a
                # stone that had left the water said "2 substeps ... (stable step inf s)")
                said = ("its stable step covers the step again" if comp.last_substeps == 1 else
                        f"stable step {comp.last_stable_step:.6g} s")
                for obs in observers:
                    obs.on_event(start, runner.name, "substep",
                                 f"{_substeps_said(comp.last_substeps)} of {comp.name} per step ({said})")
            if comp.stop_reason is not None and self.stop_reason is None:
                self.stop_reason = f"{runner.name}: {comp.stop_reason}"
        self.tick = k + 1
        for obs in observers:
            obs.on_step_complete(self)

    def run(self, until_ns: int | None = None) -> RunResult:
        """Run to ``until_ns`` (default: the scene's end) or until a stop is requested.

        A SimulationError ends the run with status ``failed`` (observers are told, then it is
        re-raised); an :class:`Interrupted` or KeyboardInterrupt ends it with ``interrupted`` (and,
        with :attr:`raise_interrupts` set, goes on to the caller once the observers are told).
        """
        until_ns = self.scene.until_ns if until_ns is None else until_ns
        end_tick = ticks_reaching(until_ns, self.dt_ns)
        wall0 = time.perf_counter()
        steps0 = self.component_steps()
        tick0 = self.tick
        # the end as run: whole steps, the last one reaching or passing until_ns
        status, reason, error = "ok", f"reached t = {exact_seconds(end_tick * self.dt_ns)} s", None
        with compile_timer() as compiling:
            try:
                self.initialize()
                if self.stop_reason is not None:  # restored from the tick a stop was asked for: ends there
                    status, reason = "stopped", self.stop_reason
                while status == "ok" and self.tick < end_tick:
                    self.step()
                    if self.interrupt_reason is not None:
                        status, reason = "interrupted", self.interrupt_reason
                        break
                    if self.stop_reason is not None:
                        status, reason = "stopped", self.stop_reason
                        break
            except SimulationError as exc:
                status, reason, error = "failed", str(exc), exc
            except (KeyboardInterrupt, Interrupted) as exc:
                status, reason = "interrupted", f"interrupted ({type(exc).__name__})"
            except Exception as exc:
                # still ends, its recording with the failed status, and the error goes on to the caller
                status, reason, error = "failed", f"internal error {type(exc).__name__}: {exc}", exc
            compile_s = compiling()
        result = RunResult(status, reason, self.tick, self.time_ns, time.perf_counter() - wall0,
                           self.component_steps() - steps0, error, compile_s, tick0, tick0 * self.dt_ns)
        self.last_result = result
        for obs in self.observers:
            obs.on_finished(self, result)
        if error is not None:
            raise error
        if status == "interrupted" and self.raise_interrupts:
            raise KeyboardInterrupt(reason)
        return result

    def component_steps(self) -> int:
        return sum(r.comp.step_count for r in self.runners)

    # --- checkpoints --------------------------------------------------------------------------------

    def checkpoint(self) -> dict[str, Any]:
        """Everything needed to continue this run exactly: tick, component states, port histories."""
        return {
            "tick": self.tick,
            "dt_ns": self.dt_ns,
            "components": {r.name: self._component_entry(r) for r in self.runners},
            "stop_reason": self.stop_reason,  # a stop asked for in the tick this checkpoint closes
            # only the ports some edge reads: the others' past messages cannot change what follows
            "slots": {f"{r.name}.{port}": [[stamp, codec_for(type(msg)).encode(msg).decode()]
                                           for stamp, msg in slot.entries]
                      for r in self.runners for port, slot in r.slots.items() if (r.name, port) in self._read_ports},
            "edges": [e.last_delivered for e in self.edges],
            "edge_keys": [e.key() for e in self.edges],  # (a restart may list its connections otherwise)
            # what each event edge has not delivered yet (a receiver stepping less often than its source)
            "queues": [[[stamp, codec_for(type(msg)).encode(msg).decode()] for stamp, msg in e.queue]
                       for e in self.edges],
            # the outputs of the steps that span this time (a component stepping every few ticks
            # publishes at its step's start, stamped at its end), of every port: a run restarted here
            # records them again, so that its recording holds what the original did from here on
            "ahead": [[stamp, f"{r.name}.{port}", codec_for(type(msg)).encode(msg).decode()]
                      for r in self.runners for port, slot in r.slots.items()
                      for stamp, msg in slot.entries if stamp > self.time_ns],
        }

    def _component_entry(self, runner: Any) -> dict[str, Any]:
        """A component's entry in a checkpoint: its state and the scheduler's counts of it; and, for a
        component that keeps a state between steps its class does not save (``unsaved``: the
        attributes, :meth:`Component.unsaved_state`), said once a component as a warning, so that the
        run tells at once what a restart from it would not give back."""
        comp = runner.comp
        entry = {"state": comp.state_for_checkpoint(self.time_ns), "step_count": comp.step_count,
                 "substeps": comp.last_substeps, "stable_step": comp.last_stable_step,
                 "most_substeps": runner.most_substeps, "stop_reason": comp.stop_reason}
        unsaved = comp.unsaved_state()
        if unsaved:
            entry["unsaved"] = unsaved
            if runner.name not in self._unsaved_said:
                self._unsaved_said.add(runner.name)
                warnings.warn(f"component {comp.name!r} ({type(comp).__name__}) changes {_attributes(unsaved)} "
                              f"between steps but its class saves no state (its get_state the base one): a "
                              f"restart from this run's checkpoints would start it as set up, not as it was; "
                              f"give the class get_state and set_state (returning {{}} where those attributes "
                              f"are no state: a log, a cache)", stacklevel=2)
        return entry

    def _restore_edges(self, cp: dict[str, Any], time_ns: int) -> None:
        """What each connection had delivered, found by the connection (a restart that lists its
        connections in another order, or changes some, keeps each one's: by position, two swapped
        lines traded theirs, and an event was lost). A connection the saved run did not have delivers
        what is published from the checkpoint on; one reading a port no connection of the saved run
        read is refused: that port's last messages were not kept."""
        outputs = {r.name: r.comp.outputs for r in self.runners}
        keyed = cp.get("edge_keys") is not None
        if not keyed and len(cp["edges"]) != len(self.edges):
            return  # (saved before edges were keyed, by another scene's connections: nothing to match)
        kept = set(cp["slots"])  # (the ports some connection of the saved run read)
        for position, edge in enumerate(self.edges):  # (in the scene's order of connections)
            source = f"{edge.spec.source}.{edge.spec.source_port}"
            index = edge.saved_index(cp, position)
            if index is not None:
                edge.undelivered(cp, index, outputs[edge.spec.source][edge.spec.source_port].type)
                continue
            if source not in kept:
                raise ValueError(f"connection {edge.key()} reads {source}, which no connection of the saved run "
                                 "read: its last messages were not kept; restart from the run's start, or keep "
                                 "that port connected in the run you restart")
            edge.last_delivered = time_ns  # (new: it delivers what is published from here on)
            edge.queue = []

    def restore(self, cp: dict[str, Any]) -> None:
        """Continue from a checkpoint; the base step may differ if the checkpoint time is on its grid."""
        time_ns = cp["tick"] * cp["dt_ns"]
        if time_ns % self.dt_ns:
            raise ValueError(f"checkpoint time {exact_seconds(time_ns)} s is not a multiple of dt = "
                             f"{exact_seconds(self.dt_ns)} s")
        self.tick = time_ns // self.dt_ns
        for runner in self.runners:
            saved = cp["components"].get(runner.name)
            if saved is None:
                raise ValueError(f"checkpoint has no state for component {runner.name!r}")
            restore_component(runner.comp, saved, time_ns)
            runner.substeps_seen = runner.comp.last_substeps
            runner.most_substeps = int(saved.get("most_substeps", runner.comp.last_substeps))
            for port, slot in runner.slots.items():
                slot.entries = saved_messages(cp, runner.name, port, runner.comp.outputs[port].type)
        self._restore_edges(cp, time_ns)
        by_name = {r.name: r for r in self.runners}
        self._ahead = []
        for stamp, channel, payload in cp.get("ahead", []):  # (not in checkpoints of older recordings)
            name, _, port = channel.partition(".")
            if name in by_name and port in by_name[name].comp.outputs:
                kind = by_name[name].comp.outputs[port].type
                msg = codec_for(kind).decode(payload.encode())
                self._ahead.append((stamp, name, port, msg))
                if channel not in cp["slots"]:
                    # a port no connection reads keeps no past in the checkpoint, but its outputs of
                    # the step spanning it are its to hold: a checkpoint the restart takes again keeps
                    # them ahead (a restart of a restart lost the pond's field published at 0.2002 s)
                    by_name[name].slots[port].entries.append((stamp, msg))
        self.stop_reason = cp.get("stop_reason")
        self._initialized = False
