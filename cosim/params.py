"""Typed component parameters, validated from plain YAML data with every problem reported at once.

A component declares its parameters as a dataclass; constraints and units go in field metadata
through :func:`param`::

    @dataclass(frozen=True)
    class Params:
        radius: float = param(0.05, unit="m", gt=0)
        shape: Literal["disk", "sphere"] = param("disk")
        velocity: tuple[float, float, float] = param((0.0, 0.0, 0.0), unit="m/s")

Supported field types: float (ints accepted), int, bool, str, ``Literal[...]`` choices, fixed
``tuple[float, ...]`` vectors, ``list[X]``, ``X | None``, and nested parameter dataclasses.
A field whose name ends in ``_deg`` is an angle in degrees (a convention, stated in messages).
A dataclass may define ``check(self) -> list[tuple[str, str]]`` for rules across fields, returning
``(field, problem)`` pairs.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import types
import typing
from dataclasses import MISSING
from typing import Any, Literal

_REQUIRED = MISSING
INT_LIMIT = 2**63  # an int parameter is an int64 where the arithmetic runs
FLOAT_LIMIT = "1.8e+308"  # a float's range (sys.float_info.max), as messages say it


def fits_float(value: Any) -> bool:
    """Whether number ``value`` converts to a float (an integer beyond a float's range does not)."""
    try:
        float(value)
    except OverflowError:
        return False
    return True


def beyond_float(value: Any) -> bool:
    """An integer too large to be a float (1 followed by 309 zeros): no float value can take it."""
    return isinstance(value, int) and not isinstance(value, bool) and not fits_float(value)


def whole_digits(text: str) -> bool:
    """Whether ``text`` is a whole number written in the digits 0-9 alone (str.isdigit also takes '²'
    and other digits int() refuses, and full-width ones it reads: an index '²' failed as an internal
    error, a full-width 1 named item 1)."""
    return text.isascii() and text.isdigit()


def number_text(value: Any) -> str:
    """A number for a message, as ``:g`` writes it: ``0.001``, ``1e+21``; an integer beyond a
    float's range (which ``:g`` cannot write) in the same form from its leading digits: ``1e+309``."""
    if beyond_float(value):
        size = abs(value)
        exponent = int(math.log10(size))  # (a float's log10, which may be one off at a power of ten)
        while 10**exponent > size:
            exponent -= 1
        while 10 ** (exponent + 1) <= size:
            exponent += 1
        lead = size // 10 ** (exponent - 5)  # its first six digits
        return f"{'-' if value < 0 else ''}{lead / 10**5:g}e+{exponent}"
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return f"{value:g}"
    return repr(value)


def param(default: Any = _REQUIRED, *, unit: str = "", doc: str = "", gt: float | None = None,
          ge: float | None = None, lt: float | None = None, le: float | None = None) -> Any:
    """A parameter field with optional bounds (gt/ge/lt/le), unit and description."""
    meta = {"unit": unit, "doc": doc, "gt": gt, "ge": ge, "lt": lt, "le": le}
    if default is _REQUIRED:
        return dataclasses.field(metadata=meta)
    if isinstance(default, (list, dict)):
        return dataclasses.field(default_factory=lambda d=default: _copy(d), metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def _copy(value: Any) -> Any:
    if isinstance(value, list):
        return [_copy(v) for v in value]
    if isinstance(value, dict):
        return {k: _copy(v) for k, v in value.items()}
    return value


def _type_name(tp: Any) -> str:
    origin = typing.get_origin(tp)
    if origin is Literal:
        return "one of " + ", ".join(repr(a) for a in typing.get_args(tp))
    if origin is tuple:
        args = typing.get_args(tp)
        return f"a list of {len(args)} numbers"
    if origin is list:
        item = typing.get_args(tp)[0]
        plural = {float: "numbers", int: "integers", bool: "booleans", str: "strings"}.get(item)
        if typing.get_origin(item) is tuple:
            plural = f"lists of {len(typing.get_args(item))} numbers"
        return f"a list of {plural}" if plural else f"a list of {_type_name(item)}"
    if origin in (typing.Union, types.UnionType) and type(None) in typing.get_args(tp):
        kinds = [_type_name(a) for a in typing.get_args(tp) if a is not type(None)]
        return " or ".join(kinds) + " or null"
    if dataclasses.is_dataclass(tp):
        return "a mapping"
    if tp is Any:
        return "any value"
    return {float: "a number", int: "an integer", bool: "true or false", str: "a string"}.get(
        tp, getattr(tp, "__name__", str(tp)))


def show_value(value: Any) -> str:
    """A value for a message: its repr, at most 60 characters; an integer of 30 digits or more as
    :func:`number_text` writes it (``1e+309``)."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**30:
        return number_text(value)
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def whole_number(value: Any) -> Any:
    """A count written as a float with no fraction (2.0, 1.0e+3; YAML reads a number with a point or an
    exponent as a float) as the integer it is; any other value as it is. (2.0 was refused as "not an
    integer", and 1e+19, past 2^63, as "non-integer", where its range is what is wrong with it.)"""
    return int(value) if isinstance(value, float) and value.is_integer() else value


UNQUOTED_NAMES = ("YAML reads null, ~, yes/no, on/off, true/false and numbers as values; quote the name "
                  "(e.g. 'off')")


def as_written(name: Any) -> str:
    """A name as a scene's YAML wrote it: a string quoted, a value YAML read from an unquoted word in
    YAML's words (``true`` for ``on``, ``null`` for ``~``), a number as itself."""
    if isinstance(name, bool) or name is None:
        return {None: "null", True: "true", False: "false"}[name]
    return show_value(name)


def unquoted_hint(name: Any) -> str:
    """For a name that is not a string (YAML read an unquoted word as a value): the words saying so,
    to append to what is said of it; nothing for a string."""
    return "" if isinstance(name, str) else f"; {as_written(name)} is a value, not a name: {UNQUOTED_NAMES}"


def convert(tp: Any, value: Any, path: str, problems: list[str], rule: str = "") -> Any:
    """Convert plain data ``value`` to type ``tp``; append ``path: problem`` lines on failure.
    ``rule``: the field's declared bounds (``> 0 m``), said where a number is refused before they
    could be checked (an integer beyond a float's range)."""
    origin = typing.get_origin(tp)
    if origin in (typing.Union, types.UnionType):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if value is None:
            return None
        return convert(args[0], value, path, problems, rule)
    if origin is Literal:
        choices = typing.get_args(tp)
        if value not in choices:
            problems.append(f"{path}: must be one of {', '.join(map(repr, choices))} (got {show_value(value)})")
        return value
    if origin is tuple:
        args = typing.get_args(tp)
        if not isinstance(value, (list, tuple)) or len(value) != len(args):
            problems.append(f"{path}: must be {_type_name(tp)} (got {show_value(value)})")
            return value
        return tuple(convert(a, v, f"{path}[{i}]", problems) for i, (a, v) in enumerate(zip(args, value, strict=False)))
    if origin is list:
        (item,) = typing.get_args(tp)
        if not isinstance(value, list):
            problems.append(f"{path}: must be {_type_name(tp)} (got {show_value(value)})")
            return value
        return [convert(item, v, f"{path}[{i}]", problems) for i, v in enumerate(value)]
    if dataclasses.is_dataclass(tp):
        return build(tp, value, path, problems)
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            problems.append(f"{path}: must be a number (got {show_value(value)})")
            return value
        if not fits_float(value):  # an integer of 309 digits or more
            problems.append(f"{path}: must be a number {rule + ' ' if rule else ''}within a float's range, at most "
                            f"{FLOAT_LIMIT} in size (got {number_text(value)})")
            return value
        if not math.isfinite(value):
            problems.append(f"{path}: must be finite (got {value})")
        return float(value)
    if tp is int:
        value = whole_number(value)
        if isinstance(value, bool) or not isinstance(value, int):
            problems.append(f"{path}: must be an integer (got {show_value(value)})")
        elif not -INT_LIMIT <= value < INT_LIMIT:  # counts and sizes reach numpy and the kernels as int64
            problems.append(f"{path}: must be a 64-bit integer, below 2^63 in size (got {show_value(value)})")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            problems.append(f"{path}: must be true or false (got {show_value(value)})")
        return value
    if tp is str:
        if not isinstance(value, str):
            problems.append(f"{path}: must be a string (got {show_value(value)})")
        return value
    if tp is Any:
        return value
    raise TypeError(f"unsupported parameter type {tp!r} at {path}")


def _bounds_text(meta: dict[str, Any]) -> str:
    """A field's declared bounds as a rule: ``> 0 m``, ``>= 0, <= 1``."""
    unit = f" {meta['unit']}" if meta.get("unit") else ""
    rule = ", ".join(f"{word} {meta[key]:g}" for key, word in (("gt", ">"), ("ge", ">="), ("lt", "<"), ("le", "<="))
                     if meta.get(key) is not None)
    return rule + unit if rule else ""


def _beside_bound(value: float) -> str:
    """A refused value as :g writes it where that is the value itself, else every digit it has: :g
    wrote 1000001 as 1e+06, the very bound it was refused for."""
    short = f"{value:g}"
    if float(short) == value:
        return short
    if isinstance(value, float) and value.is_integer() and abs(value) < 1e16:
        return str(int(value))  # (1000001, not 1000001.0: a whole number as it was written)
    return repr(value)


def _bounds(meta: dict[str, Any], value: Any, path: str, problems: list[str]) -> None:
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        return
    unit = f" {meta['unit']}" if meta.get("unit") else ""
    for key, ok, word in (("gt", lambda v, b: v > b, ">"), ("ge", lambda v, b: v >= b, ">="),
                          ("lt", lambda v, b: v < b, "<"), ("le", lambda v, b: v <= b, "<=")):
        bound = meta.get(key)
        if bound is not None and not ok(value, bound):
            problems.append(f"{path}: must be {word} {bound:g}{unit} (got {_beside_bound(value)})")


def build(cls: type, data: Any, path: str, problems: list[str], beside: tuple[str, ...] = ()) -> Any:
    """Build parameter dataclass ``cls`` from a mapping; problems are appended, never raised.
    ``beside``: other keys written in the same mapping (a component's ``every``), offered with the
    parameters when an unknown key is near one of them."""
    prefix = f"{path}." if path else ""
    if data is None:
        data = {}
    if not isinstance(data, dict):
        problems.append(f"{path or '<root>'}: must be a mapping (got {show_value(data)})")
        return None
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    for key in data:
        if key not in fields:
            close = difflib.get_close_matches(str(key), [*fields, *beside], n=1)
            hint = (f"; did you mean {close[0]!r}?" if close else f"; known: {', '.join(fields)}" if fields
                    else f" ({path or 'this'} takes no parameters)")
            problems.append(f"{prefix}{key}: unknown key{hint}")
    values: dict[str, Any] = {}
    before = len(problems)
    for name, f in fields.items():
        if name in data:
            said = len(problems)
            value = convert(hints[name], data[name], prefix + name, problems, _bounds_text(dict(f.metadata)))
            if len(problems) == said:  # a value already refused (not finite, not a number) is not also out of bounds
                _bounds(dict(f.metadata), value, prefix + name, problems)
            values[name] = value
        elif f.default is MISSING and f.default_factory is MISSING:
            problems.append(f"{prefix}{name}: missing (required, {_type_name(hints[name])})")
    if len(problems) > before:
        return None
    obj = cls(**values)
    check = getattr(obj, "check", None)
    if check is not None:
        for field_name, problem in check():
            problems.append(f"{prefix}{field_name}: {problem}")
    return obj


def require_valid(params: Any) -> None:
    """Raise ValueError with the rules ``params`` breaks, for a component built in code rather than
    from a scene, which :func:`build` checks: each field's own (:func:`field_problems`), then those
    across fields (its ``check()``, run only when the fields are right)."""
    problems = field_problems(params)
    if not problems:
        problems = [f"{name}: {text}" for name, text in params.check()]
    if problems:
        raise ValueError("; ".join(problems))


def field_problems(params: Any) -> list[str]:
    """What breaks the rules of a parameter dataclass's own fields, as a scene would be told: a
    ``Literal`` field's value not among its choices, a number outside its declared bounds or not
    finite (a tilt of inf failed on a bare "math domain error", one of NaN at the first step). Built in
    code, Params took them without a word (``shape="cube"`` made a sphere, ``restitution=2.0`` a
    bounce gaining energy). Values of other kinds (nested mappings, lists) are the component's to
    check, as before."""
    problems: list[str] = []
    hints = typing.get_type_hints(type(params))
    for f in dataclasses.fields(params):
        value = getattr(params, f.name)
        tp = hints[f.name]
        if typing.get_origin(tp) is Literal and value not in typing.get_args(tp):
            problems.append(f"{f.name}: must be one of {', '.join(map(repr, typing.get_args(tp)))} "
                            f"(got {show_value(value)})")
        elif isinstance(value, (int, float)) and not isinstance(value, bool):
            if math.isfinite(value):
                _bounds(dict(f.metadata), value, f.name, problems)
            elif value != f.default:  # (a default of inf, "none", is the field's own; NaN never is)
                problems.append(f"{f.name}: must be finite (got {value})")
    return problems


class ParamRow(typing.NamedTuple):
    """One parameter as ``cosim components`` and docs/components.md show it: its key (dotted inside
    a nested mapping), what it takes, its default as YAML writes it, its unit, its bounds
    (``> 0, <= 64``) and its description."""

    name: str
    kind: str
    default: str
    unit: str
    bounds: str
    doc: str


def yaml_text(value: Any) -> str:
    """A parameter value as a scene writes it: ``[0.0, 1.5]``, ``null``, ``true``, ``ring``."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(yaml_text(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {yaml_text(v)}" for k, v in value.items()) + "}"
    if dataclasses.is_dataclass(value):
        return yaml_text({f.name: getattr(value, f.name) for f in dataclasses.fields(value)})
    return str(value)


def describe(cls: type, prefix: str = "") -> list[ParamRow]:
    """Every parameter of dataclass ``cls``, nested mappings' fields after their own row."""
    hints = typing.get_type_hints(cls)
    rows = []
    for f in dataclasses.fields(cls):
        if f.default is not MISSING:
            default = yaml_text(f.default)
        elif f.default_factory is not MISSING:
            default = yaml_text(f.default_factory())
        else:
            default = "(required)"
        meta = dict(f.metadata)
        bounds = ", ".join(f"{word} {meta[key]:g}" for key, word in (("gt", ">"), ("ge", ">="), ("lt", "<"),
                                                                     ("le", "<=")) if meta.get(key) is not None)
        kind = hints[f.name]
        rows.append(ParamRow(prefix + f.name, _type_name(kind), default, meta.get("unit", ""), bounds,
                             meta.get("doc", "")))
        if dataclasses.is_dataclass(kind):
            rows += describe(kind, f"{prefix}{f.name}.")
    return rows
