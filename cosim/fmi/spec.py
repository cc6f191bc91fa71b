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
A preset's ``overrides`` given every derived parameter at its start value names every key it may
write: those keys are what the preset derives, and a ``--parameter`` on one of them is refused.

A ``--parameter`` takes its type and unit from what declares the value: a component's parameter
(``cosim.params.param(..., unit=...)``), a component's ``every`` (an integer), the scene's ``dt`` and
``until`` [s]. A value nothing declares (an FMU component's ``start:`` mapping) is an Integer if the
scene writes a whole number, else a Real, and has no unit.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import types
import typing
from dataclasses import asdict, dataclass
from typing import Any

from cosim.errors import ScenarioError
from cosim.messages import FieldKind, fields_of
from cosim.scenario import COMPONENT_KEYS, RecordConfig, Scene, find_parent

PRESETS_GROUP = "cosim.fmi.presets"
# an FMU variable name (structured naming): ASCII letters, digits and _ only (FMI's naming convention;
# \w took "dëns", which FMPy's validation of the model description then refused)
NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}(\.[A-Za-z_][A-Za-z0-9_]{0,63})*")
FMI_INTEGER = (-2**31, 2**31 - 1)  # an FMI 2.0 Integer is a 32-bit int (xs:int)
OUTPUT_RE = re.compile(r"^(\w+)\.(\w+)\.(\w+)(?:\[(\d+)\])?$")  # component.port.field[i]
_NAME_RULE = "of ASCII letters, digits and _, not starting with a digit, parts joined by '.' (FMI's names)"
KINDS = {FieldKind.FLOAT: "real", FieldKind.INT: "integer", FieldKind.ENUM: "integer", FieldKind.BOOL: "boolean"}
SCENE_NUMBERS = {"dt": (float, "s"), "until": (float, "s")}  # the scene's own top-level numbers: type, unit
COMPONENT_NUMBERS = {"every": (int, ""), "step": (float, "s")}  # a component's own keys beside its parameters


@dataclass(frozen=True)
class Parameter:
    """An FMU parameter: ``name``, its ``start`` value and ``unit``; ``key`` the scene value it sets,
    or None for a preset's derived value; ``kind`` real (a Real) or integer (an Integer: the scene
    value is declared an integer, and a whole number is all it takes)."""

    name: str
    start: float
    unit: str = ""
    description: str = ""
    key: str | None = None
    kind: str = "real"


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
    """The scene's value at a ``--set`` key path: as the file writes it, else, for a component's
    parameter the file leaves out, the default the component takes (None if there is neither)."""
    parts = key.split(".")
    node, missing = find_parent(scene.data, parts)
    last = parts[-1]
    if missing is None and isinstance(node, dict) and last in node:
        return node[last]
    if missing is None and isinstance(node, list) and last.isdigit() and int(last) < len(node):
        return node[int(last)]
    return _parameter_value(scene, parts)


def _parameter_value(scene: Scene, parts: list[str]) -> Any:
    """The value at ``parts`` (components.NAME.PARAM[.i ...]) among a component's validated
    parameters, defaults included, or None."""
    cfg = scene.components.get(parts[1]) if len(parts) > 2 and parts[0] == "components" else None
    if cfg is None or parts[2] in COMPONENT_KEYS:
        return None
    value: Any = cfg.params
    for part in parts[2:]:
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            value = getattr(value, part, None)
        elif isinstance(value, (list, tuple)) and part.isdigit() and int(part) < len(value):
            value = value[int(part)]
        else:
            return None
    return value


def _field_type(cls: Any, parts: list[str]) -> tuple[Any, str] | None:
    """The declared type and unit of the value at ``parts`` inside parameter dataclass ``cls`` (an
    element of a vector has the vector's unit), or None where no type is declared (a mapping, Any)."""
    tp, unit = cls, ""
    for part in parts:
        if typing.get_origin(tp) in (typing.Union, types.UnionType):  # X | None: the X
            args = [a for a in typing.get_args(tp) if a is not type(None)]
            tp = args[0] if len(args) == 1 else None
        origin, args = typing.get_origin(tp), typing.get_args(tp)
        if dataclasses.is_dataclass(tp):
            found = {f.name: f for f in dataclasses.fields(tp)}.get(part)
            if found is None:
                return None
            unit = found.metadata.get("unit", "") or unit
            tp = typing.get_type_hints(tp)[part]
        elif part.isdigit() and origin is list and args:
            tp = args[0]
        elif part.isdigit() and origin is tuple and args:
            tp = args[0] if args[-1] is Ellipsis else args[int(part)] if int(part) < len(args) else None
        else:
            return None
    return tp, unit


def declared(scene: Scene, key: str) -> tuple[Any, str] | None:
    """The type (int or float) and unit the scene's format declares for the value at ``key``, or
    None where it declares none."""
    parts = key.split(".")
    if len(parts) == 1:
        return SCENE_NUMBERS.get(key)
    if parts[0] == "record" and len(parts) == 2:
        hint = typing.get_type_hints(RecordConfig).get(parts[1])
        return (hint, "s" if parts[1] == "checkpoint_every" else "") if hint in (int, float) else None
    cfg = scene.components.get(parts[1]) if parts[0] == "components" and len(parts) > 2 else None
    if cfg is None:
        return None
    if parts[2] in COMPONENT_KEYS:
        return COMPONENT_NUMBERS.get(parts[2]) if len(parts) == 3 else None
    params = getattr(cfg.cls, "Params", None)
    found = _field_type(params, parts[2:]) if params is not None else None
    return found if found is not None and found[0] in (int, float) else None


def parse_parameter(text: str, scene: Scene) -> Parameter:
    """``NAME=KEY.PATH`` (``--parameter``): a number of the scene as an FMU parameter, an Integer
    where the value is declared an integer, with the unit declared for it (see :func:`declared`)."""
    name, sep, key = text.partition("=")
    key = key.strip()
    value = scene_value(scene, key) if sep else None
    if not sep or not NAME_RE.fullmatch(name.strip()):
        raise ScenarioError(f"--parameter {text!r}: expected NAME=key.path (e.g. density=components.stone.density), "
                            f"NAME {_NAME_RULE}", scene.source)
    if value is None:
        raise ScenarioError(f"--parameter {text!r}: the scene has no value at {key!r}{_near(scene, key)}; "
                            "a parameter sets one number of the scene", scene.source)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ScenarioError(f"--parameter {text!r}: the scene has no number at {key!r} (got {value!r}); "
                            "a parameter sets one number of the scene", scene.source)
    kind, unit = declared(scene, key) or (type(value), "")
    # a float parameter the scene writes as 2650 is still a Real; an integer one (a grid's nx)
    # takes only whole numbers, and an override of 900.0 was refused when the scene loaded
    if kind is int:
        if not FMI_INTEGER[0] <= value <= FMI_INTEGER[1]:
            raise ScenarioError(f"--parameter {text!r}: the scene's {key} is {int(value)}, outside an FMI 2.0 "
                                f"Integer's range {FMI_INTEGER[0]} to {FMI_INTEGER[1]} (a 32-bit int)", scene.source)
        return Parameter(name.strip(), int(value), key=key, description=f"the scene's {key}", kind="integer")
    return Parameter(name.strip(), float(value), unit, description=f"the scene's {key}", key=key)


def _near(scene: Scene, key: str) -> str:
    """ " (did you mean 'NAME'?)" for a component parameter misspelled in ``key``, else ""."""
    import difflib

    parts = key.split(".")
    cfg = scene.components.get(parts[1]) if len(parts) > 2 and parts[0] == "components" else None
    if cfg is None or not dataclasses.is_dataclass(cfg.params):
        return ""
    names = [f.name for f in dataclasses.fields(cfg.params)]
    close = difflib.get_close_matches(parts[2], names, n=1)
    return f" (did you mean {'.'.join([*parts[:2], close[0]])!r}?)" if close and close[0] != parts[2] else ""


def _overlap(a: str, b: str) -> bool:
    """Whether keys ``a`` and ``b`` name the same value or one holds the other."""
    return a == b or a.startswith(b + ".") or b.startswith(a + ".")


def check_parameter_keys(parameters: list[Parameter], named: list[Parameter], preset: str | None,
                         derives: list[str], source: str) -> None:
    """Refuse a ``--parameter`` (one of ``named``) whose key a preset's derived parameters write
    (``derives``: their keys), or another parameter sets too: only one of them would take effect,
    the other silently dropped (a vx0 with a changed speed gave the speed's vx)."""
    derived = ", ".join(p.name for p in parameters if p.key is None)
    for p in named:
        key = p.key or ""
        for written in derives:
            if _overlap(key, written):
                raise ScenarioError(f"--parameter {p.name}={key}: the preset {preset!r} sets {written} from its "
                                    f"parameters {derived}, which would replace this value; use --preset none to "
                                    "set it with --parameter", source)
        for other in parameters:
            if other is not p and other.key is not None and _overlap(key, other.key):
                raise ScenarioError(f"--parameter {p.name}={key}: parameter {other.name!r} already sets "
                                    f"{other.key}; a scene value takes one parameter", source)


def parse_output(text: str, scene: Scene) -> Output:
    """``NAME=COMPONENT.PORT.FIELD[i]`` (``--output-var``): a field of a port as an FMU output."""
    name, sep, where = text.partition("=")
    match = OUTPUT_RE.match(where.strip()) if sep else None
    if not match or not NAME_RE.fullmatch(name.strip()):
        raise ScenarioError(f"--output-var {text!r}: expected NAME=component.port.field or "
                            f"NAME=component.port.field[i] (e.g. z=stone.state.position[2]), NAME {_NAME_RULE}",
                            scene.source)
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
