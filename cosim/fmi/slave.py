"""A scene running inside an FMI 2.0 co-simulation FMU (the slave class of ``cosim fmu export``).

The FMU's resources hold the scene (``scene.yaml``) and what it shows (``export.json``, an
:class:`~cosim.fmi.spec.ExportSpec`). Its parameters are set before initialization; leaving
initialization loads the scene with them (as ``--set`` overrides) and publishes the t = 0 values,
and a parameter set after that is refused (they are fixed: the scene runs with the values it had).
Each ``doStep(t, h)`` runs ``h / dt`` base steps of the scene, exactly as ``cosim run`` does, so the
outputs at a communication point are the scene's values at that time, bit for bit. Once the scene
stops itself (the stone sank), the outputs hold their last values. A start time after 0 (setupExperiment)
is run up to during initialization, so that holds from the first communication point on. After
terminate, doStep is refused; reset (a new instance of the class) makes the FMU ready to run again.

Each failure is logged as an Error through the FMU's logger and also written to the process's
standard error (see :meth:`SceneSlave._report`).

The FMU runs the Python that loads it (pythonfmu's binaries embed or join an interpreter): that
Python needs cosim and its components installed, the same version for the same results.
"""

from __future__ import annotations

import hashlib
import math
import sys
from pathlib import Path
from typing import Any, NoReturn

from pythonfmu import Boolean, Fmi2Causality, Fmi2Slave, Fmi2Variability, Integer, Real
from pythonfmu.default_experiment import DefaultExperiment
from pythonfmu.enums import Fmi2Status

import cosim.fmi
from cosim.codec.json_codec import codec_for, decode_state, encode_state
from cosim.errors import one_line
from cosim.fmi.pythonfmu_exit import release_binaries_at_exit
from cosim.fmi.spec import ExportSpec, Output, load_preset
from cosim.messages import Message
from cosim.scenario import MAX_TIME_NS, loads
from cosim.scheduler import BaseObserver, Simulation
from cosim.timebase import NS_PER_S, exact_seconds, ticks_reaching

SCENE_FILE = "scene.yaml"
SPEC_FILE = "export.json"
STEP_SLACK = 1e-6  # a step size or start time within this share of a base step of a whole number of them is that
# A doStep time within this share of a base step of the scene's time is that time: the scene is on its grid of
# base steps, and a master that adds up its time (t += h) drifts from it by round-off that grows with the run
# (2400 ulp of t by t = 2304 s in steps of 0.1 s: 1.1 ns, more than a millionth of a 1 ms step)
TIME_SLACK = 0.25


class _Latest(BaseObserver):
    """Keeps the last message of each watched port."""

    def __init__(self, ports: set[tuple[str, str]]):
        self.ports = ports
        self.messages: dict[tuple[str, str], Message] = {}

    def on_exchange(self, time_ns: int, component: str, port: str, msg: Message) -> None:
        if (component, port) in self.ports:
            self.messages[(component, port)] = msg


def _value(out: Output, msg: Message | None) -> Any:
    """An output's value from its port's latest message (zero before the port's first message)."""
    if msg is None:
        return {"real": 0.0, "boolean": False}.get(out.kind, 0)
    value = getattr(msg, out.field)
    if out.index is not None:
        value = value[out.index]
    return {"real": float, "boolean": bool}.get(out.kind, int)(value)


def _run_to(sim: Simulation, end_tick: int) -> None:
    """Run ``sim``'s base steps up to ``end_tick``; once the scene has ended, as `cosim run` ends it
    (it stopped itself, the stone sank, or reached its ``until``), time goes on and the outputs hold.
    (The scene ran on past its ``until``, which a ``--parameter`` on it therefore did not move: a
    master running past it got values `cosim run` never gives.)"""
    last_tick = ticks_reaching(sim.scene.until_ns, sim.dt_ns)  # the scene's end, as Simulation.run ends it
    while sim.tick < min(end_tick, last_tick) and sim.stop_reason is None:
        sim.step()
    if sim.tick < end_tick:
        sim.tick = end_tick


_held_namespaces: list[dict[str, Any]] = []


def hold_namespace(namespace: dict[str, Any]) -> None:
    """Keep one more reference to a slave module's namespace. pythonfmu's binaries (0.7) run the
    module's text again in its namespace each time they instantiate the FMU, then release one
    reference to that namespace they never took; a module whose namespace has few other holders
    (no functions of its own) would have it freed while in use. Called by the module's own text,
    so each run of it adds the reference the binaries then release."""
    _held_namespaces.append(namespace)


class SceneSlave(Fmi2Slave):
    """Runs the scene in its resources; subclassed once per exported FMU (the class names the FMU)."""

    def __init__(self, **kwargs: Any):
        super().__init__(**kwargs)
        folder = Path(self.resources)
        release_binaries_at_exit(folder)  # the binary's double release at exit (cosim.fmi.pythonfmu_exit)
        self.scene_text = (folder / SCENE_FILE).read_text(encoding="utf-8")
        spec_text = (folder / SPEC_FILE).read_text(encoding="utf-8")
        self.spec = ExportSpec.from_json(spec_text)
        # what a state of this FMU is saved with: a digest of the scene text and the export settings
        # (every FMU exported with the throw preset has the same variables, and a stone alone took the
        # state of a stone with a gust model, extra component and all)
        self.scene_digest = hashlib.sha256(self.scene_text.encode() + b"\0" + spec_text.encode()).hexdigest()
        self.description = "A cosim scene as a co-simulation FMU (cosim fmu export)"
        self.values: dict[str, Any] = {}
        self.sim: Simulation | None = None
        self.latest = _Latest({(o.component, o.port) for o in self.spec.outputs})
        self.start_time = 0.0  # setupExperiment's start time [s]: initialization runs the scene up to it
        self.initializing = False  # in Initialization Mode: the outputs are the scene's at the start time
        # the scene started for the outputs read during Initialization Mode, and the parameters (and
        # start time) it was built from: exitInitializationMode keeps it if they are unchanged
        self._started: tuple[tuple[Any, ...], Simulation] | None = None
        self.terminated = False  # set by terminate: FMI 2.0 then allows only reset (a new instance) and freeInstance
        # set when the scene failed in a doStep: an FMU inside it may have answered Fatal, and may not be
        # called again, so a state is restored into the scene built anew (see _restore_scene)
        self.failed = False
        for p in self.spec.parameters:
            self.values[p.name] = p.start
            kind = Integer if p.kind == "integer" else Real
            self.register_variable(kind(p.name, start=p.start, causality=Fmi2Causality.parameter,
                                        variability=Fmi2Variability.fixed, description=p.description,
                                        getter=self._getter(p.name), setter=self._setter(p.name)))
        for o in self.spec.outputs:
            self.values[o.name] = _value(o, None)
            kind = {"real": Real, "boolean": Boolean}.get(o.kind, Integer)
            # an Integer or a Boolean changes only at communication points: discrete, as FMI asks of it
            variability = Fmi2Variability.continuous if o.kind == "real" else Fmi2Variability.discrete
            self.register_variable(kind(o.name, causality=Fmi2Causality.output, variability=variability,
                                        description=o.description, getter=self._output_getter(o.name)))
        # the scene's own end and step (or --step's): a master's defaults (FMPy's 1 s, its own interval)
        # stopped a throw before the stone sank, or stepped off the scene's grid
        step_ns = self.spec.step_ns or self.spec.dt_ns
        if step_ns:
            self.default_experiment = DefaultExperiment(
                start_time=0.0, stop_time=self.spec.until_ns / NS_PER_S if self.spec.until_ns else None,
                step_size=step_ns / NS_PER_S)

    def _getter(self, name: str) -> Any:
        return lambda: self.values[name]

    def _output_getter(self, name: str) -> Any:
        def get() -> Any:
            if self.initializing and self.sim is None:
                # the model description lists every output as an initial unknown (calculated), which a
                # master may read in Initialization Mode: the scene's value at the start time, as the
                # parameters now stand (it read 0 until exitInitializationMode)
                self._start()
            return self.values[name]
        return get

    def _setter(self, name: str) -> Any:
        def put(value: Any) -> None:
            if self.sim is not None or self.terminated:
                # the scene was built from the parameters as they were when initialization ended: a
                # later value would be read back but never used (FMI 2.0 forbids setting a fixed one then)
                when = "after terminate" if self.terminated else "after initialization"
                self._fail(f"parameter {name!r} set to {value!r} {when}: a fixed parameter takes a value only "
                           f"before exitInitializationMode (FMI 2.0); it stays {self.values[name]!r}")
            self.values[name] = value
        return put

    def _report(self, message: str) -> None:
        """Log ``message`` as an Error, and write it to standard error too: pythonfmu's binaries pass
        the FMU's log on only while the master has turned debug logging on (FMPy's default is off,
        so a failed run ended with exit 0 and not a word), and FMPy's logger proxy is one per
        process, taken over by any FMU the scene itself holds. The standard error of the process
        running the FMU is where a user of any master sees it."""
        text = one_line(message)
        self.log(text, Fmi2Status.error)
        if cosim.fmi.host_calls == 0:  # else the cosim scene calling the FMU reports it in its own line
            print(f"error: FMU {type(self).__name__} (instance {self.instance_name!r}): {text}", file=sys.stderr,
                  flush=True)

    def _fail(self, message: str) -> NoReturn:
        """Report ``message`` and raise it: the FMU call fails (pythonfmu answers an exception with Fatal)."""
        self._report(message)
        raise RuntimeError(message)

    # --- initialization ----------------------------------------------------------------------------

    def setup_experiment(self, start_time: float, stop_time: float | None = None,
                         tolerance: float | None = None) -> None:
        """Take the start time, a whole number of the scene's base steps from t = 0 (else refused).

        The scene's clock is the FMU's: its t = 0 is the throw, and its scripts and its `until` name
        scene times. A master that starts its co-simulation at t0 > 0 (every FMU of its system on one
        clock) asks for the model as it is at t0, so the scene is run from 0 up to t0 during
        initialization, and every output is the scene's value at its time as from a start at 0.
        Refusing t0 > 0 would leave such a master no way to use the FMU; shifting the scene to start
        at t0 would make the outputs at t the scene's at t - t0, unlike every other communication
        point. Refused here, not later, against the base step the parameters give so far: a master
        learns it before it sets anything. (A parameter on the base step set later in
        Initialization Mode is checked again as the scene starts.)"""
        self.start_time = 0.0
        if start_time == 0:
            return
        if not start_time >= 0:  # a negative or NaN start: the scene has no time before its t = 0
            self._fail(f"a start time of {start_time:.9g} s: must be at least 0 s (the scene begins at t = 0)")
        if start_time * NS_PER_S > MAX_TIME_NS:  # (an infinite one's base step, round(inf), raised unsaid)
            self._fail(f"a start time of {start_time:.9g} s: must be at most {MAX_TIME_NS / NS_PER_S:.3g} s (the "
                       "scene's clock counts 64-bit nanoseconds)")
        try:
            dt_ns = loads(self.scene_text, source=SCENE_FILE, overrides=self.overrides(),
                          base_dir=self.spec.base_dir).dt_ns
        except Exception:  # parameters that make no scene: said as the scene starts
            dt_ns = self.spec.dt_ns or loads(self.scene_text, source=SCENE_FILE, base_dir=self.spec.base_dir).dt_ns
        self._start_tick(start_time, dt_ns)
        self.start_time = start_time

    def _start_tick(self, start_time: float, dt_ns: int) -> int:
        """The base step the start time [s] is, with the base step ``dt_ns`` [ns]; refused off its grid."""
        ticks = start_time * NS_PER_S / dt_ns
        if abs(ticks - round(ticks)) > STEP_SLACK:
            self._fail(f"a start time of {start_time:.9g} s is not a whole multiple of the scene's base step "
                       f"dt = {exact_seconds(dt_ns)} s (the scene advances in whole base steps)")
        return round(ticks)

    def enter_initialization_mode(self) -> None:
        self.initializing = True

    def overrides(self, values: dict[str, Any] | None = None) -> list[str]:
        """The ``--set`` overrides the parameters ask for (``values``: the variables', default the
        instance's own): none for a parameter at its start value (also as the model description
        writes it, with 16 digits); an Integer parameter's written as a whole number, as its scene
        value must be."""
        values = self.values if values is None else values
        changed: dict[str, Any] = {}
        for p in self.spec.parameters:
            if p.kind == "integer":
                if int(values[p.name]) != p.start:
                    changed[p.name] = int(values[p.name])
            elif float(values[p.name]) not in (p.start, float(f"{p.start:.16g}")):
                changed[p.name] = float(values[p.name])
        sets = list(self.spec.overrides)
        sets += [f"{p.key}={changed[p.name]!r}" for p in self.spec.parameters if p.key and p.name in changed]
        derived = {p.name: v for p in self.spec.parameters if not p.key and (v := changed.get(p.name)) is not None}
        if derived and self.spec.preset:
            as_written = loads(self.scene_text, source=SCENE_FILE, overrides=list(self.spec.overrides),
                               base_dir=self.spec.base_dir)
            sets += load_preset(self.spec.preset).overrides(as_written, derived)
        return sets

    def _simulation(self, values: dict[str, Any] | None = None) -> Simulation:
        scene = loads(self.scene_text, source=SCENE_FILE, overrides=self.overrides(values),
                      base_dir=self.spec.base_dir)
        return Simulation(scene, observers=[self.latest])

    def exit_initialization_mode(self) -> None:
        self.sim = self._start()
        self.initializing = False
        self._started = None

    def _start(self) -> Simulation:
        """The scene as the parameters now stand, initialized and run up to the start time, its
        outputs published; built once for the same parameters and start time."""
        key = (*(self.values[p.name] for p in self.spec.parameters), self.start_time)
        if self._started is not None and self._started[0] == key:
            return self._started[1]
        self._started = None
        self.latest.messages = {}
        try:
            sim = self._simulation()
            sim.initialize()
        except Exception as exc:  # a parameter that makes the scene invalid, a component that fails at t = 0
            self._fail(f"the scene cannot start: {exc}")
        if self.start_time:
            # (its base step is the one the parameters give: a step parameter set in Initialization
            # Mode may have put the start time off its grid, which was rounded down without a word)
            tick = self._start_tick(self.start_time, sim.dt_ns)
            try:
                _run_to(sim, tick)
            except Exception as exc:  # a SimulationError: the scene failed before the start time
                self._fail(f"the scene cannot run up to the start time {self.start_time:.9g} s: {exc}")
        self._publish()
        self._started = (key, sim)
        return sim

    def _publish(self) -> None:
        for o in self.spec.outputs:
            self.values[o.name] = _value(o, self.latest.messages.get((o.component, o.port)))

    # --- stepping ----------------------------------------------------------------------------------

    def _refuse(self, message: str) -> bool:
        """Report ``message`` and answer the doStep with Discard (pythonfmu's answer to False): the
        instance stays usable, and the master can step again as it should (an exception raised here
        would be Fatal, the instance dead)."""
        self._report(message)
        return False

    def do_step(self, current_time: float, step_size: float) -> bool:
        if self.terminated:
            return self._refuse(f"doStep from t = {current_time:.9g} s after terminate: a terminated FMU takes "
                                "only reset or freeInstance (FMI 2.0)")
        # (NaN compares false: a NaN time passed the check against the scene's time below, and the
        # scene stepped on; round() of a NaN or infinite step raised, which pythonfmu answers with Fatal)
        if not math.isfinite(current_time):
            return self._refuse(f"doStep from t = {current_time!r} s: the communication point must be a finite time")
        sim = self.sim
        if sim is None:
            return self._refuse("doStep before initialization")
        if not math.isfinite(step_size) or sim.time_ns + step_size * NS_PER_S > MAX_TIME_NS:
            return self._refuse(f"a communication step of {step_size!r} s: must be a finite number of seconds, "
                                f"ending by t = {MAX_TIME_NS / NS_PER_S:.3g} s (the scene's clock counts 64-bit "
                                "nanoseconds)")
        dt_ns = sim.dt_ns
        steps = step_size * NS_PER_S / dt_ns
        if round(steps) < 1 or abs(steps - round(steps)) > STEP_SLACK:
            return self._refuse(f"a communication step of {step_size:.9g} s is not a whole multiple of the scene's "
                                f"base step dt = {exact_seconds(dt_ns)} s (the scene advances in whole base steps)")
        if abs(current_time * NS_PER_S - sim.time_ns) > TIME_SLACK * dt_ns:
            return self._refuse(f"doStep from t = {current_time!r} s, but the scene is at t = "
                                f"{sim.time_ns / NS_PER_S!r} s (a co-simulation steps on from where it is)")
        try:
            _run_to(sim, sim.tick + round(steps))
        except Exception as exc:  # a SimulationError: the scene failed at a time it names
            self.failed = True
            return self._refuse(str(exc))
        self._publish()
        return True

    def terminate(self) -> None:
        """End the simulation: every later doStep is refused, with Discard as any refused doStep, so
        that the instance can still be reset (pythonfmu's reset makes a new instance of this class;
        after Fatal, FMI 2.0 allows no further call)."""
        self.terminated = True

    # --- state (what pythonfmu's getFMUstate / setFMUstate and their serialization carry) ------------

    def _get_fmu_state(self) -> dict[str, Any]:
        """The variables' values and, once initialized, the scene's checkpoint (every component's
        state and port history, bit-exact) with the ports' latest messages the outputs read."""
        state: dict[str, Any] = {"scene": self.scene_digest, "values": dict(self.values)}
        if self.sim is not None:
            try:
                checkpoint = self.sim.checkpoint()
            except Exception as exc:  # a failed scene's FMU that answered Fatal: it is not asked for its state
                self._fail(f"cannot save this state: {exc}")
            state["checkpoint"] = encode_state(checkpoint).decode()
            state["stop_reason"] = self.sim.stop_reason
            state["latest"] = [[c, p, codec_for(type(m)).encode(m).decode()]
                               for (c, p), m in self.latest.messages.items()]
        return state

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        """Restore ``state``, or fail having changed nothing: the state is checked and the scene
        restored first, the variables' values taken only once that worked (a state of another scene
        left this instance with its values and half its scene replaced). A state saved before
        initialization takes the instance back to before it: no scene, initialization to come."""
        try:
            values = state["values"]
            if state.get("scene") != self.scene_digest:
                raise ValueError("it is the state of another exported scene, or of another version of cosim "
                                 "(the scene and export settings it was saved with differ from this FMU's)")
            if set(values) != set(self.values):
                raise ValueError(f"it holds the variables {', '.join(sorted(values))}, this FMU has "
                                 f"{', '.join(sorted(self.values))}")
            if "checkpoint" in state:
                self._restore_scene(state, values)
        except Exception as exc:  # a state from another scene or another version of cosim
            self._fail(f"cannot restore this state: {exc}")
        if "checkpoint" not in state:
            # a state saved before initialization: back to then, with no scene (its outputs of 0 with the
            # scene left at its later time made a doStep from 0 refused and one from that time accepted)
            self.sim = None
            self.failed = False
            self._started = None
            self.latest.messages = {}
        self.values.update(values)

    def _restore_scene(self, state: dict[str, Any], values: dict[str, Any]) -> None:
        """Put the scene back as ``state`` saved it; on failure, back as it was. A scene that failed is
        replaced, not restored into: an FMU inside it that answered Fatal may not be called again (its
        setFMUstate ran the dead model on), and one that answered Error may only be freed."""
        checkpoint, stop_reason = decode_state(state["checkpoint"].encode()), state["stop_reason"]
        if self.sim is None or self.failed:
            # a fresh instance or a failed scene: the scene of the state's parameters, built anew and kept
            # only if restored (the failed one stays, refusing every doStep, if not)
            sim = self._simulation(values)
            latest = self._decode_latest(sim, state["latest"])
            sim.restore(checkpoint)
            self.sim, self.failed = sim, False
        else:
            sim = self.sim
            latest = self._decode_latest(sim, state["latest"])
            before = self._get_fmu_state()  # a copy: restoring writes into the components' arrays
            try:
                sim.restore(checkpoint)
            except Exception:
                try:
                    sim.restore(decode_state(before["checkpoint"].encode()))
                except Exception:  # an FMU inside that failed restoring takes no state back: the scene is lost
                    self.failed = True  # (the reason raised is the first failure's, not this refusal's)
                raise
        sim.stop_reason = stop_reason
        self.latest.messages = latest

    @staticmethod
    def _decode_latest(sim: Simulation, saved: list[list[str]]) -> dict[tuple[str, str], Message]:
        return {(c, p): codec_for(sim.components[c].outputs[p].type).decode(text.encode()) for c, p, text in saved}
