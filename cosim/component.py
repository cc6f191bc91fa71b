"""The component contract.

A component declares typed ports and parameters and implements one pure step (``Number`` is the
message type of :mod:`cosim.examples`, a ``value`` float)::

    from dataclasses import dataclass

    from cosim.component import Component, Port
    from cosim.examples import Number
    from cosim.params import param

    class Counter(Component):
        '''Adds its input to a running total.'''

        @dataclass(frozen=True)
        class Params:
            gain: float = param(1.0)

        inputs = {"x": Port(Number)}
        outputs = {"total": Port(Number)}

        def setup(self) -> None:
            self.total = 0.0

        def get_state(self):  # what a checkpoint holds, so that a restart goes on from it
            return {"total": self.total}

        def set_state(self, state):
            self.total = float(state["total"])

        def _step_impl(self, t, dt, inputs):
            self.total += self.params.gain * (inputs["x"].value if inputs["x"] else 0.0)
            return {"total": Number(self.total)}

A message is a value: once returned, its arrays are the message's (a delayed receiver, a slower
one and the recording hold it). A component that keeps an array and changes it in place returns a
copy of it (``Pos(self.p.copy())``), and reads its inputs' arrays without changing them: neither is
copied nor made read-only for it (every exchange, every step; the compiled kernels take a read-only
array as another type).

The public :meth:`Component.step` (for a component driven by hand: its inputs held to the declared
ports and types first) and the scheduler's :meth:`Component.step_gathered` own the bookkeeping:
status and step count, the stability guard
against :meth:`max_stable_step` (error, or substepping; :meth:`Component.restep` applies it to a
bound a component learns inside its step), checking outputs (known ports, right types, finite
values, each field a value of its own kind: an int a whole number within 64 bits, a bool a bool, a
str a text, an array a numpy array of its dtype's kind and declared shape; enum fields holding one
of their members) and turning any exception into a
:class:`SimulationError` naming the component, the simulation time and the reason. Physics code
never sees the scheduler.
"""

from __future__ import annotations

import decimal
import hashlib
import math
import types
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Literal, TypeVar

import numpy as np

from cosim.errors import SimulationError
from cosim.messages import NONFINITE, Message
from cosim.timebase import NS_PER_S

OnUnstable = Literal["error", "substep"]
_T = TypeVar("_T")

MAX_SUBSTEPS = 10_000  # a component needing more substeps than this in one step is reported as unstable


def substep_count(substeps: int) -> str:
    """A number of substeps as a message gives it: whole, or in three digits when huge (not 150)."""
    return str(substeps) if substeps < 10**6 else f"{substeps:.3g}"


def step_and_bound(dt: float, bound: float) -> tuple[str, str]:
    """A step and the smaller stable step it exceeds [s], in text: in six significant digits, or as
    many as tell them apart (both 0.00412183 said nothing), the bound rounded down, so that a step
    of the value said is within it."""
    for digits in range(6, 18):
        said = f"{bound:.{digits}g}"
        if float(said) > bound:  # rounded up: the same digits rounded down, written alike
            floor = decimal.Context(prec=digits, rounding=decimal.ROUND_FLOOR).create_decimal(bound)
            said = f"{float(floor):.{digits}g}"
        if f"{dt:.{digits}g}" != said:
            return f"{dt:.{digits}g}", said
    return repr(dt), repr(bound)


@dataclass(frozen=True)
class Port:
    """A typed port.

    ``required``: an input that must be connected. ``event``: an input that receives each published
    message at most once (impulses, stage changes) instead of holding the latest value; an output
    that publishes only when something happens (a stage change, a skip), whose every message a
    recording keeps whatever its ``record.every`` (thinned, it would tell a false history).
    """

    type: type[Message]
    doc: str = ""
    required: bool = False
    event: bool = False


@dataclass(frozen=True)
class NoParams:
    """A component without parameters."""


# the attributes Component.__init__ sets (the framework's, not a component's own state)
FRAMEWORK_ATTRIBUTES = frozenset({
    "name", "params", "status", "step_count", "last_substeps", "last_stable_step", "_stepping", "stop_reason",
    "input_sources", "source_steps", "_bounded", "_first_fingerprints", "_framework_attrs"})


class Component:
    """Base class of every component; subclasses write :meth:`_step_impl` (and usually :meth:`setup`)."""

    Params: ClassVar[type] = NoParams
    inputs: ClassVar[dict[str, Port]] = {}
    outputs: ClassVar[dict[str, Port]] = {}
    # parameters that only set the state at t = 0 (a body's position): a run restarted from a
    # checkpoint takes that state from the checkpoint, so an override of one there would do nothing
    start_only_params: ClassVar[frozenset[str]] = frozenset()

    def __init__(self, name: str, params: Any = None):
        self.name = name
        self.params = params if params is not None else self.Params()
        self.status = "created"
        self.step_count = 0
        self.last_substeps = 1
        self.last_stable_step = math.inf  # [s] the stable step that set last_substeps (inf: no bound)
        # inside a step: (t_ns, dt [s], on_unstable, substeps, bound [s]) as the step takes it (restep)
        self._stepping: tuple[int, float, OnUnstable, int, float] | None = None
        self.stop_reason: str | None = None
        # the components feeding each input port, as the scene connects them (set by the simulation;
        # a component driven by hand has none): for its words, never for its physics
        self.input_sources: dict[str, list[str]] = {}
        # the step [s] of the one component feeding each input port (set by the simulation and by a
        # replay; none for a port fed by several, or for a component driven by hand): a monitor judges
        # its body's state against the step that body took, which need not be its own
        self.source_steps: dict[str, float] = {}
        # a component without a stability bound of its own is not asked for it at every step
        self._bounded = type(self).max_stable_step is not Component.max_stable_step
        # a component whose class saves no state of its own: the fingerprints of its own attributes at
        # the run's first checkpoint, to tell at the later ones whether it keeps a state between steps
        # that a restart could not give back (unsaved_state)
        self._first_fingerprints: dict[str, str | None] | None = None
        cls = type(self)
        saves_nothing = (cls.get_state is Component.get_state and cls.checkpoint_state is Component.checkpoint_state)
        # (named, not read off vars(self): reading an instance's __dict__ makes CPython keep its
        # attributes in a dict of their own, and every step's attribute reads then took 0.2 us more)
        self._framework_attrs = FRAMEWORK_ATTRIBUTES if saves_nothing else None
        self.setup()
        self.status = "initialized"

    # --- to be written by components ---------------------------------------------------------

    def setup(self) -> None:
        """Build the initial state from ``self.params``."""

    def _step_impl(self, t: float, dt: float, inputs: dict[str, Message | None]) -> dict[str, Message]:
        """Advance from ``t`` to ``t + dt`` [s] given this step's inputs; return the outputs to publish.

        Ports left out of the returned dict publish nothing this step.
        """
        raise NotImplementedError(f"{type(self).__name__} must implement _step_impl")

    def get_state(self) -> dict[str, Any]:
        """The full dynamic state as plain data (numbers, strings, lists, dicts, numpy arrays)."""
        return {}

    def set_state(self, state: dict[str, Any]) -> None:
        """Restore a state produced by :meth:`get_state` (or :meth:`checkpoint_state`)."""

    def checkpoint_state(self) -> dict[str, Any]:
        """The state a checkpoint records: :meth:`get_state` unless a component gives a smaller form
        of the same state, which its :meth:`set_state` then takes as well (the water leaves out its
        columns at rest)."""
        return self.get_state()

    def initial_outputs(self) -> dict[str, Message]:
        """What the component publishes at t = 0, before the first tick (e.g. a body's initial state)."""
        return {}

    def start_inputs(self, inputs: dict[str, Message | None]) -> None:
        """What this component's inputs hold at t = 0, once every component has published its
        initial outputs and before the first step: for each input port, its source's initial output
        (a direct edge) or the edge's ``initial`` (a delayed one), summed over several edges as a
        step's are; None for an event port or a port fed by nothing at t = 0. A step's inputs are
        those at its end, so a component that must know where something started (a monitor measuring
        the distance a body travels) reads it here. Called before the first step of every run that
        starts at t = 0 (a restart from a later checkpoint has what was read in the checkpoint).
        Default: nothing."""

    def max_stable_step(self) -> float:
        """Largest step [s] this component can take stably from its current state (inf if unbounded)."""
        return math.inf

    def stable_step_cause(self) -> str:
        """What sets :meth:`max_stable_step` when a parameter does, naming it, for the scene's refusal
        of a step over it ("" when the component's own dynamics do). Default: ""."""
        return ""

    def input_max_age(self, port: str) -> tuple[float, str] | None:
        """How long [s] a message on input ``port`` may stay the latest before it misleads this
        component, and the parameter that sets it; None when any age will do. The scene is refused
        when the port's source publishes less often (its step, plus a tick over a delayed edge): a
        coupler, for instance, asks the water for a window reaching only ``lookahead`` seconds ahead
        of the body. Default: any age."""
        return None

    def needed_outputs(self) -> dict[str, str]:
        """Outputs that must feed some input for this component's settings to mean anything, each
        with what needs it (a coupler's added mass acts only through the body's port). The scene is
        refused when one feeds nothing. Default: none."""
        return {}

    def answers(self) -> dict[str, str]:
        """Outputs that answer an input: each output port with the input port whose senders it must
        reach (a pond's patch for a body goes back to the coupler that asked for it on the request
        port beside it). The scene is refused when a component sending on the input is not fed by the
        output: wired to another body's answer, it would meet water that is not where it asked.
        Default: none."""
        return {}

    def same_senders(self) -> dict[str, str]:
        """Inputs that must come from the components sending on another input: each input port with
        the one whose senders it must have (a pond's occupied height of a body comes from the coupler
        asking for that body's patch). The scene is refused otherwise. Default: none."""
        return {}

    def exclusive_inputs(self) -> tuple[str, ...]:
        """Inputs whose senders, taken together, no other component of this type may share: two
        couplers of one body to one water each add the water's forces (a pine ball floated 2 cm high
        on double buoyancy). The scene is refused otherwise. Default: none."""
        return ()

    def fed_through(self) -> dict[str, str]:
        """Inputs whose sender must itself be fed by the sender of another input: each input port with
        that other one (a stage monitor's contact report comes from the coupler of the body it
        watches, not another body's). The scene is refused otherwise. Default: none."""
        return {}

    def told_of(self) -> dict[str, tuple[str, str]]:
        """Inputs that take the answers another component is given: each input port with (another
        input of this component, the input of that one's sender the answers arrive on). A coupler's
        ``ground`` takes what answers its body on the body's ``impulse``. The scene must then feed it
        from every component and only the components answering there, directly (the answer to the
        state it meets in the same tick) and stepping at this component's rate; one answered but
        not told is said as the scene loads. Default: none."""
        return {}

    def check_start(self, inputs: dict[str, Message | None]) -> list[str]:
        """Problems with what this component will receive at t = 0, as plain sentences; the scene is
        refused with them when it loads (bad input, exit 2). ``inputs``: each input port's value then
        (its source's initial output, or the delayed edge's ``initial``; None when not known). A
        ground, for instance, refuses a body that starts deep inside it. Default: none."""
        return []

    def idle_outputs(self) -> dict[str, str]:
        """Outputs this component never publishes with its settings, each with why: a connection from
        one delivers nothing but its initial value, which the scene's notices say. Default: none."""
        return {}

    def notices(self) -> list[str]:
        """What is worth saying about this component's settings though the scene is not refused for
        it (a mode known to mislead), as plain sentences. The scene keeps them (``Scene.notices``);
        ``cosim run``, ``validate`` and ``sweep`` say each once, as a warning line.
        Default: none."""
        return []

    def start_stable_step(self, inputs: dict[str, Message | None]) -> float:
        """Largest stable step [s] this component will need once the run is under way, judged from
        what it receives at t = 0 (``inputs`` as for :meth:`check_start`); the scene is refused when
        its step exceeds it under ``on_unstable: error``, or would need more than MAX_SUBSTEPS
        substeps. :meth:`max_stable_step` says the same of the state at hand; this is for a bound that
        the state only reaches later (a coupler's, once the body it waits for meets the water).
        Default: unbounded."""
        return math.inf

    def check_step(self, step: float, inputs: dict[str, Message | None]) -> list[str]:
        """Problems with this component's step ``step`` [s] for what it will receive at t = 0
        (``inputs`` as for :meth:`check_start`), as plain sentences; the scene is refused with them
        whatever its ``on_unstable``. For a bound that no substepping of this component can meet: a
        ground answers its body once per body step, so a step in which the body falls through a
        good part of itself is refused, not substepped. Default: none."""
        return []

    def check_start_sources(self, inputs: dict[str, Message | None], sources: dict[str, Component]) -> list[str]:
        """Like :meth:`check_start`, for what only the components feeding this one know before the
        run: ``sources``, each input port fed by one edge and the component at its other end. A
        coupler, for instance, refuses a body that starts under its water's bed. Default: none."""
        return []

    @classmethod
    def one_source(cls, port: str) -> str:
        """What to do instead of feeding input ``port`` from several edges, when its message type does
        not add up: said with the scene's refusal. Default: nothing more to say."""
        return ""

    @classmethod
    def configure(cls, params: Any, path: str, base_dir: Path, problems: list[str]) -> type[Component] | None:
        """The class a scene builds for ``params``: ``cls`` itself (the default), unless the
        component's ports or files depend on its parameters. An FMU, for one, turns its variables
        into ports and finds its file beside the scene: it returns a subclass declaring those ports.
        ``params``: the validated parameters, or None when they were not valid; ``path``: the
        component's YAML path (``components.gust``); ``base_dir``: the folder the scene's relative
        file names start from. Problems go to ``problems`` as ``path: rule (got value)`` lines;
        None means the ports are not known (the scene's edges to them are then not checked)."""
        return cls

    @classmethod
    def estimate_bytes(cls, params: Any) -> int:
        """About how many bytes of memory a component built from ``params`` will hold (its arrays),
        asked before it is built; 0 when not known (the default). A scene whose components together
        need more than the machine has is refused when it loads, instead of failing (or swapping)
        while it builds."""
        return 0

    @classmethod
    def memory_advice(cls, params: Any) -> str:
        """What to change when the scene is refused for the memory this component would hold
        (:meth:`estimate_bytes`), said with the refusal."""
        return "use a smaller grid"

    def summary(self) -> list[str]:
        """Lines for the closing run summary."""
        return []

    def visuals(self, port: str, msg: Message) -> list[Any]:
        """Viewer items (:mod:`cosim.view.items`) showing ``msg``, just published on ``port``.

        Called at the visual frame rate only, by the recorder's visual deriver, never on the physics
        path. The default shows nothing of its own: the deriver then uses the visuals registered for
        the message type (the ``cosim.visuals`` entry points). Override it for a look of your own.
        """
        return []

    def metrics(self) -> dict[str, float | int | str]:
        """Named results of the run so far (scalars), for sweeps and studies, e.g. {"skips": 4}."""
        return {}

    # --- services for components -------------------------------------------------------------

    def request_stop(self, reason: str) -> None:
        """Ask the master to end the run after the current tick (e.g. 'stone at rest')."""
        self.stop_reason = reason

    @classmethod
    def type_name(cls) -> str:
        return cls.__name__

    # --- the public step ----------------------------------------------------------------------

    def start_outputs(self) -> dict[str, Message]:
        """What the component publishes at t = 0 (:meth:`initial_outputs`), checked like a step's
        outputs; any failure is a :class:`SimulationError` naming the component at t = 0."""
        outputs = self._own_failure(0, "its outputs at t = 0: ", self.initial_outputs)
        self._mapping(outputs, 0, "its outputs at t = 0 are", "output port to message")
        self._check_outputs(0, outputs)
        return outputs

    def begin(self, inputs: dict[str, Message | None]) -> None:
        """:meth:`start_inputs`, any failure a :class:`SimulationError` naming the component at t = 0."""
        self._own_failure(0, "its inputs at t = 0: ", lambda: self.start_inputs(inputs))

    def _own_fingerprints(self) -> dict[str, str | None]:
        """Each attribute the component set itself (not the framework's), by the fingerprint of its
        value (:func:`fingerprint`; None: its content cannot be read, so its changes
        cannot be told)."""
        return {key: fingerprint(value) for key, value in vars(self).items() if key not in self._framework_attrs}

    def unsaved_state(self) -> list[str]:
        """The attributes, by name, that a component whose class saves no state (the base
        :meth:`get_state`) has changed or added since the run's first checkpoint (at its start, once
        set up and given its inputs at t = 0): a state between steps that a checkpoint does not hold,
        so a restart from it would start the component as set up, not as it was. Empty for a
        component that saves its state or keeps none, and at the first checkpoint. Values are compared
        by content (a set rebuilt in another order is the same set), through fingerprints, never a
        copy: a large table the component only reads costs a pass over it at each checkpoint, and
        nothing in between."""
        if self._framework_attrs is None:
            return []
        now = self._own_fingerprints()
        first = self._first_fingerprints
        if first is None:
            self._first_fingerprints = now
            return []
        return sorted(key for key, value in now.items() if value is not None and first.get(key) != value)

    def state_for_checkpoint(self, t_ns: int) -> dict[str, Any]:
        """:meth:`checkpoint_state` for a checkpoint at ``t_ns``: a state that fails, or is not a
        mapping, is a :class:`SimulationError` naming the component then (it was an internal error,
        and a state of None was recorded, then refused by the restart from it)."""
        state = self._own_failure(t_ns, "its state for a checkpoint failed: ", self.checkpoint_state)
        return self._mapping(state, t_ns, "its state for a checkpoint is", "names to plain data")

    def _own_failure(self, t_ns: int, about: str, call: Callable[[], _T]) -> _T:
        """``call()``, its failure the component's (status failed) at ``t_ns``, said after ``about``;
        sys.exit() and a bare BaseException too, as in a step (see :meth:`step`), not a Ctrl-C."""
        try:
            return call()
        except SimulationError:
            self.status = "failed"
            raise
        except KeyboardInterrupt:
            raise
        except BaseException as exc:
            self.status = "failed"
            raise SimulationError(self.name, t_ns, f"{about}{type(exc).__name__}: {exc}") from exc

    def _mapping(self, value: Any, t_ns: int, said: str, of: str) -> Any:
        """``value``, which a component hook returns as a mapping (of ``of``); anything else the
        component's failure at ``t_ns``: "``said`` NoneType, not a mapping of ``of``" (a forgotten
        return was an internal error)."""
        if not isinstance(value, dict):
            self.status = "failed"
            raise SimulationError(self.name, t_ns, f"{said} {type(value).__name__}, not a mapping of {of}")
        return value

    def step(self, t_ns: int, dt_ns: int, inputs: dict[str, Message | None],
             on_unstable: OnUnstable = "error") -> dict[str, Message]:
        """Advance one step of ``dt_ns`` [ns] from ``t_ns`` [ns] on ``inputs`` (input port -> message or
        None), driven by hand (a test, a script): the inputs are held to the declared ports first, so a
        misspelt port or a message of another type is the caller's error, named, not a port silently
        left empty or an AttributeError deep in the step. The scheduler, whose inputs are its own
        plan's, goes straight to :meth:`step_gathered`. An input port left out is given None, as the
        scheduler gives an unconnected one (a required one left out is the caller's error, named), and
        the times must be whole nanoseconds (a dt in seconds, 0.01, ran a step of 1e-11 s)."""
        at = 0  # the time said with a refusal: the step's own once it is a whole number
        for name, value in (("t_ns", t_ns), ("dt_ns", dt_ns)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer):
                raise SimulationError(self.name, at, f"was given {name} = {value!r}, not a whole number of "
                                      "nanoseconds (step takes times in ns; its _step_impl is given seconds)")
            at = int(t_ns)
        if t_ns < 0 or dt_ns <= 0:
            raise SimulationError(self.name, at, f"was given t_ns = {t_ns} and dt_ns = {dt_ns}: a step starts at "
                                  "t_ns >= 0 and lasts dt_ns > 0")
        self._check_inputs(t_ns, inputs)
        missing = [port for port in self.inputs if port not in inputs]
        if missing:
            required = [port for port in missing if self.inputs[port].required]
            if required:
                raise SimulationError(self.name, int(t_ns), f"was not given its required input "
                                      f"{', '.join(map(repr, required))}")
            inputs = {**dict.fromkeys(missing), **inputs}
        return self.step_gathered(int(t_ns), int(dt_ns), inputs, on_unstable)

    def _check_inputs(self, t_ns: int, inputs: Any) -> None:
        """A :class:`SimulationError` unless ``inputs`` maps this component's input ports to messages
        of their types (or None); the component is left as it was (the error is the caller's)."""
        if not isinstance(inputs, dict):
            raise SimulationError(self.name, t_ns, f"was given inputs as {type(inputs).__name__}, not a mapping "
                                  "of input port to message")
        declared = self.inputs
        for port, msg in inputs.items():
            spec = declared.get(port)
            if spec is None:
                ports = ", ".join(declared) or "none"
                raise SimulationError(self.name, t_ns, f"was given input {port!r}, which is not one of its "
                                      f"input ports ({ports})")
            if msg is not None and not isinstance(msg, spec.type):
                raise SimulationError(self.name, t_ns, f"input {port!r} was given a {type(msg).__name__}; "
                                      f"the port takes {spec.type.__name__}")

    def step_gathered(self, t_ns: int, dt_ns: int, inputs: dict[str, Message | None],
                      on_unstable: OnUnstable = "error") -> dict[str, Message]:
        """:meth:`step` on inputs already known to be the component's own ports' (the scheduler's
        gather, a replay's decoded channels): guards and bookkeeping around ``_step_impl``."""
        if self.status not in ("initialized", "running"):
            raise SimulationError(self.name, t_ns, f"cannot step a component whose status is {self.status!r}")
        t = t_ns / NS_PER_S
        dt = dt_ns / NS_PER_S
        try:
            if self._bounded:
                outputs = self._bounded_step(t_ns, t, dt, inputs, on_unstable)
            else:  # (no stable step of its own: one step, nothing for restep to keep)
                self.status = "running"
                outputs = self._step_impl(t, dt, inputs)
        except SimulationError:
            self.status = "failed"
            raise
        except KeyboardInterrupt:
            raise
        except BaseException as exc:
            # SystemExit too (sys.exit() in a component's step): let through, it ended a run with exit 0
            # and said nothing, its recording without a status
            self.status = "failed"
            raise SimulationError(self.name, t_ns, f"{type(exc).__name__}: {exc}") from exc
        if not isinstance(outputs, dict):  # (the guard's call only when it fails: every step's path)
            self._mapping(outputs, t_ns, "its step returned", "output port to message")
        self._check_outputs(t_ns, outputs)
        self.step_count += 1
        return outputs

    def _bounded_step(self, t_ns: int, t: float, dt: float, inputs: dict[str, Message | None],
                      on_unstable: OnUnstable) -> dict[str, Message]:
        """The step of a component with a stable step of its own (:meth:`max_stable_step`): in as
        many substeps as its bound asks, the step's terms kept while it runs so that a bound it learns
        inside it (:meth:`restep`) is judged as the scheduler would. (A component without one takes
        its step whole, and keeps nothing: every step of every component passes here, and building
        the record cost 5% of the framework's overhead.)"""
        bound = self.max_stable_step()
        substeps = 1 if bound >= dt else self._substeps_for(t_ns, dt, bound, on_unstable)
        self.status = "running"
        self._stepping = (t_ns, dt, on_unstable, substeps, bound)
        try:
            if substeps == 1:
                outputs = self._step_impl(t, dt, inputs)
            else:
                outputs = self._substep(t, dt, substeps, inputs)
            # (the count a component's restep raised it to, said as the scheduler's own)
            stepping = self._stepping
            self.last_substeps = stepping[3]
            self.last_stable_step = stepping[4]
        finally:
            self._stepping = None
        return outputs

    def _substeps_for(self, t_ns: int, dt: float, bound: float, on_unstable: OnUnstable) -> int:
        """The substeps a step of ``dt`` [s] from ``t_ns`` needs under a stable step ``bound`` [s] below
        it; a :class:`SimulationError` under ``on_unstable: error``, over MAX_SUBSTEPS, or for a bound
        no step can keep (0, negative, NaN)."""
        if not bound > 0:
            raise SimulationError(self.name, t_ns, f"its stable step is {bound!r} s: no step can be stable")
        if on_unstable == "error":
            step_said, bound_said = step_and_bound(dt, bound)
            raise SimulationError(
                self.name, t_ns,
                f"step {step_said} s exceeds the stable step {bound_said} s (on_unstable: error; "
                f"use a base step or 'every' giving at most {bound_said} s, or on_unstable: substep)")
        substeps = math.ceil(dt / bound)
        if substeps > MAX_SUBSTEPS:
            raise SimulationError(
                self.name, t_ns, f"needs {substep_count(substeps)} substeps (stable step {bound:.3g} s), "
                f"more than the limit {MAX_SUBSTEPS}")
        return substeps

    def restep(self, bound: float, step_taken: float | None = None) -> int | None:
        """For a component that learns, inside its step, that the state it has just received needs a
        shorter stable step than the one the scheduler asked for before the step (:meth:`max_stable_step`
        tells the state at hand then: a coupler's, its body's previous one): the substeps this step
        needs under ``bound`` [s], judged as the scheduler judges a step before it (a
        :class:`SimulationError` naming the step and the bound under ``on_unstable: error``, or past
        MAX_SUBSTEPS) and, when more than it takes, said as taken (:attr:`last_substeps`,
        :attr:`last_stable_step`); the component then takes them itself. The count the step already
        takes when ``bound`` covers its substeps; None outside :meth:`step` (a component driven by hand
        through :meth:`_step_impl` takes the step it is given) and for a component without a stable
        step of its own (:meth:`max_stable_step`), whose step is taken whole. ``step_taken`` [s]: the
        length of the pieces the component takes itself, when it splits one of the scheduler's
        substeps under ``bound`` (the count said is then the step over it, which may be more than the
        bound's own)."""
        if self._stepping is None:
            return None
        t_ns, dt, on_unstable, substeps, _ = self._stepping
        if bound >= dt / substeps:
            return substeps
        substeps = self._substeps_for(t_ns, dt, bound, on_unstable)
        if step_taken is not None:
            substeps = max(substeps, round(dt / step_taken))
        self._stepping = (t_ns, dt, on_unstable, substeps, bound)
        return substeps

    def _substep(self, t: float, dt: float, n: int, inputs: dict[str, Message | None]) -> dict[str, Message]:
        """n equal substeps with held inputs; event inputs (impulses) go to the first substep only.
        The step's outputs are what its substeps published: each port's latest, an event output of an
        additive type their sum (only the last substep's were kept: a port published earlier in the
        step, an event above all, was lost)."""
        h = dt / n
        events = [name for name, port in self.inputs.items() if port.event]
        later = {k: (None if k in events else v) for k, v in inputs.items()} if events else inputs
        outputs: dict[str, Message] = {}
        for i in range(n):
            for port, msg in self._step_impl(t + i * h, h, inputs if i == 0 else later).items():
                spec = self.outputs.get(port)
                earlier = outputs.get(port)
                if earlier is not None and spec is not None and spec.event and type(msg).additive:
                    msg = earlier + msg
                outputs[port] = msg
        return outputs

    def _check_outputs(self, t_ns: int, outputs: dict[str, Message]) -> None:
        declared = self.outputs
        for port, msg in outputs.items():
            spec = declared.get(port)
            if spec is None:
                self.status = "failed"
                raise SimulationError(self.name, t_ns, f"returned unknown output port {port!r} "
                                      f"(declared: {', '.join(declared) or 'none'})")
            if type(msg) is not spec.type:
                self.status = "failed"
                raise SimulationError(self.name, t_ns, f"output {port!r} must be {spec.type.__name__}, "
                                      f"got {type(msg).__name__}")
            bad = msg.first_invalid()
            if bad is not None:
                self.status = "failed"
                field, fault = bad
                if fault == NONFINITE:
                    raise SimulationError(self.name, t_ns, f"non-finite value in output {port!r} field {field!r}")
                raise SimulationError(self.name, t_ns, f"output {port!r} field {field!r}: {fault}")


# --- fingerprints: whether a component's own attributes changed between two checkpoints -------------
# (Component.unsaved_state). A value's fingerprint is a short digest that two equal values share
# whatever their layout in memory (a set rebuilt in another order, a dict whose keys came in another
# order, equal strings that are or are not one object), an array read in place, never copied; a value
# whose content cannot be read (an open file, a lock, a native handle) has none: None.

FINGERPRINT_DEPTH = 8  # nesting read into; deeper, the value's content is not told (no fingerprint)

_SCALARS = (type(None), bool, int, float, complex, str, bytes)
_NAMED = (types.FunctionType, types.BuiltinFunctionType, types.MethodType, types.ModuleType, type)


class _Untold(Exception):
    """Raised inside :func:`fingerprint` for a value whose content cannot be read."""


def fingerprint(value: Any) -> str | None:
    """The hex digest of ``value``'s content, or None where it cannot be read."""
    digest = hashlib.blake2b(digest_size=16)
    try:
        _feed(digest, value, 0, set())
    except (_Untold, RecursionError):
        return None
    return digest.hexdigest()


def _feed(digest: Any, value: Any, depth: int, inside: set[int]) -> None:
    if depth > FINGERPRINT_DEPTH:
        raise _Untold
    if isinstance(value, _SCALARS):
        digest.update(f"{type(value).__name__}:{value!r};".encode())
        return
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            _feed(digest, value.tolist(), depth + 1, inside)
            return
        # its bytes by their CRC, read in place when the array is contiguous (a CRC is about twice as
        # fast as a cryptographic digest over a large table, and a change it misses is a 2^-32 chance)
        content = zlib.crc32(np.ascontiguousarray(value).data)
        digest.update(f"array:{value.dtype.str}:{value.shape}:{content};".encode())
        return
    if isinstance(value, np.generic):
        digest.update(f"{type(value).__name__}:{value!r};".encode())
        return
    if isinstance(value, _NAMED):  # code, not data: known by its name
        digest.update(f"named:{getattr(value, '__module__', '')}.{getattr(value, '__qualname__', value)!s};".encode())
        return
    if id(value) in inside:  # a cycle: its content is being read further up
        digest.update(b"cycle;")
        return
    inside.add(id(value))
    try:
        if isinstance(value, (list, tuple)):
            digest.update(f"{type(value).__name__}[{len(value)};".encode())
            for item in value:
                _feed(digest, item, depth + 1, inside)
        elif isinstance(value, (set, frozenset)):
            digest.update(f"{type(value).__name__}{{{len(value)};".encode())
            for item in sorted(_member(v, depth, inside) for v in value):
                digest.update(item.encode())
        elif isinstance(value, dict):
            digest.update(f"{type(value).__name__}{{{len(value)};".encode())
            for pair in sorted(_member(k, depth, inside) + _member(v, depth, inside) for k, v in value.items()):
                digest.update(pair.encode())
        elif hasattr(value, "__dict__") or hasattr(type(value), "__slots__"):
            fields = dict(vars(value)) if hasattr(value, "__dict__") else {}
            for slot in getattr(type(value), "__slots__", ()):
                if hasattr(value, slot):
                    fields[slot] = getattr(value, slot)
            digest.update(f"object:{type(value).__module__}.{type(value).__qualname__};".encode())
            _feed(digest, fields, depth + 1, inside)
        else:
            raise _Untold
    finally:
        inside.discard(id(value))


def _member(value: Any, depth: int, inside: set[int]) -> str:
    """The digest of a member of a set or a dict (whose order is not the content's: the members are
    sorted by it), read within the same walk (its depth and the cycles above it)."""
    digest = hashlib.blake2b(digest_size=16)
    _feed(digest, value, depth + 1, inside)
    return digest.hexdigest()
