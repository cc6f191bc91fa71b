"""Sweeps: many independent runs of one scene over a grid or random samples of its parameters.

The framework knows nothing about what it sweeps: a sweep is a base scene plus axes of values
applied as overrides (``key.path=value``, exactly like ``cosim run --set``). A sweep file::

    name: demo                      # default: the file's stem
    scene: ../skip.yaml             # relative to this file, or an inline scene mapping
    mode: grid                      # grid: every combination | random: `samples` draws with `seed`
    axes:                           # override key path (or a variable of `derived`) -> values
      components.stone.tilt_deg: {linspace: [5, 45, 9]}
      speed: [2.0, 2.5, 3.0]        # not a key of the scene: a variable used by `derived`
    derived:                        # key path -> expression of the variable axes
      components.stone.velocity: "[speed * cos(radians(20)), 0, -speed * sin(radians(20))]"
    set: {components.stone.lock_attitude: true}    # fixed overrides of every run
    until: 2.0                      # end time of every run [s] (default: the scene's)
    metrics: ["stages.*"]           # component metrics to keep (fnmatch patterns; default: all)
    record: false                   # true: an MCAP per run in <output stem>_runs/
    run_timeout: 600                # wall seconds a run may take; one longer is stopped, its row failed
    output: runs/demo.csv           # relative to the working directory; .parquet needs pyarrow
    figure: {metric: stages.skips, x: components.stone.tilt_deg, y: speed, threshold: 1}

Axis values: a list; ``{linspace: [a, b, n]}``; ``{logspace: [a, b, n]}`` (n values spaced
geometrically from a to b: the values themselves, not exponents); ``{range: [start, stop, step]}``
(integers, stop excluded). In random mode: ``{uniform: [a, b]}``, ``{loguniform: [a, b]}``, or a list
(each sample picks one value).

An axis named by a key path of the scene (it has a dot, or is a top-level key of a scene such as ``dt``
or ``on_unstable``, given in the base scene or not) is an override; any other name is a variable for
``derived`` (and a column of the table). Every point gets a stable id (a hash of its axis values), so
a resumed sweep skips finished points and tables from different backends or worker counts can be
compared row by row.

:func:`load_sweep` validates the whole file before anything runs and reports every problem with its
path as one :class:`ScenarioError`, including those of the scene of the first point whose derived
values can be worked out (a misspelt key path shows up there; when no point's can, the first one's
failure) and of each value of an override axis that breaks its own key's rule, loaded with
the other axes at their first values (``VALUES_CHECKED`` values at most, spread over each axis); any
other point whose scene is invalid for its combination of values (or for a derived value) becomes
an error row of the table. A sweep of more than ``MAX_POINTS`` points is refused from its axis counts (or ``samples``)
before any value is built.
"""

from __future__ import annotations

import ast
import difflib
import fnmatch
import hashlib
import itertools
import json
import math
import operator
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from cosim.errors import ScenarioError
from cosim.params import FLOAT_LIMIT, beyond_float, fits_float, number_text, show_value
from cosim.scenario import SCENE_NAME_RE, dump_yaml, find_parent, loads, read_input, read_yaml
from cosim.scenario import TOP_KEYS as SCENE_KEYS

TOP_KEYS = ("name", "description", "scene", "mode", "samples", "seed", "axes", "derived", "set", "until",
            "metrics", "record", "run_timeout", "output", "figure")
MODES = ("grid", "random")
GRID_SPECS = ("linspace", "logspace", "range")
RANDOM_SPECS = ("uniform", "loguniform")
TABLE_SUFFIXES = (".csv", ".parquet")  # the results tables a sweep writes
FIGURE_KEYS = ("metric", "x", "y", "threshold", "reference")
REFERENCE_KEYS = ("label", "points")  # of figure.reference
MAX_POINTS = 1_000_000  # a sweep larger than this is almost surely a typo in an axis
# values of override axes whose scenes are loaded as a sweep is (4 to 40 ms each, a second or a few on
# every start and resume); past that, those checked of each axis are spread over it, its ends among them
VALUES_CHECKED = 100
ID_LENGTH = 12  # hex digits of a point id (48 bits: collisions are negligible below billions of points)

# the fixed columns of the results table, around the axes and the metrics
HEAD_COLUMNS = ("index", "point_id")
RUN_COLUMNS = ("status", "reason", "error_type", "sim_time_s", "ticks")


# --- values and overrides ----------------------------------------------------------------------

def plain(value: Any) -> Any:
    """``value`` as plain Python data (numpy scalars and arrays become floats, ints and lists)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, (list, tuple, np.ndarray)):
        return [plain(v) for v in value]
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    return value


def yaml_value(value: Any) -> str:
    """One-line YAML for ``value`` that parses back to the same value (floats bit for bit)."""
    value = plain(value)
    quick = _plain_yaml(value)
    if quick is not None:
        return quick
    text = dump_yaml(value, default_flow_style=True, width=math.inf, allow_unicode=True)
    return text.removesuffix("\n...\n").strip()


def _plain_yaml(value: Any) -> str | None:
    """The text :func:`dump_yaml` gives a number, a bool, None or a list of them, written
    here directly (a sweep's plan writes one per axis and derived key at every point: 180,000 for a
    300 x 300 grid, 16 s through the dumper); None for anything else (text needs the dumper's
    quoting)."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if value != value:
            return ".nan"
        if value in (math.inf, -math.inf):
            return ".inf" if value > 0 else "-.inf"
        text = repr(value).lower()
        # YAML 1.1 reads a float only with a dot in it: 1e-05 is written 1.0e-05 (as the dumper does)
        return text.replace("e", ".0e") if "." not in text and "e" in text else text
    if isinstance(value, list):
        items = [_plain_yaml(v) for v in value]
        return None if any(item is None for item in items) else "[" + ", ".join(items) + "]"  # type: ignore[arg-type]
    return None


def point_id(values: dict[str, Any]) -> str:
    """A stable id of one point: a hash of its axis names and values (floats by their exact repr)."""
    text = json.dumps(plain(values), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:ID_LENGTH]


# --- expressions of `derived` -------------------------------------------------------------------

_FUNCTIONS: dict[str, Callable[..., Any]] = {
    name: getattr(math, name) for name in (
        "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh", "radians",
        "degrees", "sqrt", "exp", "log", "log10", "log2", "hypot", "floor", "ceil")}
_FUNCTIONS.update(abs=abs, min=min, max=max, round=round)
_CONSTANTS = {"pi": math.pi, "e": math.e, "tau": math.tau, "inf": math.inf}
_BINARY = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
           ast.FloorDiv: operator.floordiv, ast.Mod: operator.mod, ast.Pow: operator.pow}
_UNARY = {ast.USub: operator.neg, ast.UAdd: operator.pos}
MAX_EXPONENT = 1024  # larger integer powers would take unbounded time and memory
# round()'s digits at most this far either side of the point: a float has 17 significant digits and
# none beyond about 1e308 or below 5e-324, and round(u, -100000000) of an integer took minutes
MAX_ROUND_DIGITS = 400
# an expression's length and nesting: Python's parser and the checks recurse once per operator, and a
# chain of 1,000 '+' or 50,000 '-' ended in RecursionError or MemoryError (exit 1) instead of a problem
MAX_EXPRESSION_CHARS = 2000
MAX_EXPRESSION_DEPTH = 100


class Expression:
    """An arithmetic expression of named values: numbers, + - * / // % **, math functions (sin, cos,
    radians, sqrt, hypot, ...), pi, and [lists]. Nothing else is evaluated (no attributes, no imports)."""

    def __init__(self, text: str):
        self.text = text
        if len(text) > MAX_EXPRESSION_CHARS:
            raise ValueError(f"the expression is {len(text)} characters long (at most {MAX_EXPRESSION_CHARS})")
        try:
            self.tree = ast.parse(text.strip(), mode="eval").body
        except (RecursionError, MemoryError):
            raise ValueError(f"the expression is nested too deeply to read (at most {MAX_EXPRESSION_DEPTH} "
                             "operations inside one another)") from None
        self.names: set[str] = set()
        self._check(self.tree)

    def _check(self, node: ast.AST, depth: int = 0) -> None:
        if depth > MAX_EXPRESSION_DEPTH:
            raise ValueError(f"the expression has more than {MAX_EXPRESSION_DEPTH} operations inside one another "
                             f"(a sum of {MAX_EXPRESSION_DEPTH + 2} terms is one)")
        depth += 1
        if isinstance(node, ast.Constant):
            if isinstance(node.value, bool) or not isinstance(node.value, (int, float, str)):
                raise ValueError(f"constant {node.value!r} is not a number or a string")
        elif isinstance(node, ast.Name):
            if node.id not in _CONSTANTS:
                self.names.add(node.id)
        elif isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
            self._check(node.left, depth)
            self._check(node.right, depth)
        elif isinstance(node, ast.UnaryOp) and type(node.op) in _UNARY:
            self._check(node.operand, depth)
        elif isinstance(node, (ast.List, ast.Tuple)):
            for item in node.elts:
                self._check(item, depth)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and not node.keywords:
            if node.func.id not in _FUNCTIONS:
                known = ", ".join(sorted(_FUNCTIONS))
                raise ValueError(f"unknown function {node.func.id!r} (known: {known})")
            for arg in node.args:
                self._check(arg, depth)
        else:
            raise ValueError(f"{ast.unparse(node)!r} is not allowed (numbers, names, + - * / // % **, "
                             "math functions and [lists] only)")

    def __call__(self, env: dict[str, Any]) -> Any:
        return self._eval(self.tree, env)

    def _eval(self, node: ast.AST, env: dict[str, Any]) -> Any:
        value = self._value(node, env)
        if isinstance(value, complex):  # a negative number to a fractional power: no scene value is one
            raise ValueError(f"{ast.unparse(node)} is the complex number {value!r}, not a real value")
        if beyond_float(value):
            # no scene value can take it (attack**1000 reached the scene as an integer of 1001 digits),
            # and refusing each such step keeps the integers, and the time they take, small
            raise ValueError(f"{ast.unparse(node)} is {number_text(value)}, beyond a float's range (at most "
                             f"{FLOAT_LIMIT} in size)")
        return value

    def _value(self, node: ast.AST, env: dict[str, Any]) -> Any:
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, ast.Name):
            return env[node.id] if node.id in env else _CONSTANTS[node.id]
        if isinstance(node, ast.BinOp):
            left, right = self._eval(node.left, env), self._eval(node.right, env)
            if isinstance(node.op, ast.Pow) and isinstance(right, (int, float)) and abs(right) > MAX_EXPONENT:
                raise ValueError(f"exponent {right:g} is too large (at most {MAX_EXPONENT})")
            if isinstance(left, list) or isinstance(right, list):
                # numbers combine; a list is a value's components, never repeated or joined
                # ([attack] * 100000000 took a minute and ended out of memory)
                raise ValueError("a list can only be a value (its items computed one by one), not "
                                 "repeated or joined with +, -, *, /")
            if isinstance(left, str) or isinstance(right, str):
                # a text is a value as it stands: 'ab' * 50000000 * u took minutes and gigabytes
                raise ValueError(f"{ast.unparse(node)}: a text can only be a value, not repeated or joined "
                                 "with +, -, *, /, //, %, **")
            return _BINARY[type(node.op)](left, right)
        if isinstance(node, ast.UnaryOp):
            return _UNARY[type(node.op)](self._eval(node.operand, env))
        if isinstance(node, (ast.List, ast.Tuple)):
            return [self._eval(item, env) for item in node.elts]
        if isinstance(node, ast.Call):
            args = [self._eval(arg, env) for arg in node.args]
            if node.func.id == "round" and len(args) == 2 and isinstance(args[1], int):  # type: ignore[attr-defined]
                if abs(args[1]) > MAX_ROUND_DIGITS:
                    raise ValueError(f"{ast.unparse(node)}: round's digits must be within +-{MAX_ROUND_DIGITS} "
                                     f"(got {number_text(args[1])})")
            return _FUNCTIONS[node.func.id](*args)  # type: ignore[attr-defined]
        raise AssertionError(f"unchecked node {node!r}")  # _check admits nothing else


# --- the sweep ----------------------------------------------------------------------------------

@dataclass(frozen=True)
class Axis:
    """One axis: an override (``kind`` "override") or a variable of ``derived`` ("variable").

    Grid mode: ``values``. Random mode: ``sampler`` = ("uniform" | "loguniform", a, b) or ("choice",
    values).
    """

    name: str
    kind: str
    values: tuple[Any, ...] = ()
    sampler: tuple[Any, ...] | None = None


@dataclass(frozen=True)
class Point:
    """One run of the sweep: its position, axis values, stable id and the overrides of its scene.

    ``problem``: why its overrides could not be computed (a derived value failed), else None.
    """

    index: int
    values: dict[str, Any]
    point_id: str
    overrides: tuple[str, ...]
    problem: str | None = None

    def label(self) -> str:
        return ", ".join(f"{k}={yaml_value(v)}" for k, v in self.values.items())


@dataclass(frozen=True)
class FigureSpec:
    """The summary figure: ``metric`` over axis ``x`` (and ``y``: a heat map); ``threshold``: also draw,
    for each x, the lowest y whose metric reaches it; ``reference``: labelled points to overlay."""

    metric: str
    x: str
    y: str | None = None
    threshold: float | None = None
    reference_label: str = ""
    reference_points: tuple[tuple[float, float], ...] = ()


@dataclass
class Sweep:
    """A validated sweep: the base scene, the points to run and what to keep of each run."""

    name: str
    description: str
    source: str
    text: str
    scene_text: str
    scene_source: str
    mode: str
    axes: list[Axis]
    derived: dict[str, Expression]
    fixed: list[str]
    metrics: list[str]
    record: bool
    output: Path
    figure: FigureSpec | None
    points: list[Point]
    samples: int | None = None
    seed: int = 0
    metric_kinds: dict[str, str] = field(default_factory=dict)
    notices: list[str] = field(default_factory=list)  # the first point's scene's (Scene.notices)
    run_timeout_s: float | None = None  # wall seconds a run may take (None: no bound)

    @property
    def columns(self) -> list[str]:
        """The columns of the results table, in order."""
        tail = ["recording"] if self.record else []
        return [*HEAD_COLUMNS, *(a.name for a in self.axes), *RUN_COLUMNS, *self.metrics, *tail, "wall_s"]

    def fingerprint(self) -> str:
        """A hash of everything that shapes each run except the axis values: the base scene, the fixed
        and derived overrides, the kept metrics and the table's columns. A table may be resumed (or
        extended with more axis values) only by a sweep with the same fingerprint."""
        data = {"scene": self.scene_text, "fixed": self.fixed,
                "derived": {k: e.text for k, e in self.derived.items()}, "columns": self.columns}
        return hashlib.sha256(json.dumps(data, sort_keys=True).encode()).hexdigest()[:16]

    def describe(self) -> str:
        """One line: name, number of points and how they are laid out."""
        if self.mode == "grid":
            shape = " x ".join(f"{len(a.values)} {a.name}" for a in self.axes)
            return f"{self.name}: {len(self.points)} points (grid of {shape})"
        names = ", ".join(a.name for a in self.axes)
        return f"{self.name}: {len(self.points)} points (random samples of {names}, seed {self.seed})"


# --- parsing and validation ---------------------------------------------------------------------

def _parse_yaml(text: str, source: str) -> dict[str, Any]:
    data = read_yaml(text, source)
    if not isinstance(data, dict):
        raise ScenarioError("a sweep must be a mapping with at least 'scene' and 'axes' "
                            f"(got {'nothing' if data is None else type(data).__name__})", source)
    return data


def _is_number(value: Any) -> bool:
    """A finite number a float holds (an integer beyond a float's range is not: math.isfinite of it
    overflowed, an internal error)."""
    return (isinstance(value, (int, float)) and not isinstance(value, bool) and fits_float(value)
            and math.isfinite(value))


def _shown(value: Any) -> str:
    """A value for a problem line: a list's items (and a lone value) as :func:`cosim.params.show_value`
    writes them, so that an integer of hundreds of digits is shown as 1e+309."""
    if isinstance(value, list):
        return "[" + ", ".join(show_value(v) for v in value) + "]"
    return show_value(value)


def _numbers(spec: Any, count: int, path: str, problems: list[str]) -> list[float] | None:
    if not isinstance(spec, list) or len(spec) != count or not all(_is_number(v) for v in spec):
        problems.append(f"{path}: expected a list of {count} finite numbers (got {_shown(spec)})")
        return None
    return spec


def _range_count(start: int, stop: int, step: int = 1) -> int:
    """``len(range(start, stop, step))`` without building it (and without overflowing a C size)."""
    if step > 0:
        return max(0, (stop - start + step - 1) // step)
    return max(0, (start - stop - step - 1) // -step)


def _grid_axis(name: str, spec: Any, problems: list[str]) -> tuple[int, Callable[[], tuple[Any, ...]]]:
    """An axis of a grid: its number of values and a function that builds them.

    The count comes from the spec alone, so a sweep that is too large is refused before any value is
    built (``{range: [0, 100000000]}`` would otherwise take gigabytes). An axis with a problem, or more
    values than a whole sweep may have, counts 0 and builds nothing.
    """
    path = f"axes.{name}"
    nothing: tuple[int, Callable[[], tuple[Any, ...]]] = (0, tuple)
    if isinstance(spec, list):
        if not spec:
            problems.append(f"{path}: needs at least one value")
        values = tuple(plain(spec))  # already in memory: the YAML parser built it
        return len(values), lambda: values
    if not isinstance(spec, dict) or len(spec) != 1:
        problems.append(f"{path}: expected a list of values or one of {{linspace: [a, b, n]}}, "
                        f"{{logspace: [a, b, n]}}, {{range: [start, stop, step]}} (got {spec!r})")
        return nothing
    (kind, args), = spec.items()
    if kind in RANDOM_SPECS:
        problems.append(f"{path}.{kind}: is for mode: random "
                        "(in a grid, use linspace, logspace, range or a list)")
        return nothing
    if kind in ("linspace", "logspace"):
        nums = _numbers(args, 3, f"{path}.{kind}", problems)
        if nums is None:
            return nothing
        a, b, n = nums
        if not (isinstance(n, int) and n >= 1):
            problems.append(f"{path}.{kind}: the count must be a whole number >= 1 (got {n!r})")
            return nothing
        if n > MAX_POINTS:
            problems.append(f"{path}.{kind}: {n} values is more than the {MAX_POINTS} points a sweep may "
                            f"have (got {args!r}); check the count")
            return nothing
        if kind == "logspace":
            if not (a > 0 and b > 0):
                problems.append(f"{path}.logspace: both ends must be > 0 (got {a:g} and {b:g})")
                return nothing
            return n, lambda: tuple(plain(np.geomspace(a, b, n)))
        if not math.isfinite(b - a):  # (numpy warned of an overflow, and the points were nan)
            problems.append(f"{path}.linspace: the span from {a:g} to {b:g} is beyond what a float holds; "
                            "give ends whose difference is finite")
            return nothing
        return n, lambda: tuple(plain(np.linspace(a, b, n)))
    if kind == "range":
        if not (isinstance(args, list) and 2 <= len(args) <= 3
                and all(isinstance(v, int) and not isinstance(v, bool) for v in args)):
            problems.append(f"{path}.range: expected [start, stop] or [start, stop, step] of integers "
                            f"(got {args!r})")
            return nothing
        if len(args) == 3 and args[2] == 0:
            problems.append(f"{path}.range: the step must not be 0")
            return nothing
        count = _range_count(*args)
        if not count:
            problems.append(f"{path}.range: {args!r} holds no value")
        elif count > MAX_POINTS:
            problems.append(f"{path}.range: {count} values is more than the {MAX_POINTS} points a sweep may "
                            f"have (got {args!r}); check the start, stop and step")
            return nothing
        return count, lambda: tuple(range(*args))
    problems.append(f"{path}: unknown kind {kind!r} (known in a grid: {', '.join(GRID_SPECS)}, or a list)")
    return nothing


def _sampler(name: str, spec: Any, problems: list[str]) -> tuple[Any, ...] | None:
    path = f"axes.{name}"
    if isinstance(spec, list):
        if not spec:
            problems.append(f"{path}: needs at least one value to choose from")
            return None
        return ("choice", tuple(plain(spec)))
    if not isinstance(spec, dict) or len(spec) != 1:
        problems.append(f"{path}: expected {{uniform: [a, b]}}, {{loguniform: [a, b]}} or a list of values "
                        f"to choose from (got {spec!r})")
        return None
    (kind, args), = spec.items()
    if kind in GRID_SPECS:
        problems.append(f"{path}.{kind}: is for mode: grid "
                        "(in random mode, use uniform, loguniform or a list)")
        return None
    if kind not in RANDOM_SPECS:
        problems.append(f"{path}: unknown kind {kind!r} "
                        f"(known in random mode: {', '.join(RANDOM_SPECS)}, or a list)")
        return None
    nums = _numbers(args, 2, f"{path}.{kind}", problems)
    if nums is None:
        return None
    a, b = nums
    if not a < b:
        problems.append(f"{path}.{kind}: expected a < b (got {a:g} and {b:g})")
        return None
    if kind == "loguniform" and not a > 0:
        problems.append(f"{path}.loguniform: both ends must be > 0 (got {a:g})")
        return None
    if kind == "uniform" and not math.isfinite(float(b) - float(a)):  # (numpy's draw overflowed)
        problems.append(f"{path}.uniform: the span from {a:g} to {b:g} is beyond what a float holds; "
                        "give ends whose difference is finite")
        return None
    return (kind, float(a), float(b))


def _check_key_path(data: Any, key: str, path: str, problems: list[str]) -> None:
    """Every part of ``key`` but the last must exist in the base scene (the last may be a parameter
    left at its default; the scene's own validation judges it)."""
    parts = key.split(".")
    node, missing = find_parent(data, parts)
    if missing is not None:
        problems.append(f"{path}: the scene has no key {missing}")
        return
    if not isinstance(node, (dict, list)):
        parent = ".".join(parts[:-1])
        problems.append(f"{path}: {parent!r} is a {type(node).__name__} in the scene, not a mapping")


def _base_scene(data: dict[str, Any], base_dir: Path, source: str,
                problems: list[str]) -> tuple[str, str, dict[str, Any]] | None:
    spec = data.get("scene")
    if spec is None:
        problems.append("scene: missing (required: a scene file relative to this sweep, or a scene mapping)")
        return None
    if isinstance(spec, dict):
        return dump_yaml(spec, sort_keys=False), f"{source}:scene", spec
    if not isinstance(spec, str):
        problems.append(f"scene: must be a file name or a mapping (got {spec!r})")
        return None
    path = base_dir / spec
    try:  # as a scene is read: a folder, a device or pipe (/dev/zero filled the memory) or a huge file refused
        text = read_input(path)
    except ScenarioError as exc:
        looked = f" (looked for {path})" if str(path) != spec else ""
        problems.append(f"scene: {spec!r}: {exc.problems[0]}{looked}")
        return None
    try:
        scene_data = read_yaml(text, spec)  # read as the scene is loaded (YAML 1.2's numbers)
    except ScenarioError:
        scene_data = None  # the scene's own validation reports it, with the line
    if isinstance(scene_data, dict) and "axes" in scene_data and "components" not in scene_data:
        problems.append(f"scene: {spec!r} is a sweep file (it has axes and no components), not the scene "
                        "a sweep varies")
        return None
    return text, str(path), scene_data if isinstance(scene_data, dict) else {}


def _same_value(value: Any) -> Any:
    """What two equal values of an axis have in common: a number its value (10 and 10.0 are one point's
    value twice, though their ids differ), a list its items', anything else its YAML text."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return ("nan",) if value != value else value  # (nan differs from itself, and is repeated all the same)
    if isinstance(value, (list, tuple)):
        return tuple(_same_value(v) for v in value)
    return yaml_value(value)


def _points(mode: str, axes: list[Axis], samples: int | None, seed: int, fixed: list[str],
            derived: dict[str, Expression]) -> list[Point]:
    if mode == "grid":
        combos: Any = itertools.product(*(a.values for a in axes))
    else:
        rng = np.random.default_rng(seed)
        combos = []
        for _ in range(samples or 0):  # sample by sample, so a larger `samples` keeps the first ones
            combo = []
            for axis in axes:
                kind, *args = axis.sampler or ("choice", (None,))
                if kind == "uniform":
                    combo.append(float(rng.uniform(args[0], args[1])))
                elif kind == "loguniform":
                    combo.append(float(math.exp(rng.uniform(math.log(args[0]), math.log(args[1])))))
                else:
                    combo.append(args[0][int(rng.integers(len(args[0])))])
            combos.append(combo)
    points = []
    for index, combo in enumerate(combos):
        values = dict(zip((a.name for a in axes), combo, strict=True))
        overrides = list(fixed)
        overrides += [f"{a.name}={yaml_value(v)}" for a, v in zip(axes, combo, strict=True)
                      if a.kind == "override"]
        problem = None
        env = {a.name: v for a, v in zip(axes, combo, strict=True) if a.kind == "variable"}
        for key, expr in derived.items():
            try:
                overrides.append(f"{key}={yaml_value(expr(env))}")
            except Exception as exc:  # a math domain error at one point fails that point only
                problem = f"derived.{key}: cannot evaluate {expr.text!r}: {type(exc).__name__}: {exc}"
                break
        points.append(Point(index, values, point_id(values), tuple(overrides), problem))
    return points


def _figure(spec: Any, problems: list[str]) -> dict[str, Any] | None:
    if spec is None:
        return None
    if not isinstance(spec, dict):
        problems.append(f"figure: must be a mapping with metric, x, y (got {spec!r})")
        return None
    for key in spec:
        if key not in FIGURE_KEYS:
            problems.append(f"figure.{key}: unknown key (known: {', '.join(FIGURE_KEYS)})")
    for key in ("metric", "x", "y"):
        if key in spec and not isinstance(spec[key], str):
            problems.append(f"figure.{key}: must be a name (got {spec[key]!r})")
    if "threshold" in spec and not _is_number(spec["threshold"]):
        problems.append(f"figure.threshold: must be a number (got {_shown(spec['threshold'])})")
    ref = spec.get("reference")
    for key in ref if isinstance(ref, dict) else ():
        if key not in REFERENCE_KEYS:
            problems.append(f"figure.reference.{key}: unknown key (known: {', '.join(REFERENCE_KEYS)})")
    if ref is not None:
        points = ref.get("points") if isinstance(ref, dict) else None
        if (not isinstance(points, list) or not points or not all(
                isinstance(p, list) and len(p) == 2 and all(_is_number(v) for v in p) for p in points)):
            problems.append("figure.reference: expected {label: text, points: [[x, y], ...]} "
                            f"(got {ref!r})")
    return spec


def loads_sweep(text: str, source: str = "<sweep>", base_dir: str | Path = ".",
                overrides: list[str] | None = None, output: str | Path | None = None) -> Sweep:
    """Parse and validate a sweep; raises ScenarioError listing every problem.

    ``base_dir``: where a ``scene:`` file name is looked up. ``overrides``: ``key.path=value`` strings
    applied to every run (after the file's ``set``). ``output``: the table, instead of ``output:``.
    """
    data = _parse_yaml(text, source)
    if "components" in data and "axes" not in data and "scene" not in data:
        # a scene given where a sweep belongs: say so, not every scene key that a sweep lacks
        raise ScenarioError([f"a scene, not a sweep (it has components: and no axes:); run it with "
                             f"`cosim run {source}`, or name it in a sweep's scene: key"], source)
    problems: list[str] = []
    for key in data:
        if key not in TOP_KEYS:
            problems.append(f"{key}: unknown key (known: {', '.join(TOP_KEYS)})")
    name = data.get("name", Path(source).stem if source != "<sweep>" else "sweep")
    if not isinstance(name, str) or not name:
        problems.append(f"name: must be a non-empty string (got {name!r})")
        name = "sweep"
    elif "\0" in name:  # no file name can hold it (the table's default is runs/NAME.csv)
        problems.append(f"name: must not hold a NUL character (got {name!r})")
        name = "sweep"
    elif "name" in data and (not SCENE_NAME_RE.fullmatch(name) or ".." in name):
        # as a scene's name: it names the default table, runs/NAME.csv ("../x" wrote outside runs/)
        problems.append(f"name: must be letters, digits, _, - and . (not first), at most 100 characters, "
                        f"no '..': it names the table's file (got {name!r})")
        name = "sweep"
    description = data.get("description", "")
    base = _base_scene(data, Path(base_dir), source, problems)
    scene_data = base[2] if base else {}

    mode = data.get("mode", "grid")
    if mode not in MODES:
        problems.append(f"mode: must be one of {', '.join(MODES)} (got {mode!r})")
        mode = "grid"
    samples = data.get("samples")
    seed = data.get("seed", 0)
    if mode == "random":
        if not (isinstance(samples, int) and not isinstance(samples, bool) and samples >= 1):
            problems.append(f"samples: mode: random needs a whole number of samples >= 1 (got {samples!r})")
            samples = 0
        elif samples > MAX_POINTS:  # refused before a single sample is drawn
            problems.append(f"samples: {samples} points is more than {MAX_POINTS}; check the count")
        if not (isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0):
            problems.append(f"seed: must be a whole number >= 0 (got {seed!r})")
            seed = 0
    else:
        for key in ("samples", "seed"):
            if key in data:
                problems.append(f"{key}: only for mode: random (a grid runs every combination)")

    axes: list[Axis] = []
    grid: list[tuple[str, str, int, Callable[[], tuple[Any, ...]]]] = []  # name, kind, count, build
    raw_axes = data.get("axes")
    if not isinstance(raw_axes, dict) or not raw_axes:
        problems.append("axes: missing or empty (required: a mapping of key path or variable -> values)"
                        if raw_axes is None or raw_axes == {}
                        else f"axes: must be a mapping (got {raw_axes!r})")
        raw_axes = {}
    for axis_name, spec in raw_axes.items():
        axis_name = str(axis_name)
        # (a top-level key the scene leaves at its default, such as on_unstable, as set: and --set take it)
        if "." in axis_name or axis_name in scene_data or axis_name in SCENE_KEYS:
            kind = "override"
            _check_key_path(scene_data, axis_name, f"axes.{axis_name}", problems)
        elif axis_name.isidentifier() and axis_name not in _CONSTANTS and axis_name not in _FUNCTIONS:
            kind = "variable"
        else:
            problems.append(f"axes.{axis_name}: neither a key path of the scene nor a variable name")
            continue
        if mode == "grid":
            grid.append((axis_name, kind, *_grid_axis(axis_name, spec, problems)))
        else:
            axes.append(Axis(axis_name, kind, sampler=_sampler(axis_name, spec, problems)))
    # the number of points from the axis counts alone: a grid too large is refused before any of its
    # values (let alone its points) is built; an axis with a problem counts 0 and is reported already
    total = math.prod(count for _, _, count, _ in grid)
    if total > MAX_POINTS:
        shape = " x ".join(f"{count} {axis_name}" for axis_name, _, count, _ in grid)
        problems.append(f"axes: {total} points is more than {MAX_POINTS} (a grid of {shape}); "
                        "check the axis counts")
    for axis_name, kind, _, build in grid:
        values = build() if total <= MAX_POINTS else ()
        if len(set(map(_same_value, values))) < len(values):
            problems.append(f"axes.{axis_name}: repeats a value ({list(values)!r}); each point must differ")
        axes.append(Axis(axis_name, kind, values=values))

    fixed: list[str] = []
    targets: dict[str, str] = {a.name: f"axes.{a.name}" for a in axes if a.kind == "override"}

    def claim(key: str, path: str) -> None:
        if key in targets:
            problems.append(f"{path}: sets {key!r}, which {targets[key]} sets too")
        targets[key] = path

    raw_set = data.get("set", {}) or {}
    if not isinstance(raw_set, dict):
        problems.append(f"set: must be a mapping of key path -> value (got {raw_set!r})")
        raw_set = {}
    if "until" in data:
        if not (_is_number(data["until"]) and data["until"] > 0):
            problems.append(f"until: must be a number of seconds > 0 (got {_shown(data['until'])})")
        elif "until" in raw_set:
            problems.append("until: given twice (here and in set)")
        else:
            raw_set = {**raw_set, "until": data["until"]}
    for key, value in raw_set.items():
        key = str(key)
        _check_key_path(scene_data, key, f"set.{key}", problems)
        claim(key, f"set.{key}")
        fixed.append(f"{key}={yaml_value(value)}")
    command_line_keys: list[str] = []  # --set's keys: checked against the axes' and derived ones below
    for item in overrides or []:
        key, sep, _ = item.partition("=")
        if not sep or not key.strip():
            problems.append(f"--set {item!r}: expected key.path=value")
            continue
        _check_key_path(scene_data, key.strip(), f"--set {key.strip()}", problems)
        command_line_keys.append(key.strip())
        fixed.append(item)

    derived: dict[str, Expression] = {}
    raw_derived = data.get("derived", {}) or {}
    if not isinstance(raw_derived, dict):
        problems.append(f"derived: must be a mapping of key path -> expression (got {raw_derived!r})")
        raw_derived = {}
    variables = {a.name for a in axes if a.kind == "variable"}
    used: set[str] = set()
    unread = False  # a derived expression that could not be read: which axes it uses is not known
    for key, expr_text in raw_derived.items():
        key, path = str(key), f"derived.{key}"
        if not isinstance(expr_text, str):
            problems.append(f"{path}: must be an expression in quotes (got {expr_text!r}; "
                            "a fixed value goes in set)")
            continue
        try:
            expr = Expression(expr_text)
        except SyntaxError as exc:
            problems.append(f"{path}: not an expression: {expr_text!r} ({exc.msg})")
            unread = True
            continue
        except ValueError as exc:
            problems.append(f"{path}: {exc}")
            unread = True
            continue
        unknown = sorted(expr.names - variables)
        if unknown:
            problems.append(f"{path}: unknown name {', '.join(map(repr, unknown))} (variable axes: "
                            f"{', '.join(sorted(variables)) or 'none'}; constants: {', '.join(_CONSTANTS)})")
        used |= expr.names
        # an axis whose name was misspelled here is not also "not used" (the misspelling is the problem)
        used |= {name for u in unknown for name in difflib.get_close_matches(u, variables, n=1)}
        _check_key_path(scene_data, key, path, problems)
        claim(key, path)
        derived[key] = expr
    for key in command_line_keys:
        # a point's own value is applied after --set: one given here for the same key would do nothing
        if key in targets and not targets[key].startswith("set."):
            problems.append(f"--set {key}: {targets[key]} sets it at every point; a value given here would "
                            "be ignored (leave it out, or change the sweep file)")
    for axis in axes:
        # (without the scene, which keys it has is not known: its own problem is said instead)
        if axis.kind == "variable" and axis.name not in used and not unread and base is not None:
            known = ", ".join(sorted(map(str, scene_data))) or "none"
            problems.append(f"axes.{axis.name}: not a key of the scene (top-level keys: {known}) and not "
                            "used in derived; give a key path such as components.NAME.PARAM")

    metric_patterns = data.get("metrics")
    if metric_patterns is not None and not (
            isinstance(metric_patterns, list) and all(isinstance(p, str) for p in metric_patterns)):
        problems.append("metrics: must be a list of names or patterns such as 'stages.*' "
                        f"(got {metric_patterns!r})")
        metric_patterns = None
    record = data.get("record", False)
    if not isinstance(record, bool):
        problems.append(f"record: must be true or false (got {record!r})")
        record = False
    run_timeout = data.get("run_timeout")
    if run_timeout is not None and not (_is_number(run_timeout) and run_timeout > 0):
        problems.append(f"run_timeout: must be a finite number of wall seconds > 0 (got {_shown(run_timeout)})")
        run_timeout = None
    out = output if output is not None else data.get("output", f"runs/{name}.csv")
    if not isinstance(out, (str, Path)) or Path(out).suffix not in TABLE_SUFFIXES:
        problems.append(f"output: must be a .csv or .parquet file name (got {out!r})")
        out = f"runs/{name}.csv"
    elif "\0" in str(out):  # no file name can hold it
        problems.append(f"output: must not hold a NUL character (got {str(out)!r})")
        out = f"runs/{name}.csv"
    elif Path(out).suffix == ".parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            problems.append(f"output: {out} needs pyarrow (pip install pyarrow), or use a .csv file")
    figure = _figure(data.get("figure"), problems)
    if problems or base is None:
        raise ScenarioError(problems, source)

    points = _points(mode, axes, samples, seed, fixed, derived)  # at most MAX_POINTS: checked above
    # the first point whose derived values can be worked out (one of sqrt(v - 1) at v = 0.5 refused
    # the sweep, where the same failure at a later point was only a failed row: the order of an
    # axis's values decided whether the sweep ran)
    worked_out = [p for p in points if not p.problem] or points[:1]
    valid, (metric_keys, kinds, notices) = _first_valid_point(worked_out, base[0], base[1], source)
    problems += _invalid_axis_values(points, axes, len(fixed), base[0], base[1], valid)
    metrics = _select_metrics(metric_keys, metric_patterns, problems)
    sweep = Sweep(name=name, description=str(description), source=source, text=text, scene_text=base[0],
                  scene_source=base[1], mode=mode, axes=axes, derived=derived, fixed=fixed, metrics=metrics,
                  record=record, output=Path(out), figure=None, points=points, samples=samples, seed=seed,
                  metric_kinds={k: kinds[k] for k in metrics}, notices=notices,
                  run_timeout_s=None if run_timeout is None else float(run_timeout))
    sweep.figure = _figure_spec(figure, sweep, problems)
    if len({p.point_id for p in points}) < len(points):
        problems.append("axes: two points have the same values (random choices that repeat? "
                        "use fewer samples or more values)")
    if problems:
        raise ScenarioError(problems, source)
    return sweep


FIRST_POINT_TRIES = 20  # points whose scenes are loaded in turn for the first valid one


def _first_valid_point(points: list[Point], scene_text: str, scene_source: str,
                       source: str) -> tuple[Point, tuple[list[str], dict[str, str], list[str]]]:
    """The first of ``points`` (up to :data:`FIRST_POINT_TRIES`) whose scene loads, and its
    :func:`_first_point`: a point whose derived values make no scene is a row that fails (listed by a
    dry run), and an override axis's value that makes none is the sweep file's mistake
    (:func:`_invalid_axis_values`), not the sweep's refusal naming that point alone, which it was when
    it came first. When none loads, the first one's failure refuses the sweep (a key path no scene
    has, say)."""
    first: ScenarioError | None = None
    for point in points[:FIRST_POINT_TRIES]:
        try:
            return point, _first_point(point, scene_text, scene_source, source)
        except ScenarioError as exc:
            first = first or exc
    assert first is not None
    raise first


def _first_point(point: Point, scene_text: str, scene_source: str,
                 source: str) -> tuple[list[str], dict[str, str], list[str]]:
    """Validate the scene of ``point`` (so a wrong key path is reported before anything runs), and
    return the metric keys its components report, with their kinds (number or text), and its
    notices; a ScenarioError naming the point when its derived values or its scene fail
    (:func:`_first_valid_point` tries the points in turn)."""
    from cosim.runner import collect_metrics
    from cosim.scheduler import Simulation

    where = f"the first point ({point.label()})" if point.index == 0 else f"point {point.index} ({point.label()})"
    if point.problem:
        raise ScenarioError(f"{where}: {point.problem}", source)
    try:
        scene = loads(scene_text, scene_source, list(point.overrides))
    except ScenarioError as exc:
        raise ScenarioError([f"{where}: {p}" for p in exc.problems], source) from None
    metrics = collect_metrics(Simulation(scene))
    kinds = {k: "text" if isinstance(v, str) else "number" for k, v in metrics.items()}
    return list(metrics), kinds, scene.notices


def _invalid_axis_values(points: list[Point], axes: list[Axis], fixed: int, scene_text: str,
                         scene_source: str, valid: Point) -> list[str]:
    """A problem for each value of an override axis that breaks its own key's rule (a radius of -1:
    ``components.stone.radius: must be > 0 m``), loaded with the other axes at the first point's
    values: such a value makes no scene in any point, and is the sweep file's mistake, said before
    anything runs, where only the first point's was (the others became failed rows, and the sweep
    exited 0). A value refused only for what it does with the other settings (a body's ``every``
    against its ground's, a step against a stable step the speed sets) may be valid beside the other
    axes' other values, so its points stay failed rows where they are invalid. One scene a value,
    not one a point; at most ``VALUES_CHECKED`` in all (:func:`_shares`). ``fixed``: how many of a
    point's overrides come before its axes' (``set``, ``--set``); ``valid``: the point whose scene
    was loaded (:func:`_first_valid_point`), whose values are the others' and are not checked again."""
    checked: list[tuple[Axis, int, list[Any]]] = []  # an axis, its place in the overrides, its other values
    place = fixed
    for axis in axes:
        if axis.kind != "override":
            continue
        held = axis.values if axis.sampler is None else [p.values[axis.name] for p in points]
        others = {_same_value(v): v for v in held}
        others.pop(_same_value(valid.values[axis.name]), None)
        values = list(others.values())
        if values and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values):
            values.sort()  # the ends (a bound the scene's rules set) among those checked
        checked.append((axis, place, values))
        place += 1
    problems = []
    at = "their first values" if valid is points[0] else f"point {valid.index}'s values"
    with_others = f" (the other axes at {at})" if len(axes) > 1 else ""
    shares = _shares([len(values) for _, _, values in checked], VALUES_CHECKED)
    for (axis, place, values), share in zip(checked, shares, strict=True):
        for value in _spread(values, share):
            overrides = list(valid.overrides)
            overrides[place] = f"{axis.name}={yaml_value(value)}"
            try:
                loads(scene_text, scene_source, overrides)
            except ScenarioError as exc:
                own = [p for p in exc.problems if p.startswith((f"{axis.name}:", f"{axis.name}."))]
                if own:
                    problems.append(f"axes.{axis.name}: {_shown(value)} makes an invalid scene{with_others}: "
                                    + "; ".join(own))
    return problems


def _shares(counts: list[int], budget: int) -> list[int]:
    """How many of each axis's ``counts`` values to check within ``budget`` in all: every value of an
    axis that has fewer than an even share, the rest shared evenly among the others."""
    shares = [0] * len(counts)
    left = budget
    by_count = sorted(range(len(counts)), key=lambda i: counts[i])
    for k, i in enumerate(by_count):
        shares[i] = min(counts[i], left // (len(counts) - k))
        left -= shares[i]
    return shares


def _spread(values: list[Any], share: int) -> list[Any]:
    """``share`` of ``values`` spread evenly over them, the first and the last among them."""
    if share >= len(values):
        return values
    if share <= 1:
        return values[-1:] if share else []
    return [values[i] for i in sorted({round(k * (len(values) - 1) / (share - 1)) for k in range(share)})]


def _select_metrics(keys: list[str], patterns: list[str] | None, problems: list[str]) -> list[str]:
    if patterns is None:
        return keys
    chosen: list[str] = []
    for pattern in patterns:
        matched = [k for k in keys if fnmatch.fnmatchcase(k, pattern)]
        if not matched:
            problems.append(f"metrics: {pattern!r} matches no metric of the scene "
                            f"(its components report: {', '.join(keys) or 'none'})")
        chosen += [k for k in matched if k not in chosen]
    return chosen


def _figure_spec(spec: dict[str, Any] | None, sweep: Sweep, problems: list[str]) -> FigureSpec | None:
    names = [a.name for a in sweep.axes]
    numeric = [m for m in sweep.metrics if sweep.metric_kinds.get(m) == "number"]
    if spec is None:
        if not numeric:
            return None
        return FigureSpec(numeric[0], names[0], names[1] if len(names) > 1 else None)
    metric = spec.get("metric", numeric[0] if numeric else None)
    if metric is None or metric not in sweep.metrics:
        kept = ", ".join(sweep.metrics) or "none"
        problems.append(f"figure.metric: {metric!r} is not a kept metric (kept: {kept})")
    elif sweep.metric_kinds.get(metric) != "number":
        problems.append(f"figure.metric: {metric!r} is text, not a number")
    x = spec.get("x", names[0])
    y = spec.get("y", names[1] if len(names) > 1 and names[1] != x else None)
    for key, value in (("x", x), ("y", y)):
        if value is not None and value not in names:
            problems.append(f"figure.{key}: {value!r} is not an axis (axes: {', '.join(names)})")
    if x is not None and x == y:
        problems.append(f"figure.y: must differ from x (both {x!r})")
    ref = spec.get("reference") or {}
    return FigureSpec(str(metric), str(x), y, spec.get("threshold"), str(ref.get("label", "reference")),
                      tuple(tuple(p) for p in ref.get("points", [])))


def load_sweep(path: str | Path, overrides: list[str] | None = None,
               output: str | Path | None = None) -> Sweep:
    """Parse and validate a sweep file (its ``scene:`` is looked up beside it); raises ScenarioError."""
    path = Path(path)
    return loads_sweep(read_input(path), str(path), path.parent, overrides, output)
