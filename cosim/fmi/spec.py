"""What an exported scene shows as an FMU: its parameters (scene values) and outputs (port fields).

A parameter either sets one scene value (``key``: a ``--set`` path such as
``components.stone.density`` or ``components.stone.position.2``) or is one of a preset's derived
values (``key`` None: the preset turns it into scene values, e.g. a throw's speed and angle into the
stone's velocity). A parameter left at its start value changes nothing in the scene, so the FMU at
its defaults runs the scene exactly as written.

Defaults come from presets, registered under the ``cosim.fmi.presets`` entry points: a preset is a
module or object with ``parameters(scene) -> list[Parameter]``, ``outputs(scene) -> list[Output]``
(empty when the scene has nothing it knows) and ``overrides(scene, values) -> list[str]`` for its
derived parameters. The framework knows no preset by name; ``components`` registers ``throw``.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import asdict, dataclass
from typing import Any

from cosim.errors import ScenarioError
from cosim.messages import FieldKind, fields_of
from cosim.scenario import Scene, find_parent

PRESETS_GROUP = "cosim.fmi.presets"
NAME_RE = re.compile(r"[A-Za-z_]\w{0,63}(\.[A-Za-z_]\w{0,63})*")  # an FMU variable name (structured naming)
OUTPUT_RE = re.compile(r"^(\w+)\.(\w+)\.(\w+)(?:\[(\d+)\])?$")  # component.port.field[i]
KINDS = {FieldKind.FLOAT: "real", FieldKind.INT: "integer", FieldKind.ENUM: "integer", FieldKind.BOOL: "boolean"}


@dataclass(frozen=True)
class Parameter:
    """An FMU parameter (Real): ``name``, its ``start`` value and ``unit``; ``key`` the scene value
    it sets, or None for a preset's derived value."""

    name: str
    start: float
    unit: str = ""
    description: str = ""
    key: str | None = None


@dataclass(frozen=True)
class Output:
    """An FMU output: field ``field`` (element ``index`` of an array) of the messages published on
    ``component.port``; ``kind`` real, integer or boolean."""

    name: str
    component: str
    port: str
    field: str
    index: int | None = None
    kind: str = "real"
    unit: str = ""
    description: str = ""


@dataclass(frozen=True)
class ExportSpec:
    """The parameters and outputs of an exported scene; ``preset`` names the preset whose derived
    parameters it holds (None: only scene values)."""

    parameters: tuple[Parameter, ...] = ()
    outputs: tuple[Output, ...] = ()
    preset: str | None = None
    step_ns: int = 0  # the default communication step [ns]
    base_dir: str = "."  # where the scene's relative file names start
    overrides: tuple[str, ...] = ()  # the export's own --set, applied before the parameters
    dt_ns: int = 0  # the scene's base step [ns]: the default communication step without --step
    until_ns: int = 0  # the scene's end [ns]: the default experiment's stop time

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=1)

    @staticmethod
    def from_json(text: str) -> ExportSpec:
        data = json.loads(text)
        return ExportSpec(parameters=tuple(Parameter(**p) for p in data["parameters"]),
                          outputs=tuple(Output(**o) for o in data["outputs"]), preset=data["preset"],
                          step_ns=data["step_ns"], base_dir=data["base_dir"],
                          overrides=tuple(data.get("overrides", ())), dt_ns=int(data.get("dt_ns", 0)),
                          until_ns=int(data.get("until_ns", 0)))


def load_preset(name: str) -> Any:
    """The preset registered as ``name`` (a ScenarioError listing the known ones if there is none)."""
    from importlib.metadata import entry_points

    found = {ep.name: ep for ep in entry_points(group=PRESETS_GROUP)}
    if name not in found:
        raise ScenarioError(f"--preset: no preset {name!r} (known: {', '.join(sorted(found)) or 'none'}; "
                            "or 'none')", "cosim fmu export")
    return found[name].load()


def scene_value(scene: Scene, key: str) -> Any:
    """The scene's value at a ``--set`` key path (None if there is none)."""
    parts = key.split(".")
    node, missing = find_parent(scene.data, parts)
    if missing is not None:
        return None
    last = parts[-1]
    if isinstance(node, dict):
        return node.get(last)
    if isinstance(node, list) and last.isdigit() and int(last) < len(node):
        return node[int(last)]
    return None


def parse_parameter(text: str, scene: Scene) -> Parameter:
    """``NAME=KEY.PATH`` (``--parameter``): a number of the scene as an FMU parameter."""
    name, sep, key = text.partition("=")
    value = scene_value(scene, key.strip()) if sep else None
    if not sep or not NAME_RE.fullmatch(name.strip()):
        raise ScenarioError(f"--parameter {text!r}: expected NAME=key.path (e.g. density=components.stone.density)",
                            scene.source)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ScenarioError(f"--parameter {text!r}: the scene has no number at {key.strip()!r} (got {value!r}); "
                            "a parameter sets one number of the scene", scene.source)
    return Parameter(name.strip(), float(value), key=key.strip(), description=f"the scene's {key.strip()}")


def parse_output(text: str, scene: Scene) -> Output:
    """``NAME=COMPONENT.PORT.FIELD[i]`` (``--output-var``): a field of a port as an FMU output."""
    name, sep, where = text.partition("=")
    match = OUTPUT_RE.match(where.strip()) if sep else None
    if not match or not NAME_RE.fullmatch(name.strip()):
        raise ScenarioError(f"--output-var {text!r}: expected NAME=component.port.field or "
                            "NAME=component.port.field[i] (e.g. z=stone.state.position[2])", scene.source)
    component, port, field_name, index = match.groups()
    return check_output(Output(name.strip(), component, port, field_name, int(index) if index else None), scene)


def check_output(out: Output, scene: Scene) -> Output:
    """``out`` with its kind, once its component, port and field are found in ``scene``."""
    where = f"{out.component}.{out.port}.{out.field}" + ("" if out.index is None else f"[{out.index}]")
    cfg = scene.components.get(out.component)
    if cfg is None:
        raise ScenarioError(f"output {out.name!r}: no component {out.component!r} "
                            f"(components: {', '.join(scene.order)})", scene.source)
    port = cfg.cls.outputs.get(out.port)
    if port is None:
        raise ScenarioError(f"output {out.name!r}: {out.component} has no output port {out.port!r} "
                            f"(outputs: {', '.join(cfg.cls.outputs) or 'none'})", scene.source)
    specs = {s.name: s for s in fields_of(port.type)}
    spec = specs.get(out.field)
    if spec is None:
        raise ScenarioError(f"output {out.name!r}: {port.type.__name__} has no field {out.field!r} "
                            f"(fields: {', '.join(specs)})", scene.source)
    if spec.kind is FieldKind.ARRAY and spec.array is not None:
        size = spec.array.fixed_size
        if len(spec.array.shape) != 1 or size is None or out.index is None or not 0 <= out.index < size:
            raise ScenarioError(f"output {out.name!r}: {where} must name one element of the fixed-size vector "
                                f"{out.field} ({out.field}[i], i < {size})", scene.source)
        kind = "real" if spec.array.dtype.startswith("float") else "integer"
    elif spec.kind in KINDS and out.index is None:
        kind = KINDS[spec.kind]
    else:
        raise ScenarioError(f"output {out.name!r}: {where} is not a number, a boolean or a vector element",
                            scene.source)
    return Output(out.name, out.component, out.port, out.field, out.index, kind, out.unit,
                  out.description or f"{where}")


def check_step(step_ns: int, scene: Scene, what: str = "--step", given: float | None = None) -> None:
    """A communication step must be a whole number of the scene's base steps (``given``: the step as
    the user wrote it [s], named in the error rather than its rounding to whole nanoseconds)."""
    if step_ns <= 0 or step_ns % scene.dt_ns:
        said = step_ns / 1e9 if given is None else given
        raise ScenarioError(f"{what}: a communication step of {said:g} s is not a whole multiple of the "
                            f"scene's base step dt = {scene.dt_ns / 1e9:g} s (the scene advances in whole base "
                            "steps; use a multiple of dt)", scene.source)


def unique(spec: ExportSpec, source: str) -> ExportSpec:
    """``spec`` if no two of its variables share a name."""
    names = [p.name for p in spec.parameters] + [o.name for o in spec.outputs]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ScenarioError(f"FMU variables named twice: {', '.join(twice)} (every parameter and output needs "
                            "its own name)", source)
    return spec
