"""FMU: a co-simulation FMU (FMI 2.0 or 3.0) as a component, through FMPy.

::

    gust:
      type: FMU
      path: fmus/wind_gust.fmu        # relative to the scene; or model: a pythonfmu .py, built and cached
      every: 2                        # doStep every 2 base steps
      start: {peak_speed: 6.0}        # parameters and start values, by variable name
      inputs:  {body: {type: BodyState, fields: {"velocity[0]": vx, "velocity[2]": vz}}}
      outputs: {wrench: {type: Wrench, fields: {"force[0]": Fx, "force[2]": Fz}}}

The mapping (:mod:`components.fmu.mapping`) is checked against the model description when the scene
loads, so an unknown variable or a wrong causality or type is bad input (exit 2) naming the FMU, the
variable and the YAML path. Each step sets the inputs, calls ``doStep(t, dt)`` and reads the
outputs; an FMU answering Discard, Error or Fatal fails the run with a SimulationError naming the
FMU, the time and the FMU's own log. Its state goes into checkpoints through the FMU's own state
serialization when the FMU declares ``canGetAndSetFMUstate`` and ``canSerializeFMUstate``; restoring
one that does not is refused with that reason.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from components.fmu.instance import FmuCallError, FmuInstance
from components.fmu.mapping import PortMap, build_message, parse_ports, parse_start, read_message
from cosim.component import Component, Port
from cosim.errors import SimulationError, counted, shortened
from cosim.messages import Message
from cosim.params import param
from cosim.timebase import NS_PER_S


@dataclass(frozen=True)
class FMUParams:
    """Parameters of an FMU component (see the module's text)."""

    path: str | None = param(None, doc="the .fmu file, relative to the scene's folder")
    model: str | None = param(None, doc="a pythonfmu model (.py, relative to the scene), built into an FMU "
                                        "on first use and cached")
    start: Any = param({}, doc="FMU variable -> value, for parameters and inputs")
    inputs: Any = param({}, doc="port -> {type: message type, fields: {field: FMU input variable}}")
    outputs: Any = param({}, doc="port -> {type: message type, fields: {field: FMU output variable}}, "
                                 "or port -> variable (a Number)")

    def check(self) -> list[tuple[str, str]]:
        if (self.path is None) == (self.model is None):
            return [("path", "give either path (an .fmu file) or model (a pythonfmu .py file), one of them")]
        return []


def _fmu_file(params: FMUParams, path: str, base_dir: Path, problems: list[str]) -> Path | None:
    """The FMU file the parameters name: ``path`` as it is, or ``model`` built (from the cache)."""
    key, given = ("path", params.path) if params.path is not None else ("model", params.model)
    file = base_dir / str(given)
    try:
        is_file, exists = file.is_file(), file.exists()
    except OSError as exc:  # a name too long for the file system: said on its key, shortened
        shown = shortened(str(given), 60)
        problems.append(f"{path}.{key}: cannot be looked up: {exc.strerror or exc} ({len(str(given))} characters: "
                        f"{shown!r})")
        return None
    if not is_file:  # (a folder, a device or a pipe is there, but is no file to read)
        what = "not a file" if exists else "no such file"
        problems.append(f"{path}.{key}: {what} {given!r} (looked in {base_dir})")
        return None
    if key == "path":
        return file
    if file.suffix != ".py":
        problems.append(f"{path}.model: must be a pythonfmu model, a .py file (got {given!r})")
        return None
    from cosim.fmi.build import FmuBuildError, cached_fmu

    try:
        return cached_fmu(file)
    except FmuBuildError as exc:
        problems.append(f"{path}.model: {exc}")
        return None


def _describe(file: Path, label: str, path: str, problems: list[str]) -> Any:
    """FMPy's model description of ``file``, if it is a co-simulation FMU of FMI 2.0 or 3.0."""
    from fmpy import read_model_description

    try:
        md = read_model_description(str(file))
    except Exception as exc:  # not a zip, no modelDescription.xml, invalid XML: all bad input
        # FMPy's validation lists its findings on lines of their own: one line here
        said = " ".join(line.strip() for line in str(exc).splitlines() if line.strip())
        problems.append(f"{path}: cannot read FMU {label}: {type(exc).__name__}: {said}")
        return None
    if md.coSimulation is None:
        problems.append(f"{path}: FMU {label} has no co-simulation interface (model exchange only)")
        return None
    if not (md.fmiVersion.startswith("2.") or md.fmiVersion.startswith("3.")):
        problems.append(f"{path}: FMU {label} is FMI {md.fmiVersion}; FMI 2.0 and 3.0 are supported")
        return None
    return md


class FMU(Component):
    """A co-simulation FMU; the scene's ``inputs`` and ``outputs`` become its ports."""

    Params = FMUParams
    inputs: ClassVar[dict[str, Port]] = {}
    outputs: ClassVar[dict[str, Port]] = {}
    # the start values are set once, as the FMU is instantiated: a restart restores the FMU's own
    # serialized state, every variable with it, so a changed start value would do nothing there
    start_only_params: ClassVar[frozenset[str]] = frozenset({"start"})
    # set on the class configure() makes for one scene's component
    fmu_file: ClassVar[Path | None] = None
    label: ClassVar[str] = ""
    description: ClassVar[Any] = None
    variables: ClassVar[dict[str, Any]] = {}
    start_values: ClassVar[dict[str, Any]] = {}
    input_maps: ClassVar[tuple[PortMap, ...]] = ()
    output_maps: ClassVar[tuple[PortMap, ...]] = ()

    @classmethod
    def configure(cls, params: Any, path: str, base_dir: Path, problems: list[str]) -> type[Component] | None:
        if params is None or (params.path is None) == (params.model is None):
            return None  # (neither or both given: FMUParams.check says so)
        try:
            import fmpy  # noqa: F401
        except ImportError:
            problems.append(f"{path}.type: FMU needs fmpy, which is not installed: pip install 'cosim[fmi]'")
            return None
        file = _fmu_file(params, path, base_dir, problems)
        if file is None:
            return None
        label = repr(Path(params.path or params.model or file).name)
        md = _describe(file, label, path, problems)
        if md is None:
            return None
        variables = {v.name: v for v in md.modelVariables}
        before = len(problems)
        start = parse_start(params.start, label, variables, path, problems, md.fmiVersion)
        ins = parse_ports(params.inputs, "inputs", label, variables, path, problems)
        outs = parse_ports(params.outputs, "outputs", label, variables, path, problems)
        if len(problems) > before:
            return None
        return type("FMU", (cls,), {
            "__module__": cls.__module__, "__doc__": cls.__doc__,
            "fmu_file": file, "label": label, "description": md, "variables": variables,
            "start_values": start, "input_maps": tuple(ins), "output_maps": tuple(outs),
            "inputs": {m.port: Port(m.type, f"to FMU {label}: {_vars(m)}") for m in ins},
            "outputs": {m.port: Port(m.type, f"from FMU {label}: {_vars(m)}") for m in outs},
        })

    def setup(self) -> None:
        self._failed_do_step = False  # whether the last doStep failed
        # the doStep calls made, as step_count counts them (one whose outputs the run then refused, a
        # NaN, counts: the summary said "0 doStep calls" of an FMU that had made one)
        self._calls_made = 0
        self._at_ns = 0  # the time the FMU was last stepped to or from [ns]: where a failure to save its state is said
        if self.fmu_file is None:
            raise TypeError("an FMU component is built from a scene (its ports come from the scene's mapping)")
        try:
            self.fmu = FmuInstance(self.fmu_file, self.description, self.name, self.start_values, self.variables)
        except FmuCallError as exc:
            raise SimulationError(self.name, 0, f"FMU {self.label}: {exc}") from None
        weakref.finalize(self, self.fmu.close)

    # --- stepping ------------------------------------------------------------------------------

    def _outputs(self) -> dict[str, Message]:
        out = {}
        for port in self.output_maps:
            values: list[Any] = [None] * len(port.bindings)
            for fmu_type, positions in _by_type(port).items():
                got = self.fmu.get(fmu_type, [port.bindings[i].value_reference for i in positions])
                for i, value in zip(positions, got, strict=True):
                    values[i] = value
            try:
                out[port.port] = build_message(port, values)
            except ValueError as exc:  # a value its field cannot hold (an enum's number out of its range)
                raise ValueError(f"FMU {self.label}: {exc}") from None
        return out

    def initial_outputs(self) -> dict[str, Message]:
        return self._outputs()

    def _step_impl(self, t: float, dt: float, inputs: dict[str, Message | None]) -> dict[str, Message]:
        try:
            for port in self.input_maps:
                msg = inputs.get(port.port)
                if msg is None:  # nothing received yet: the FMU keeps its start value
                    continue
                values = read_message(port, msg)
                for fmu_type, positions in _by_type(port).items():
                    self.fmu.set(fmu_type, [port.bindings[i].value_reference for i in positions],
                                 [values[i] for i in positions])
            self._calls_made = self.step_count + 1
            self._at_ns = round(t * NS_PER_S)
            try:
                self.fmu.do_step(t, dt)
            except FmuCallError:
                self._failed_do_step = True
                raise
            self._at_ns = round((t + dt) * NS_PER_S)
            return self._outputs()
        except FmuCallError as exc:
            raise SimulationError(self.name, round(t * NS_PER_S),
                                  f"FMU {self.label} {exc} (step from t = {t:.9g} s by {dt:.6g} s)") from None

    # --- state ---------------------------------------------------------------------------------

    def get_state(self) -> dict[str, Any]:
        if not self.fmu.can_save:
            return {"fmu_state": None}  # a checkpoint without it: restoring it is refused (set_state)
        try:
            data = self.fmu.save()
        except FmuCallError as exc:
            # (at the time it was stepped to: one whose doStep failed at 0.062 s was said to fail at 0)
            raise SimulationError(self.name, self._at_ns, f"FMU {self.label}: cannot save its state: {exc}") from None
        return {"fmu_state": np.frombuffer(data, dtype=np.uint8).copy()}

    def set_state(self, state: dict[str, Any]) -> None:
        data = state.get("fmu_state")
        if data is None:
            cs = self.description.coSimulation
            raise ValueError(f"FMU {self.label} cannot save and restore its state (canGetAndSetFMUstate "
                             f"{str(cs.canGetAndSetFMUstate).lower()}, canSerializeFMUstate "
                             f"{str(cs.canSerializeFMUstate).lower()}): a run with it restarts only from t = 0")
        try:
            self.fmu.restore(np.asarray(data, dtype=np.uint8).tobytes())
        except FmuCallError as exc:
            raise ValueError(f"FMU {self.label}: cannot restore its state: {exc}") from None

    def summary(self) -> list[str]:
        calls = counted(max(self.step_count, self._calls_made), "doStep call")
        failed = " (the last one failed)" if self._failed_do_step else ""
        return [f"{self.name}: FMU {self.label} (FMI {self.description.fmiVersion}), {calls}{failed}"]


def _vars(port: PortMap) -> str:
    return ", ".join(f"{b.field}{'' if b.index is None else f'[{b.index}]'} = {b.variable}" for b in port.bindings)


def _by_type(port: PortMap) -> dict[str, list[int]]:
    """The port's binding positions grouped by FMU value type: one get/set call per type."""
    groups: dict[str, list[int]] = {}
    for i, binding in enumerate(port.bindings):
        groups.setdefault(binding.fmu_type, []).append(i)
    return groups
