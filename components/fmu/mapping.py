"""FMU variables mapped onto typed ports, checked against the model description.

A port is one message type; each of its numeric fields (or one element of a fixed-size array field)
is tied to one FMU variable::

    outputs:
      wrench: {type: Wrench, fields: {"force[0]": Fx, "force[2]": Fz}}   # Wrench.force x, z <- Fx, Fz
      thrust: F                                                           # shorthand: Number.value <- F
    inputs:
      body: {type: BodyState, fields: {"velocity[0]": vx}}              # vx <- BodyState.velocity[0]

An output field left unmapped is zero (an additive Wrench then adds nothing there); an input message
field left unmapped is not sent. Kinds must agree: a float field (or float array element) with a
real variable (FMI 2.0 Real, FMI 3.0 Float64/Float32), an int or enum field with an integer one,
a bool field with a Boolean; inputs need causality ``input``, outputs ``output``.
"""

from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from cosim.examples import Number
from cosim.messages import FieldKind, FieldSpec, Message, fields_of
from cosim.params import UNQUOTED_NAMES, as_written, unquoted_hint

FIELD_RE = re.compile(r"^([A-Za-z_]\w*)(?:\[(\d+)\])?$")  # "speed" or "force[0]"
PORT_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}")  # a port name becomes a channel name
REAL_TYPES = {"Real", "Float64", "Float32"}
INTEGER_TYPES = {"Integer", "Enumeration", "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64"}
KIND_OF_TYPE = {**dict.fromkeys(REAL_TYPES, "real"), **dict.fromkeys(INTEGER_TYPES, "integer"),
                "Boolean": "boolean", "String": "string"}
START_CAUSALITIES = ("parameter", "structuralParameter", "input")
# each integer type's width in bits and whether it is signed: FMI 2.0's Integer is a C int, 32-bit
# signed (a start value beyond it was wrapped around, 10000000000 set as 1410065408); an Enumeration
# is FMI 2.0's Integer, FMI 3.0's Int64 (see integer_width)
INTEGER_WIDTHS = {"Integer": (32, True), "Int8": (8, True), "UInt8": (8, False), "Int16": (16, True),
                  "UInt16": (16, False), "Int32": (32, True), "UInt32": (32, False), "Int64": (64, True),
                  "UInt64": (64, False)}


def message_types() -> dict[str, type[Message]]:
    """The message types a port may carry, by class name: the physics messages and ``Number``."""
    from components import messages

    found = {name: obj for name, obj in vars(messages).items()
             if isinstance(obj, type) and issubclass(obj, Message) and obj is not Message}
    return {**found, "Number": Number}


@dataclass(frozen=True)
class Binding:
    """One message field (``index``: the array element, or None) tied to one FMU variable."""

    field: str
    index: int | None
    variable: str
    value_reference: int
    fmu_type: str  # the model description's type name: Real, Float64, Integer, Int32, Boolean...


@dataclass(frozen=True)
class PortMap:
    """A port: its message type and the bindings of its fields."""

    port: str
    type: type[Message]
    bindings: tuple[Binding, ...]


def _close(name: str, choices: list[str]) -> str:
    match = difflib.get_close_matches(name, choices, n=1)
    if match:
        return f"did you mean {match[0]!r}?"
    shown = ", ".join(choices[:12]) + (", ..." if len(choices) > 12 else "")
    return f"known: {shown or 'none'}"


def field_kind(spec: FieldSpec) -> str | None:
    """The FMU value kind a message field (or an element of it) takes: real, integer, boolean, or
    None for a field no FMU variable can fill (a string, a free-shape array)."""
    if spec.kind is FieldKind.FLOAT:
        return "real"
    if spec.kind in (FieldKind.INT, FieldKind.ENUM):
        return "integer"
    if spec.kind is FieldKind.BOOL:
        return "boolean"
    if spec.kind is FieldKind.ARRAY and spec.array is not None and len(spec.array.shape) == 1:
        kind = np.dtype(spec.array.dtype).kind
        return "real" if kind == "f" else "integer" if kind in "iu" else "boolean" if kind == "b" else None
    return None


def parse_ports(data: Any, side: str, label: str, variables: dict[str, Any], path: str,
                problems: list[str]) -> list[PortMap]:
    """The ``inputs`` or ``outputs`` mapping (``side``) checked against the FMU's ``variables``
    (name -> FMPy ScalarVariable); problems name the YAML path, the FMU (``label``) and the variable."""
    where = f"{path}.{side}"
    if not isinstance(data, dict):
        problems.append(f"{where}: must be a mapping of port -> {{type, fields}} (got {data!r})")
        return []
    types = message_types()
    causality = "input" if side == "inputs" else "output"
    ports = []
    for port, spec in data.items():
        at = f"{where}.{port}"
        if not isinstance(port, str) or not PORT_RE.fullmatch(port):
            problems.append(f"{where}: port names must be identifiers (they become channel names; got "
                            f"{as_written(port)}){unquoted_hint(port)}")
            continue
        if isinstance(spec, str):  # shorthand: a scalar port
            spec = {"type": "Number", "fields": {"value": spec}}
        if not isinstance(spec, dict) or set(spec) - {"type", "fields"} or "type" not in spec:
            problems.append(f"{at}: must be a variable name, or a mapping with 'type' (a message type) and "
                            f"'fields' (message field -> FMU variable) (got {as_written(spec)})"
                            f"{unquoted_hint(spec) if not isinstance(spec, dict | list) else ''}")
            continue
        msg_type = types.get(spec["type"]) if isinstance(spec["type"], str) else None
        if msg_type is None:
            hint = _close(str(spec["type"]), sorted(types))
            problems.append(f"{at}.type: unknown message type {spec['type']!r} ({hint})")
            continue
        fields = spec.get("fields", {})
        if not isinstance(fields, dict) or not fields:
            problems.append(f"{at}.fields: must be a non-empty mapping of message field -> FMU variable "
                            f"(got {fields!r})")
            continue
        bindings = [b for item in fields.items()
                    if (b := _binding(item, msg_type, causality, label, variables, f"{at}.fields", problems))]
        if len(bindings) == len(fields):
            ports.append(PortMap(port, msg_type, tuple(bindings)))
    return ports


def _binding(item: tuple[Any, Any], msg_type: type[Message], causality: str, label: str,
             variables: dict[str, Any], at: str, problems: list[str]) -> Binding | None:
    key, name = item
    if not isinstance(key, str):
        problems.append(f"{at}: a field is named {as_written(key)}, not a name: {UNQUOTED_NAMES}")
        return None
    specs = {s.name: s for s in fields_of(msg_type)}
    match = FIELD_RE.match(key)
    if not match or match.group(1) not in specs:
        problems.append(f"{at}.{key}: {msg_type.__name__} has no field {key!r} "
                        f"(fields: {', '.join(specs)}; an array element as 'name[i]')")
        return None
    spec, index = specs[match.group(1)], match.group(2)
    is_array = spec.kind is FieldKind.ARRAY
    size = spec.array.fixed_size if is_array and spec.array is not None else None
    if is_array and (index is None or size is None or int(index) >= size):
        problems.append(f"{at}.{key}: {msg_type.__name__}.{spec.name} is an array: map one element, "
                        f"'{spec.name}[i]' with i < {size if size is not None else 'its fixed size'}")
        return None
    if not is_array and index is not None:
        problems.append(f"{at}.{key}: {msg_type.__name__}.{spec.name} is not an array (map it as {spec.name!r})")
        return None
    kind = field_kind(spec)
    if kind is None:
        problems.append(f"{at}.{key}: {msg_type.__name__}.{spec.name} cannot be tied to an FMU variable "
                        "(only numbers, booleans and fixed-size vectors)")
        return None
    if not isinstance(name, str) or name not in variables:
        names = sorted(n for n, v in variables.items() if v.causality == causality)
        problems.append(f"{at}.{key}: FMU {label} has no variable {as_written(name)} "
                        f"({causality}s: {', '.join(names) or 'none'}){unquoted_hint(name)}")
        return None
    var = variables[name]
    if var.causality != causality:
        problems.append(f"{at}.{key}: variable {name!r} of FMU {label} has causality {var.causality!r}; "
                        f"a port's {causality} must be an {causality} variable")
        return None
    if getattr(var, "dimensions", None):
        problems.append(f"{at}.{key}: variable {name!r} of FMU {label} is an array; map scalar variables")
        return None
    fmu_kind = KIND_OF_TYPE.get(var.type)
    if fmu_kind != kind:
        problems.append(f"{at}.{key}: variable {name!r} of FMU {label} is {var.type}, but "
                        f"{msg_type.__name__}.{spec.name} takes a {kind} value")
        return None
    return Binding(spec.name, int(index) if index is not None else None, name, var.valueReference, var.type)


def integer_width(fmu_type: str, fmi_version: str) -> tuple[int, bool]:
    """The width in bits of the integer type ``fmu_type`` of an FMU of FMI ``fmi_version``, and
    whether it is signed."""
    if fmu_type == "Enumeration":
        return (64, True) if fmi_version.startswith("3") else (32, True)
    return INTEGER_WIDTHS[fmu_type]


def _declared(var: Any, bound: str) -> tuple[str, float] | None:
    """The variable's ``min`` or ``max`` (``bound``) as the model description writes it and as a
    number, the variable's own else its declared type's, as FMI reads them; None where there is
    none (or none that reads as a number: FMPy's validation of the model description names that)."""
    text = getattr(var, bound, None)
    if text is None and getattr(var, "declaredType", None) is not None:
        text = getattr(var.declaredType, bound, None)
    if text is None:
        return None
    try:
        return text, int(text)  # an integer's bound as written: a float would round one above 2**53
    except ValueError:
        try:
            return text, float(text)
        except ValueError:
            return None


def _out_of_bounds(value: Any, var: Any, kind: str, fmi_version: str, label: str) -> str | None:
    """Why the number ``value`` cannot be the start of ``var`` (its type's range, its min and max),
    or None if it can."""
    name = var.name
    if kind == "integer":
        bits, signed = integer_width(var.type, fmi_version)
        low, high = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if signed else (0, 2**bits - 1)
        if not low <= value <= high:
            sign = "signed" if signed else "unsigned"
            return (f"variable {name!r} of FMU {label} is {var.type}, a {bits}-bit {sign} integer, from {low} to "
                    f"{high}; got {value!r}")
    lowest, highest = _declared(var, "min"), _declared(var, "max")
    if lowest is not None and value < lowest[1]:
        return f"must be at least {lowest[0]}, the min of variable {name!r} of FMU {label} (got {value!r})"
    if highest is not None and value > highest[1]:
        return f"must be at most {highest[0]}, the max of variable {name!r} of FMU {label} (got {value!r})"
    return None


def parse_start(data: Any, label: str, variables: dict[str, Any], path: str, problems: list[str],
                fmi_version: str = "2.0") -> dict[str, Any]:
    """The ``start`` mapping (variable -> value) for parameters and inputs, values checked against
    each variable's type (an integer within its type's range) and its min and max where the model
    description gives them; returns name -> value."""
    at = f"{path}.start"
    if not isinstance(data, dict):
        problems.append(f"{at}: must be a mapping of FMU variable -> value (got {data!r})")
        return {}
    out = {}
    for name, value in data.items():
        var = variables.get(name) if isinstance(name, str) else None
        if var is None:
            settable = sorted(n for n, v in variables.items() if v.causality in START_CAUSALITIES)
            if not isinstance(name, str):
                problems.append(f"{at}: a variable is named {as_written(name)}, not a name: {UNQUOTED_NAMES}")
                continue
            problems.append(f"{at}.{name}: FMU {label} has no variable {name!r} ({_close(name, settable)})")
            continue
        if var.causality not in START_CAUSALITIES or var.variability == "constant":
            problems.append(f"{at}.{name}: variable {name!r} of FMU {label} is a {var.variability} "
                            f"{var.causality}; start values go to parameters and inputs")
            continue
        kind = KIND_OF_TYPE.get(var.type)
        ok = {"real": isinstance(value, (int, float)) and not isinstance(value, bool),
              "integer": isinstance(value, int) and not isinstance(value, bool),
              "boolean": isinstance(value, bool), "string": isinstance(value, str)}.get(kind or "", False)
        if not ok:
            problems.append(f"{at}.{name}: variable {name!r} of FMU {label} is {var.type}; got {value!r}")
            continue
        if kind == "real" and not math.isfinite(float(value)):  # it would reach the outputs at the first step
            problems.append(f"{at}.{name}: must be finite (got {value!r})")
            continue
        if kind in ("real", "integer") and (why := _out_of_bounds(value, var, kind, fmi_version, label)):
            problems.append(f"{at}.{name}: {why}")
            continue
        out[name] = float(value) if kind == "real" else value
    return out


def zero_fields(msg_type: type[Message]) -> dict[str, Any]:
    """Every field of ``msg_type`` at zero (0.0, 0, False, "", the enum's first member, zero arrays
    of the declared shape, a free dimension empty): what an output field no variable fills holds."""
    values: dict[str, Any] = {}
    for spec in fields_of(msg_type):
        if spec.kind is FieldKind.ARRAY and spec.array is not None:
            values[spec.name] = np.zeros(tuple(d or 0 for d in spec.array.shape), dtype=spec.array.dtype)
        elif spec.kind is FieldKind.ENUM and spec.enum_type is not None:
            values[spec.name] = next(iter(spec.enum_type))
        else:
            values[spec.name] = {FieldKind.FLOAT: 0.0, FieldKind.INT: 0, FieldKind.BOOL: False,
                                 FieldKind.STR: ""}[spec.kind]
    return values


def build_message(port: PortMap, values: list[Any]) -> Message:
    """The port's message from its variables' ``values`` (in binding order)."""
    fields = zero_fields(port.type)
    specs = {s.name: s for s in fields_of(port.type)}
    for binding, value in zip(port.bindings, values, strict=True):
        spec = specs[binding.field]
        if binding.index is not None:
            fields[binding.field][binding.index] = value
        elif spec.kind is FieldKind.ENUM and spec.enum_type is not None:
            try:
                fields[binding.field] = spec.enum_type(int(value))
            except ValueError:  # (the enum's own words named neither the variable nor the port)
                members = ", ".join(f"{m.value} {m.name.lower()}" for m in spec.enum_type)
                raise ValueError(f"variable {binding.variable!r} = {int(value)} is no {spec.enum_type.__name__} "
                                 f"(port {port.port}, field {binding.field}; its values: {members})") from None
        elif spec.kind is FieldKind.FLOAT:
            fields[binding.field] = float(value)
        else:
            fields[binding.field] = type(fields[binding.field])(value)
    return port.type(**fields)


def read_message(port: PortMap, msg: Message) -> list[Any]:
    """The values a message sends to the port's variables (in binding order), as Python numbers."""
    out = []
    for binding in port.bindings:
        value = getattr(msg, binding.field)
        if binding.index is not None:
            value = value[binding.index].item()
        out.append(int(value) if isinstance(value, int) and not isinstance(value, bool) else value)
    return out
