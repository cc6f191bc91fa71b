"""Small components for framework tests: they know nothing about stones or water.

Each records the inputs it received per step in ``seen`` so scheduler tests can assert what every
step got.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass

from cosim.component import Component, Port
from cosim.messages import Message, message
from cosim.params import param
from cosim.scheduler import BaseObserver


@message
class Scalar(Message):
    """A plain number (no unit)."""

    value: float


@message
class Force(Message):
    """An additive number [N], for summing ports."""

    value: float

    additive = True

    def __add__(self, other: Force) -> Force:  # type: ignore[override]
        return Force(self.value + other.value)


@message
class Text(Message):
    """A string, to test type mismatches."""

    text: str


class Source(Component):
    """Publishes value = start + rate * t_end at the end of each step (t in seconds)."""

    @dataclass(frozen=True)
    class Params:
        start: float = param(0.0)
        rate: float = param(1.0, unit="1/s")

    outputs = {"out": Port(Scalar), "force": Port(Force)}

    def setup(self) -> None:
        self.t = 0.0
        self.seen: list[tuple[float, dict]] = []

    def _step_impl(self, t, dt, inputs):
        self.seen.append((t, dict(inputs)))
        self.t = t + dt
        value = self.params.start + self.params.rate * self.t
        return {"out": Scalar(value), "force": Force(value)}

    def get_state(self):
        return {"t": self.t}

    def set_state(self, state):
        self.t = state["t"]


class Gain(Component):
    """out = gain * x (+ 1 if x is missing); records its inputs."""

    @dataclass(frozen=True)
    class Params:
        gain: float = param(2.0)

    inputs = {"x": Port(Scalar)}
    outputs = {"out": Port(Scalar)}

    def setup(self) -> None:
        self.seen: list[tuple[float, dict]] = []

    def start_inputs(self, inputs):
        self.started = dict(inputs)

    def get_state(self):
        return {}  # what it was given is the test's log, not a state: its outputs do not depend on it

    def _step_impl(self, t, dt, inputs):
        self.seen.append((t, dict(inputs)))
        x = inputs["x"]
        return {"out": Scalar(self.params.gain * x.value if x is not None else 1.0)}


class Accumulator(Component):
    """Integrates its input: total += x * dt; publishes the total. Stops at ``stop_at`` if set."""

    @dataclass(frozen=True)
    class Params:
        stop_at: float = param(math.inf)
        stable_step: float = param(math.inf, unit="s", gt=0)
        max_age: float = param(math.inf, unit="s", gt=0, doc="the oldest input x it can use")

    inputs = {"x": Port(Scalar)}
    outputs = {"total": Port(Scalar)}

    def input_max_age(self, port):
        return None if math.isinf(self.params.max_age) else (self.params.max_age, "max_age")

    def setup(self) -> None:
        self.total = 0.0
        self.seen: list[tuple[float, dict]] = []
        self.calls: list[float] = []

    def _step_impl(self, t, dt, inputs):
        self.seen.append((t, dict(inputs)))
        self.calls.append(dt)
        x = inputs["x"]
        self.total += (x.value if x is not None else 0.0) * dt
        if self.total >= self.params.stop_at:
            self.request_stop(f"total reached {self.total:g}")
        return {"total": Scalar(self.total)}

    def initial_outputs(self):
        return {"total": Scalar(self.total)}

    def get_state(self):
        return {"total": self.total}

    def set_state(self, state):
        self.total = state["total"]

    def max_stable_step(self):
        return self.params.stable_step


class Summer(Component):
    """Receives an additive Force port and an event port; records both."""

    inputs = {"f": Port(Force), "kick": Port(Scalar, event=True), "label": Port(Text)}
    outputs = {"sum": Port(Force)}

    def setup(self) -> None:
        self.seen: list[tuple[float, dict]] = []

    def get_state(self):
        return {}  # what it was given is the test's log, not a state: its outputs do not depend on it

    def _step_impl(self, t, dt, inputs):
        self.seen.append((t, dict(inputs)))
        f = inputs["f"]
        return {"sum": Force(f.value if f is not None else 0.0)}


class Kicker(Component):
    """Publishes the additive event Force(n) at its n-th step, for n in ``at`` (every step when
    empty), on ``kick`` (an event output); with ``stable_step`` it substeps, and kicks at its n-th
    substep instead."""

    @dataclass(frozen=True)
    class Params:
        at: list[int] = param([])
        stable_step: float = param(math.inf, unit="s", gt=0)

    outputs = {"kick": Port(Force, event=True)}

    def setup(self) -> None:
        self.n = 0

    def _step_impl(self, t, dt, inputs):
        self.n += 1
        return {"kick": Force(float(self.n))} if not self.params.at or self.n in self.params.at else {}

    def max_stable_step(self):
        return self.params.stable_step

    def get_state(self):
        return {"n": self.n}

    def set_state(self, state):
        self.n = state["n"]


class Announcer(Component):
    """Publishes the event Scalar(t_end) at every step on ``note`` (a type that cannot be summed),
    and, with ``at_start``, Scalar(0) at t = 0 too."""

    @dataclass(frozen=True)
    class Params:
        at_start: bool = param(True)

    outputs = {"note": Port(Scalar, event=True)}

    def initial_outputs(self):
        return {"note": Scalar(0.0)} if self.params.at_start else {}

    def _step_impl(self, t, dt, inputs):
        return {"note": Scalar(t + dt)}


class Catcher(Component):
    """Takes the additive event input ``kick``; publishes the total of what it received."""

    inputs = {"kick": Port(Force, event=True)}
    outputs = {"total": Port(Force)}

    def setup(self) -> None:
        self.total = 0.0
        self.seen: list[tuple[float, dict]] = []

    def _step_impl(self, t, dt, inputs):
        self.seen.append((t, dict(inputs)))
        kick = inputs["kick"]
        self.total += kick.value if kick is not None else 0.0
        return {"total": Force(self.total)}

    def get_state(self):
        return {"total": self.total}

    def set_state(self, state):
        self.total = state["total"]


class Faulty(Component):
    """Raises (or returns NaN) once t reaches ``fail_at`` seconds; with ``mode: start``, raises on
    reading its inputs at t = 0 (``start_exit``, ``start_base``: sys.exit(3), a bare BaseException;
    ``start_none``: its outputs at t = 0 are None). Other modes, from ``fail_at``: ``exit`` calls
    sys.exit(3), ``base`` raises a bare BaseException, ``none`` returns None from its step (a
    forgotten return); ``state``, ``state_exit`` and ``state_object``: its state for a checkpoint
    raises, calls sys.exit(4), or holds an object that is not plain data."""

    @dataclass(frozen=True)
    class Params:
        fail_at: float = param(0.0, unit="s")
        mode: str = param("raise")

    outputs = {"out": Port(Scalar)}

    def start_inputs(self, inputs):
        if self.params.mode == "start":
            raise RuntimeError("boom at the start")
        if self.params.mode == "start_exit":
            sys.exit(3)
        if self.params.mode == "start_base":
            raise BaseException("base")

    def initial_outputs(self):
        return None if self.params.mode == "start_none" else {}

    def setup(self) -> None:
        self.t = 0.0

    def get_state(self):
        if self.t >= self.params.fail_at:
            if self.params.mode == "state":
                raise RuntimeError("no state")
            if self.params.mode == "state_exit":
                sys.exit(4)
            if self.params.mode == "state_object":
                return {"t": object()}
        return {"t": self.t}

    def set_state(self, state):
        self.t = state["t"]

    def _step_impl(self, t, dt, inputs):
        self.t = t + dt
        mode = self.params.mode
        if t >= self.params.fail_at and not mode.startswith("state"):
            if mode == "nan":
                return {"out": Scalar(math.nan)}
            if mode == "exit":
                sys.exit(3)
            if mode == "base":
                raise BaseException("base")
            if mode == "none":
                return None
            raise RuntimeError("boom")
        return {"out": Scalar(t)}


class Channels(BaseObserver):
    """An observer keeping every (time [s], message) published on the watched ``component.port``
    channels, in order."""

    def __init__(self, *names: str):
        self.seen: dict[str, list] = {name: [] for name in names}

    def on_exchange(self, time_ns, component, port, msg):
        key = f"{component}.{port}"
        if key in self.seen:
            self.seen[key].append((time_ns / 1e9, msg))

    def messages(self, name: str) -> list:
        """The messages of channel ``name``, in order (without their times)."""
        return [msg for _, msg in self.seen[name]]
