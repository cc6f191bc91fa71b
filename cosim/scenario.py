"""Scenes: YAML turned into typed, validated configuration before anything runs.

A scene::

    name: ping_pong
    dt: 0.001                 # base step [s]
    until: 1.0                # end time [s]
    on_unstable: error        # or substep (per component too)
    components:
      a: {type: Counter, every: 1, gain: 2.0}      # type, every | step, on_unstable, then parameters
      b: {type: tests.toys:Echo}
    connections:
      - a.out -> b.x                               # direct edge (Gauss-Seidel)
      - {from: b.y, to: a.x, delay: 1, initial: {value: 0.0}}
    record: {checkpoint_every: 0.5, channels: ["/a/*"], every: 1}

:func:`load` / :func:`loads` report every problem at once, each with its YAML path, as one
:class:`ScenarioError`. ``overrides`` (``key.path=value`` strings, the CLI's ``--set``) are applied to
the YAML data first, so they are validated like the file itself.
"""

from __future__ import annotations

import fnmatch
import heapq
import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from cosim.codec.json_codec import CodecError, codec_for, json_kind
from cosim.component import MAX_SUBSTEPS, Component, OnUnstable, step_and_bound, substep_count
from cosim.errors import NO_ROOM, ScenarioError, one_line
from cosim.messages import Message
from cosim.params import (
    UNQUOTED_NAMES,
    as_written,
    beyond_float,
    build,
    number_text,
    show_value,
    whole_digits,
    whole_number,
)
from cosim.registry import COMPONENT_KEYS, UnknownComponentType, check_contract, resolve
from cosim.timebase import NS_PER_S, exact_seconds, seconds_to_ns, ticks_reaching

NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}")  # a component name: it becomes channel names
# the first part of the framework's and the viewer's own channels (/cosim/status, /perf/tick,
# /scene/<body>, /tf, /log): a component of that name would write its outputs onto them (one named
# cosim with a port status made the recording unreadable; one named scene lost its body's looks)
RESERVED_NAMES = ("cosim", "perf", "scene", "tf", "log")
# the viewer's fixed frame: a body's frame is named after it, and one named world moved the world
# (/tf world -> world: the trail, the arrows and the water drawn in a moving frame)
RESERVED_FRAMES = ("world",)
SCENE_NAME_RE = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,99}")  # a scene name: it becomes a file name
MIN_STEP_NS = 1  # the clock's tick: no step is shorter
MAX_TIME_NS = 2**63 - 1  # MCAP's times are 64-bit nanoseconds: no time goes past this (about 292 years)
MAX_SCENE_BYTES = 4 << 20  # a scene file larger than this is refused before it is read
MAX_DEPTH = 64  # deepest nesting of mappings and lists in a scene
MAX_VALUES = 1_000_000  # most values a scene may hold, counting every repeat of a YAML alias
MEMORY_SHARE = 0.9  # a scene whose components' estimated memory exceeds this share of the machine's is refused
EDGE_RE = re.compile(r"^\s*(\w+)\.(\w+)\s*->\s*(\w+)\.(\w+)\s*$")
END_RE = re.compile(r"^\s*(\w+)\.(\w+)\s*$")  # one end of a connection written as a mapping: component.port
TOP_KEYS = {"name", "description", "dt", "until", "on_unstable", "components", "connections", "record"}
ON_UNSTABLE = ("error", "substep")


@dataclass
class ComponentConfig:
    """One component of a scene: its name, class, rate and validated parameters."""

    name: str
    type_name: str
    cls: type[Component]
    every: int
    params: Any
    on_unstable: OnUnstable

    def build(self) -> Component:
        return self.cls(self.name, self.params)


@dataclass(frozen=True)
class Connection:
    """An edge ``source.source_port -> target.target_port``; ``delay`` 0 (direct) or 1."""

    source: str
    source_port: str
    target: str
    target_port: str
    delay: int = 0
    initial: Message | None = None

    def __str__(self) -> str:
        arrow = "-(delay)->" if self.delay else "->"
        return f"{self.source}.{self.source_port} {arrow} {self.target}.{self.target_port}"


@dataclass
class RecordConfig:
    """What the recorder writes: channel patterns (fnmatch, None = all), every n-th message of each
    physics channel (all of an event output's: stage changes, skips), component checkpoints every
    ``checkpoint_every`` seconds (0 = never), and viewer channels at ``visual_rate`` frames per second
    (0 = none)."""

    channels: list[str] | None = None
    every: int = 1
    checkpoint_every: float = 1.0
    visual_rate: float = 30.0


RECORD_NUMBERS = ("every", "checkpoint_every", "visual_rate")  # RecordConfig's numbers, range-checked


def _plain_number(value: Any) -> bool:
    """A finite int or float, not a bool (YAML's true is no number of steps; a NaN is said as such);
    an integer of any size (one beyond a float's range is refused by its own range)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    return isinstance(value, int) or math.isfinite(value)


@dataclass
class Scene:
    """A validated scene. ``order`` is the execution order within a tick."""

    name: str
    description: str
    dt_ns: int
    until_ns: int
    components: dict[str, ComponentConfig]
    connections: list[Connection]
    record: RecordConfig
    order: list[str]
    text: str
    data: dict[str, Any]
    source: str = "<string>"
    overrides: list[str] = field(default_factory=list)
    base_dir: str = "."  # absolute folder that relative file names in the scene (an FMU's path) start from
    notices: list[str] = field(default_factory=list)  # its components' notices (Component.notices), with their keys

    def instantiate(self) -> dict[str, Component]:
        """Fresh components, built from the parameters (in execution order)."""
        return {name: self.components[name].build() for name in self.order}

    @property
    def dt(self) -> float:
        return self.dt_ns / NS_PER_S

    def step_of(self, name: str) -> float:
        """The step [s] component ``name`` takes (its ``every`` base steps), as the scheduler gives it."""
        return self.dt_ns * self.components[name].every / NS_PER_S


# --- YAML with duplicate-key detection -----------------------------------------------------------

class _Strict:
    """What both of this module's loaders share: duplicate mapping keys recorded instead of the last
    one silently kept, and a value that cannot be built said at its line."""

    duplicates: list[str]

    def construct_object(self, node: yaml.Node, deep: bool = False) -> Any:
        """A value as SafeLoader builds it; one it cannot build (``!!bool maybe``, the date
        ``2024-13-45``) is a YAML error at its line, not an exception from inside PyYAML."""
        try:
            return super().construct_object(node, deep=deep)
        except (ValueError, TypeError, KeyError, AttributeError, OverflowError) as exc:
            what = repr(node.value) if isinstance(node, yaml.ScalarNode) else f"a {node.id}"
            why = f" ({exc})" if isinstance(exc, ValueError) else ""  # (month must be in 1..12)
            raise yaml.constructor.ConstructorError(
                None, None, f"cannot read {what} as {node.tag.rpartition(':')[2]}{why}", node.start_mark) from None


class _StrictLoader(_Strict, yaml.SafeLoader):
    """SafeLoader that records duplicate mapping keys instead of silently keeping the last one."""


_MERGE_TAG = "tag:yaml.org,2002:merge"  # the key << (YAML 1.1 merge): its mappings' pairs join this one
_VALUE_TAG = "tag:yaml.org,2002:value"  # the key = (YAML 1.1 default value), read as the text '=' as SafeLoader does


def _construct_mapping(loader: _StrictLoader, node: yaml.Node, deep: bool = False) -> dict:
    """A mapping as SafeLoader reads it, merge keys included (``<<: *base`` or ``<<: [*a, *b]``, the
    earlier of several winning), with each key written twice recorded in ``loader.duplicates``. A key
    written beside a merge overrides the merged one (YAML's rule), which is no duplicate.

    The merge is done here, not by SafeLoader's ``flatten_mapping``: that one rewrites the merged
    mapping's node in place, after which the keys it merged itself could no longer be told from the
    ones written in it, and its overrides would be reported as duplicates."""
    if not isinstance(node, yaml.MappingNode):  # e.g. `!!map text`
        raise yaml.constructor.ConstructorError(None, None, f"expected a mapping, found a {node.id}", node.start_mark)
    merged: dict[Any, Any] = {}
    written: dict[Any, Any] = {}
    merges = 0
    for key_node, value_node in node.value:
        if key_node.tag == _MERGE_TAG:
            merges += 1
            if merges == 2:  # (SafeLoader takes both; a key twice is a duplicate all the same)
                loader.duplicates.append(f"line {key_node.start_mark.line + 1}: duplicate key '<<' (merge "
                                         "several mappings with one key: <<: [*a, *b])")
            for source in reversed(_merge_sources(node, value_node)):  # the first listed wins: applied last
                value = loader.construct_object(source, deep=True)
                if not isinstance(value, dict):
                    raise yaml.constructor.ConstructorError(
                        "while reading a mapping", node.start_mark,
                        f"a merge (<<) takes a mapping, found a {type(value).__name__}", source.start_mark)
                merged.update(value)
            continue
        if key_node.tag == _VALUE_TAG:
            key_node.tag = "tag:yaml.org,2002:str"
        key = loader.construct_object(key_node, deep=deep)
        try:  # a list or mapping as a key (a set of them would fail on it as an internal error)
            hash(key)
        except TypeError:
            raise yaml.constructor.ConstructorError(
                "while reading a mapping", node.start_mark,
                f"found a key that is a {type(key).__name__}, not a name", key_node.start_mark) from None
        if key in written:
            written_as = key_node.value if isinstance(key_node, yaml.ScalarNode) else key  # `on`, not True
            read_as = f" (read as {key!r}, as a key before it)" if written_as != key else ""
            loader.duplicates.append(f"line {key_node.start_mark.line + 1}: duplicate key {written_as!r}{read_as}")
        written[key] = loader.construct_object(value_node, deep=deep)
    return {**merged, **written} if merged else written


def _merge_sources(node: yaml.MappingNode, value_node: yaml.Node) -> list[yaml.MappingNode]:
    """The mappings a merge key's value names: one mapping, or a list of them."""
    sources = value_node.value if isinstance(value_node, yaml.SequenceNode) else [value_node]
    for source in sources:
        if not isinstance(source, yaml.MappingNode):
            raise yaml.constructor.ConstructorError(
                "while reading a mapping", node.start_mark,
                f"a merge (<<) takes a mapping or a list of mappings, found a {source.id}", source.start_mark)
    return sources


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)

# Numbers as YAML 1.2's core schema reads them, not as PyYAML's YAML 1.1: 5e-4 and 1e21 are floats
# (1.1 wants a dot in a float), 0o17 octal and 0x10 hexadecimal; 1:30 and 12:30:00 are text (1.1:
# base-60 numbers, 90 and 45000), as are 1_000, 0b101 and -0x10; 017, octal 15 to 1.1 and 17 to 1.2,
# is refused (_construct_int)
_INT_TAG, _FLOAT_TAG = "tag:yaml.org,2002:int", "tag:yaml.org,2002:float"
_INT_1_2 = re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$")
_LEADING_ZERO = re.compile(r"[-+]?0[0-9]+")  # 017: octal to YAML 1.1, decimal to YAML 1.2
_FLOAT_1_2 = re.compile(r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
                        r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$")
_StrictLoader.yaml_implicit_resolvers = {
    first: [(tag, regexp) for tag, regexp in resolvers if tag not in (_INT_TAG, _FLOAT_TAG)]
    for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()}
_StrictLoader.add_implicit_resolver(_INT_TAG, _INT_1_2, list("-+0123456789"))  # before float: 1 is an int
_StrictLoader.add_implicit_resolver(_FLOAT_TAG, _FLOAT_1_2, list("-+0123456789."))


def _construct_int(loader: _StrictLoader, node: yaml.Node) -> int:
    """A YAML 1.2 integer (also one tagged ``!!int``): decimal, ``0o`` octal or ``0x`` hexadecimal."""
    text = loader.construct_scalar(node)
    if not isinstance(text, str) or not _INT_1_2.fullmatch(text):
        raise yaml.constructor.ConstructorError(None, None, f"{text!r} is not an integer (YAML 1.2: decimal "
                                                "digits, 0o octal or 0x hexadecimal)", node.start_mark)
    if text[:2] in ("0o", "0x"):
        return int(text[2:], 8 if text[1] == "o" else 16)
    if _LEADING_ZERO.fullmatch(text):
        # YAML 1.1 (PyYAML, and scenes written before) reads 017 as octal 15, YAML 1.2 as 17: which one
        # was meant cannot be told, so neither is taken
        digits = text.lstrip("+-")
        octal = f"{int(digits, 8)}" if set(digits) <= set("01234567") else "no number"
        raise yaml.constructor.ConstructorError(
            None, None, f"{text!r}: an integer with a leading zero is {int(text)} in YAML 1.2 and {octal} in "
            f"YAML 1.1 (octal); write {int(text)}, or 0o{digits.lstrip('0') or '0'} for octal", node.start_mark)
    try:
        return int(text)
    except ValueError:  # more digits than Python reads (sys.get_int_max_str_digits)
        raise yaml.constructor.ConstructorError(None, None, f"an integer of {len(text.lstrip('+-'))} digits is "
                                                "too long to read", node.start_mark) from None


def _construct_float(loader: _StrictLoader, node: yaml.Node) -> float:
    """A YAML 1.2 float (also one tagged ``!!float``, which may be written as an integer)."""
    text = loader.construct_scalar(node)
    if not isinstance(text, str) or not (_FLOAT_1_2.fullmatch(text) or _INT_1_2.fullmatch(text)):
        raise yaml.constructor.ConstructorError(None, None, f"{text!r} is not a number", node.start_mark)
    if text.lower().lstrip("+-") == ".inf":
        return -math.inf if text.startswith("-") else math.inf
    if text.lower() == ".nan":
        return math.nan
    if text[:2] in ("0o", "0x"):
        return float(_construct_int(loader, node))
    return float(text)  # (a 1e999 is inf, as YAML's own readers make it)


_StrictLoader.add_constructor(_INT_TAG, _construct_int)
_StrictLoader.add_constructor(_FLOAT_TAG, _construct_float)

# A large scene read by libyaml's parser (PyYAML's Python scanner took 4 s for 100,000 values, 90% of
# the load), built by the same constructors and resolvers; only a clean read is taken from it: any
# error or duplicate key is read again by the Python loader, whose messages the scenes' errors are.
# libyaml's composer recurses in C without a limit (200,000 nested '[' crash the process), so it is
# given only text whose nesting is surely far below C_NESTING_LIMIT (_nesting_bound).
FAST_YAML_BYTES = 65_536  # [characters] smaller scenes read in milliseconds either way
C_NESTING_LIMIT = 1000
_NON_PRINTABLE = yaml.reader.Reader.NON_PRINTABLE  # (the Python reader says where such a character is)

if getattr(yaml, "__with_libyaml__", False):
    class _FastStrictLoader(_Strict, yaml.CSafeLoader):
        """libyaml's parser with :class:`_StrictLoader`'s constructors and resolvers."""

    _FastStrictLoader.yaml_constructors = _StrictLoader.yaml_constructors
    _FastStrictLoader.yaml_implicit_resolvers = _StrictLoader.yaml_implicit_resolvers
else:  # pragma: no cover - PyYAML built without libyaml
    _FastStrictLoader = None


def _nesting_bound(text: str) -> int:
    """An upper bound of how deeply ``text``'s YAML nests: the deepest run of flow brackets (counted
    in quoted text too, which only raises it) plus, for the block collections, twice a line's
    indentation plus one, plus the indicators on it ('-', '?', ':'), which opens at most as many
    block levels as that (a mapping's sequence may share its key's column, each such level one
    indicator on its line)."""
    codes = np.frombuffer(text.encode("utf-8", "surrogatepass"), dtype=np.uint8)
    step = np.zeros(256, dtype=np.int64)
    step[[ord("["), ord("{")]] = 1
    step[[ord("]"), ord("}")]] = -1
    flow = int(np.cumsum(step[codes]).max(initial=0))
    block = 0
    for line in text.split("\n"):
        stripped = line.lstrip(" ")
        indicators = stripped.count("-") + stripped.count(":") + stripped.count("?")
        block = max(block, 2 * (len(line) - len(stripped) + 1) + indicators)
    return flow + block


def _read_fast(text: str) -> tuple[bool, Any]:
    """(True, the data) where libyaml reads ``text`` cleanly and safely, else (False, None): the
    Python loader then reads it (and says what is wrong with it)."""
    if (_FastStrictLoader is None or len(text) < FAST_YAML_BYTES or _NON_PRINTABLE.search(text)
            or _nesting_bound(text) > C_NESTING_LIMIT):
        return False, None
    try:
        loader = _FastStrictLoader(text)
    except Exception:  # whatever it is, the Python loader says it
        return False, None
    loader.duplicates = []
    try:
        data = loader.get_single_data()
    except Exception:  # as above
        return False, None
    finally:
        loader.dispose()
    return (False, None) if loader.duplicates else (True, data)


class _QuotingDumper(yaml.SafeDumper):
    """SafeDumper that quotes every text YAML 1.2's numbers would read as a number, as well as what
    YAML 1.1 would: its own resolvers are YAML 1.1's, and '1e5' or '0o17' went out unquoted and came
    back as 100000.0 and 15 (a sweep's inline scene named "1e5" was refused as a number)."""


_QuotingDumper.add_implicit_resolver(_INT_TAG, _INT_1_2, list("-+0123456789"))
_QuotingDumper.add_implicit_resolver(_FLOAT_TAG, _FLOAT_1_2, list("-+0123456789."))


def dump_yaml(value: Any, **options: Any) -> str:
    """YAML text of ``value`` (plain data) that :func:`read_yaml` reads back as the same value;
    ``options``: yaml.dump's."""
    return yaml.dump(value, Dumper=_QuotingDumper, **options)


def _shape_problem(data: Any) -> str | None:
    """Why ``data`` is too deep or too large to be a scene (None when it is fine). Aliases are
    counted as often as they are used, each shared node once (so the walk itself stays cheap)."""
    sizes: dict[int, int] = {}
    stack: list[tuple[Any, int, bool]] = [(data, 1, False)]
    while stack:
        node, depth, done = stack.pop()
        if not isinstance(node, (dict, list)):
            continue
        if depth > MAX_DEPTH:
            return f"is nested more than {MAX_DEPTH} levels deep"
        children = list(node.values()) if isinstance(node, dict) else node
        if done:
            sizes[id(node)] = 1 + sum(sizes.get(id(c), 1) for c in children)
            if sizes[id(node)] > MAX_VALUES:
                return f"holds more than {MAX_VALUES:,} values (counting each use of a YAML alias)"
            continue
        if id(node) in sizes:
            continue
        stack.append((node, depth, True))
        stack.extend((c, depth + 1, False) for c in children if isinstance(c, (dict, list)) and id(c) not in sizes)
    return None


def read_yaml(text: str, source: str) -> Any:
    """YAML text to plain data, refusing duplicate keys; errors as one ScenarioError with the line."""
    clean, data = _read_fast(text)
    if clean:
        problem = _shape_problem(data)
        if problem is not None:
            raise ScenarioError(f"the YAML {problem}", source)
        return data
    try:
        loader = _StrictLoader(text)
    except yaml.reader.ReaderError as exc:  # a character YAML does not allow, found as the reader starts
        line = text.count("\n", 0, exc.position) + 1
        column = exc.position - (text.rfind("\n", 0, exc.position) + 1) + 1
        code = exc.character if isinstance(exc.character, int) else ord(exc.character)  # (an int for text)
        raise ScenarioError(f"YAML syntax error: line {line}, column {column}: the character U+{code:04X} is not "
                            "allowed in YAML", source) from None
    except yaml.YAMLError as exc:
        raise ScenarioError(f"YAML syntax error: {getattr(exc, 'problem', None) or exc}", source) from None
    loader.duplicates = []
    try:
        data = loader.get_single_data()
    except RecursionError:
        raise ScenarioError(f"YAML nested too deeply to read (at most {MAX_DEPTH} levels)", source) from None
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        problem = getattr(exc, "problem", None) or str(exc)
        raise ScenarioError(f"YAML syntax error: {where}{problem}", source) from None
    finally:
        loader.dispose()
    if loader.duplicates:
        raise ScenarioError(loader.duplicates, source)
    problem = _shape_problem(data)
    if problem is not None:
        raise ScenarioError(f"the YAML {problem}", source)
    return data


def yaml_value(text: str) -> Any:
    """One value as a scene reads it (``--set key=VALUE``): YAML, with 1.2 floats; text that is not
    YAML stays text."""
    try:
        loader = _StrictLoader(text)
    except yaml.YAMLError:
        return text
    loader.duplicates = []
    try:
        value = loader.get_single_data()
    except (yaml.YAMLError, RecursionError):
        return text
    finally:
        loader.dispose()
    return text if _shape_problem(value) is not None else value


def _parse_yaml(text: str, source: str) -> dict[str, Any]:
    data = read_yaml(text, source)
    if data is None:
        raise ScenarioError("the scene is empty (expected a mapping with dt, until, components)", source)
    if not isinstance(data, dict):
        raise ScenarioError(f"the scene must be a mapping (got {json_kind(data)})", source)
    if "axes" in data and "scene" in data and "components" not in data:
        # said as one thing, by every command that loads a scene (cosim run listed its keys one by one
        # as unknown, where cosim validate named the file for what it is)
        raise ScenarioError(f"this is a sweep file (it has scene: and axes:, no components:): run it with "
                            f"`cosim sweep {source}` (`--dry-run` checks it)", source)
    return data


# --- overrides -----------------------------------------------------------------------------------

def find_parent(data: Any, parts: list[str]) -> tuple[Any, str | None]:
    """The node holding the last of the key ``parts`` (mapping keys, or list indices as digits), or
    (None, problem) naming the first missing part and the keys known there."""
    node = data
    for depth, part in enumerate(parts[:-1]):
        if isinstance(node, dict) and part in node:
            node = node[part]
        elif isinstance(node, list) and whole_digits(part) and int(part) < len(node):
            node = node[int(part)]
        else:
            return None, f"{'.'.join(parts[: depth + 1])!r} ({_known_there(node)})"
    return node, None


def _known_there(node: Any) -> str:
    """What a key path may name inside ``node``: its keys, a list's indices, or that it holds none."""
    if isinstance(node, dict):
        return f"known there: {', '.join(map(str, node)) or 'none'}"
    if isinstance(node, list):
        if len(node) == 1:
            return "a list of 1 item: index 0"
        return f"a list of {len(node)} items: indices 0 to {len(node) - 1}" if node else "an empty list: no index"
    kind = ("null" if node is None else "true or false" if isinstance(node, bool) else "text" if isinstance(node, str)
            else "a number" if isinstance(node, int | float) else f"a {type(node).__name__}")
    return f"{kind}, which holds no keys"


def apply_overrides(data: dict[str, Any], overrides: list[str]) -> list[str]:
    """Apply ``a.b.c=value`` overrides (value parsed as YAML) in place; returns the problems."""
    problems = []
    for item in overrides:
        key, sep, raw = item.partition("=")
        if not sep or not key.strip():
            problems.append(f"--set {item!r}: expected key.path=value")
            continue
        value = yaml_value(raw)
        parts = key.strip().split(".")
        if len(parts) > 1 and parts[0] == "record" and data.get("record") is None:
            data["record"] = {}  # a scene without a record block records with the defaults: --record sets them
        node, missing = find_parent(data, parts)
        if missing is not None:
            problems.append(f"--set {key}: no such key {missing}")
            continue
        node = _own_path(data, parts)
        last = parts[-1]
        if isinstance(node, dict):
            node[last] = value
        elif isinstance(node, list) and whole_digits(last) and int(last) < len(node):
            node[int(last)] = value
        elif isinstance(node, list):
            problems.append(f"--set {key}: no such key {key!r} ({_known_there(node)})")
        else:
            problems.append(f"--set {key}: cannot set {last!r} inside a {type(node).__name__}")
    return problems


def _own_path(data: dict[str, Any], parts: list[str]) -> Any:
    """The node holding the last of the key ``parts`` (which :func:`find_parent` found), after each
    mapping and list on the way to it is replaced by a copy of its own. YAML aliases (``b: *a``) and
    merges (``<<: *base``) share one mapping between several places: an override written into the
    shared one would change every place that uses it, where it names one."""
    node: Any = data
    for part in parts[:-1]:
        key: Any = int(part) if isinstance(node, list) else part
        child = node[key]
        if isinstance(child, dict | list):
            child = type(child)(child)
            node[key] = child
        node = child
    return node


# --- validation ----------------------------------------------------------------------------------

def _seconds_text(ns: int) -> str:
    """A time in whole nanoseconds as seconds, in as many digits as it takes (``0.0015``)."""
    return repr(ns / NS_PER_S)


def _whole_multiple(value: float, value_ns: int, dt_ns: int) -> bool:
    """Whether a time of ``value`` seconds, ``value_ns`` in whole nanoseconds, is a whole number
    (>= 1) of base steps: in nanoseconds exactly, and in seconds to a relative 1e-9 (the nanoseconds
    are rounded to 1e-6 of themselves: 0.0010000001 s is 1 ms in them, yet no multiple of 1 ms)."""
    steps, rest = divmod(value_ns, dt_ns)
    return steps >= 1 and rest == 0 and abs(value * NS_PER_S / dt_ns - steps) <= 1e-9 * steps


def _nearest_multiples(value: float, value_ns: int, dt_ns: int) -> str:
    """The two whole multiples of the base step around a time of ``value`` seconds, ``value_ns`` in
    whole nanoseconds (those of them from one step to the largest time), for a problem:
    ``0.001 s or 0.0015 s``."""
    lower = value_ns // dt_ns * dt_ns
    if lower == value_ns and value * NS_PER_S < value_ns:
        lower -= dt_ns  # whole in nanoseconds, a little below them in seconds: between the one below and it
    near = [m for m in (lower, lower + dt_ns) if dt_ns <= m <= MAX_TIME_NS]
    return " or ".join(f"{_seconds_text(m)} s" for m in near)


def _range_text(low_ns: int) -> str:
    return f"between {low_ns / NS_PER_S:g} s and {MAX_TIME_NS / NS_PER_S:.3g} s"


def _beside_range(value: Any) -> str:
    """``value`` as a time refused for its range: in short, unless the short text would read as a
    time within it (9223372036.854775807 s, a hair over the largest, read 9.22337e+09 s), then whole,
    with the end of the range it passed, every digit."""
    text = number_text(value)
    try:
        shown = float(text)
    except ValueError:
        return text
    if not MIN_STEP_NS <= shown * NS_PER_S <= MAX_TIME_NS:
        return text
    if value * NS_PER_S > MAX_TIME_NS:
        return f"{value!r}, over the largest, {exact_seconds(MAX_TIME_NS)} s"
    return f"{value!r}, under the smallest, {exact_seconds(MIN_STEP_NS)} s"


def _seconds(data: dict, key: str, problems: list[str], *, required: bool, default: float = 0.0) -> int | None:
    if key not in data:
        if required:
            problems.append(f"{key}: missing (required, seconds)")
            return None
        return seconds_to_ns(default)
    return seconds_value(data[key], key, problems)


def seconds_value(value: Any, path: str, problems: list[str], *, zero: str | None = None) -> int | None:
    """A time [s] > 0 as whole nanoseconds, from one tick (1 ns) to the largest time a recording can
    hold; otherwise a problem naming the range. ``zero``: what a 0 means where it is allowed too
    (e.g. "no checkpoints"), said in the problem so that it states the whole rule."""
    if not _plain_number(value):
        base60 = isinstance(value, str) and re.fullmatch(r"[-+]?[0-9]+(?::[0-5]?[0-9])+(?:\.[0-9]*)?", value)
        hint = "; YAML 1.2 reads a base-60 time as text: write it in seconds" if base60 else ""
        problems.append(f"{path}: must be a number of seconds (got {show_value(value)}{hint})")
        return None
    if zero is not None and value == 0:
        return 0
    if value <= 0:
        rule = "> 0 s" if zero is None else f">= 0 s (0: {zero})"
        problems.append(f"{path}: must be {rule} (got {number_text(value)})")
        return None
    if not MIN_STEP_NS <= value * NS_PER_S <= MAX_TIME_NS:  # (exact for an integer of any size)
        below = " (shorter than the clock's 1 ns tick)" if value * NS_PER_S < MIN_STEP_NS else ""
        rule = _range_text(MIN_STEP_NS) if zero is None else f"0 ({zero}) or {_range_text(MIN_STEP_NS)}"
        problems.append(f"{path}: must be {rule}{below} (got {_beside_range(value)})")
        return None
    try:
        return seconds_to_ns(float(value), what=path)
    except ValueError:  # said with the path in front, as every other problem
        problems.append(f"{path}: must be a whole number of nanoseconds (got {value!r} s)")
        return None


def _component(name: str, spec: Any, dt_ns: int | None, default_unstable: str,
               problems: list[str], classes: dict[str, type[Component]], base_dir: Path) -> ComponentConfig | None:
    path = f"components.{name!r}" if not NAME_RE.fullmatch(str(name)) else f"components.{name}"
    if not NAME_RE.fullmatch(str(name)):
        problems.append(f"{path}: component names must be identifiers of at most 64 characters (letters, "
                        "digits, _; not starting with a digit): they become channel names")
        return None
    if name in RESERVED_NAMES:
        problems.append(f"{path}: {name!r} names the framework's or the viewer's own channels (/{name}...); a "
                        "component of that name would write its outputs among them: name it otherwise")
        return None
    if name in RESERVED_FRAMES:
        problems.append(f"{path}: {name!r} names the viewer's fixed frame, in which a body named so would move "
                        "everything drawn: name it otherwise")
        return None
    if not isinstance(spec, dict):
        problems.append(f"{path}: must be a mapping with a 'type' (got {spec!r})")
        return None
    type_name = spec.get("type")
    if not isinstance(type_name, str):
        problems.append(f"{path}.type: missing (required, a component type name)" if type_name is None
                        else f"{path}.type: must be a string (got {type_name!r})")
        return None
    try:
        cls = resolve(type_name)
    except UnknownComponentType as exc:
        problems.append(f"{path}.type: {exc}")
        return None
    classes[name] = cls  # its ports are known even if its parameters turn out invalid
    every = _rate(path, spec, dt_ns, problems)
    on_unstable = spec.get("on_unstable", default_unstable)
    if on_unstable not in ON_UNSTABLE:
        problems.append(f"{path}.on_unstable: must be one of 'error', 'substep' (got {on_unstable!r})")
    params_data = {k: v for k, v in spec.items() if k not in COMPONENT_KEYS}
    params = build(cls.Params, params_data, path, problems, tuple(sorted(COMPONENT_KEYS)))
    configured = cls.configure(params, path, base_dir, problems)  # ports that depend on the parameters
    if configured is None:
        del classes[name]
        return None
    if configured is not cls:  # a class made for these parameters (an FMU's ports) keeps the contract too
        try:
            check_contract(configured, type_name)
        except UnknownComponentType as exc:
            problems.append(f"{path}.type: {exc}")
            del classes[name]
            return None
    cls = classes[name] = configured
    if params is None or every is None:
        return None
    return ComponentConfig(name, type_name, cls, every, params, on_unstable)


def _rate(path: str, spec: dict, dt_ns: int | None, problems: list[str]) -> int | None:
    if "every" in spec and "step" in spec:
        problems.append(f"{path}: give either 'every' (base steps) or 'step' (seconds), not both")
        return None
    if "step" in spec:
        step = spec["step"]
        if isinstance(step, bool) or not isinstance(step, (int, float)) or not step > 0:
            problems.append(f"{path}.step: must be a positive number of seconds (got {step!r})")
            return None
        step_ns = seconds_value(step, f"{path}.step", problems)
        if step_ns is None or dt_ns is None:
            return None
        if not _whole_multiple(step, step_ns, dt_ns):
            # in full digits: 0.0010000001 s is no multiple of 0.001 s, which :g would print as both
            problems.append(f"{path}.step: {step!r} s is not a whole multiple of dt = {_seconds_text(dt_ns)} s "
                            f"(ratio {step * NS_PER_S / dt_ns:.12g}); rates must divide exactly: use "
                            f"{_nearest_multiples(step, step_ns, dt_ns)}")
            return None
        return step_ns // dt_ns
    every = whole_number(spec.get("every", 1))
    if isinstance(every, bool) or not isinstance(every, int):
        rounded = "; a non-integer rate ratio is not rounded" if isinstance(every, float) and math.isfinite(every) \
            else ""
        problems.append(f"{path}.every: must be a whole number of base steps (got {every!r}){rounded}")
        return None
    if every < 1:
        problems.append(f"{path}.every: must be >= 1 (got {every})")
        return None
    if dt_ns is not None and every * dt_ns > MAX_TIME_NS:
        problems.append(f"{path}.every: a step of {show_value(every)} x dt is longer than "
                        f"{MAX_TIME_NS / NS_PER_S:.3g} s")
        return None
    return every


LARGEST_INITIAL = 1e15  # |value| of an edge's initial field beyond which it can only overflow the run


def _out_of_range_field(msg: Message) -> str | None:
    """"FIELD: why" for the first field of an edge's initial message that is not finite or is beyond
    :data:`LARGEST_INITIAL` in size (a NaN force passed the scene and failed the run at t = 0), else None."""
    bad = msg.first_nonfinite()
    if bad is not None:
        value = getattr(msg, bad)
        return f"{bad}: must be finite (got {value.tolist() if hasattr(value, 'tolist') else value!r})"
    for name, value in vars(msg).items():
        if isinstance(value, bool | str) or value is None:
            continue
        try:
            largest = float(np.max(np.abs(np.asarray(value, dtype=float)))) if np.size(value) else 0.0
        except (TypeError, ValueError):
            continue
        if largest > LARGEST_INITIAL:
            return f"{name}: {largest:g} is beyond {LARGEST_INITIAL:g} (too large for any start of a run)"
    return None


def _connection(index: int, item: Any, components: dict[str, type[Component]], names: set[str],
                problems: list[str], types: dict[str, str]) -> Connection | None:
    """One edge, checked against the component classes (``components``: name -> class; ``types``:
    name -> the type name as the scene spells it)."""
    path = f"connections.{index}"  # as --set spells it
    initial_data = None
    delay = 0
    if isinstance(item, str):
        match = EDGE_RE.match(item)
        if not match:
            problems.append(f"{path}: expected 'source.port -> target.port' (got {item!r})")
            return None
        src, sport, dst, dport = match.groups()
    elif isinstance(item, dict):
        unknown = sorted(set(item) - {"from", "to", "delay", "initial"})
        if unknown:
            problems.append(f"{path}: unknown key {', '.join(map(repr, unknown))} "
                            "(known: from, to, delay, initial)")
        ends = []
        for key in ("from", "to"):
            value = item.get(key)
            match = END_RE.match(value) if isinstance(value, str) else None
            if not match:
                problems.append(f"{path}.{key}: expected 'component.port' (got {value!r})")
                return None
            ends.extend(match.groups())
        src, sport, dst, dport = ends
        delay = item.get("delay", 0)
        if isinstance(delay, bool) or not isinstance(delay, int):  # 1.0 is refused (it was kept as a float)
            rounded = "; a non-integer delay is not rounded" if isinstance(delay, float) else ""
            problems.append(f"{path}.delay: must be 0 or 1, a whole number of base steps (got "
                            f"{show_value(delay)}){rounded}")
            return None
        if delay not in (0, 1):
            problems.append(f"{path}.delay: must be 0 or 1 (got {show_value(delay)})")
            return None
        initial_data = item.get("initial")
    else:
        problems.append(f"{path}: expected 'a.port -> b.port' or a mapping with from/to (got {item!r})")
        return None

    ok = True
    for comp, port, side, path_key in ((src, sport, "outputs", "from"), (dst, dport, "inputs", "to")):
        if comp not in names:
            problems.append(f"{path}.{path_key}: unknown component {comp!r} (known: {', '.join(sorted(names))})")
            ok = False
        elif comp in components:
            ports = getattr(components[comp], side)
            if port not in ports:
                kind = "output" if side == "outputs" else "input"
                spelled = types.get(comp, components[comp].__name__)
                problems.append(f"{path}.{path_key}: {comp} ({spelled}) has no {kind} port "
                                f"{port!r} ({side}: {', '.join(ports) or 'none'})")
                ok = False
    if not ok or src not in components or dst not in components:
        return None
    out_type = components[src].outputs[sport].type
    in_type = components[dst].inputs[dport].type
    if out_type is not in_type:
        problems.append(f"{path}: type mismatch: {src}.{sport} sends {out_type.__name__} but {dst}.{dport} "
                        f"takes {in_type.__name__}")
        return None
    initial = None
    if delay:
        if initial_data is None:
            problems.append(f"{path}.initial: a delayed edge needs an initial value (fields of "
                            f"{out_type.__name__}: {', '.join(s.name for s in codec_for(out_type).fields)})")
            return None
        huge = _beyond_float_in(initial_data)
        if huge is not None:  # (the codec's float() of it was an internal OverflowError)
            where, value = huge
            # the field's own rule, as a value a float holds is told (_out_of_range_field)
            problems.append(f"{path}.initial{where}: {number_text(value)} is beyond {LARGEST_INITIAL:g} (too large "
                            "for any start of a run)")
            return None
        codec = codec_for(out_type)
        names = [spec.name for spec in codec.fields]
        fields = f"fields of {out_type.__name__}: {', '.join(names)}"
        if not isinstance(initial_data, dict):
            problems.append(f"{path}.initial: expected a mapping of the message's fields ({fields}), got "
                            f"{show_value(initial_data)}")
            return None
        # said here in the scene's words (each key on its path, the type as the scene's ports name it):
        # a key that was no text (5:, ~:) was an internal error, and the codec's own words named
        # 'cosim.Number'
        strangers = [key for key in initial_data if key not in names]
        for key in strangers:
            spelled = json_kind(key) if key is None or isinstance(key, bool) else str(key)
            problems.append(f"{path}.initial.{spelled}: unknown key ({fields})")
        missing = codec.missing(initial_data)
        if missing:
            problems.append(f"{path}.initial: missing {', '.join(missing)} ({fields})")
        if strangers or missing:
            return None
        try:
            initial = codec.from_dict(initial_data)
        except CodecError as exc:  # (about one field: said on it, path.initial.x_max: ...)
            problems.append(f"{path}.initial.{exc}" if exc.field else f"{path}.initial: {exc}")
            return None
        wrong = _out_of_range_field(initial)
        if wrong is not None:
            problems.append(f"{path}.initial.{wrong}")
            return None
    elif initial_data is not None:
        problems.append(f"{path}.initial: only a delayed edge (delay: 1) takes an initial value")
    return Connection(src, sport, dst, dport, delay, initial)


def _beyond_float_in(data: Any, where: str = "") -> tuple[str, int] | None:
    """(".FIELD[i]", value) of the first integer beyond a float's range in a message's fields, else None."""
    if beyond_float(data):
        return where, data
    items = data.items() if isinstance(data, dict) else enumerate(data) if isinstance(data, list) else ()
    for key, value in items:
        found = _beyond_float_in(value, f"{where}[{key}]" if isinstance(data, list) else f"{where}.{key}")
        if found is not None:
            return found
    return None


def _written_target(item: Any) -> tuple[str, str] | None:
    """The (component, port) a connection as written feeds, whether or not it is a valid one."""
    if isinstance(item, str):
        match = EDGE_RE.match(item)
        return (match.group(3), match.group(4)) if match else None
    value = item.get("to") if isinstance(item, dict) else None
    match = END_RE.match(value) if isinstance(value, str) else None
    return (match.group(1), match.group(2)) if match else None


def _check_inputs(components: dict[str, type[Component]], edges: list[Connection], problems: list[str],
                  written: set[tuple[str, str]] = frozenset()) -> None:  # type: ignore[assignment]
    """Inputs fed several times that do not add up, and required inputs left unconnected (those in
    ``written``, fed by a connection the scene writes but that was refused, are not said again)."""
    fed: dict[tuple[str, str], list[Connection]] = {}
    seen: dict[tuple[str, str, str, str, int], int] = {}
    for index, edge in enumerate(edges):
        key = (edge.source, edge.source_port, edge.target, edge.target_port, edge.delay)
        if key in seen:  # (an additive input summed it twice: a kick of 1 arrived as 2)
            problems.append(f"connections.{index}: repeats connections.{seen[key]} ({edge}): each connection "
                            "delivers its own copy; give it once")
            continue
        seen[key] = index
        fed.setdefault((edge.target, edge.target_port), []).append(edge)
    for (target, port), feeding in fed.items():
        port_type = components[target].inputs[port].type
        if len(feeding) > 1 and not port_type.additive:
            instead = components[target].one_source(port)
            problems.append(f"connections: input {target}.{port} is connected {len(feeding)} times "
                            f"({'; '.join(map(str, feeding))}) but {port_type.__name__} is not additive"
                            + (f"; {instead}" if instead else ""))
    for name, cls in components.items():
        for port, spec in cls.inputs.items():
            if spec.required and (name, port) not in fed and (name, port) not in written:
                problems.append(f"components.{name}: required input {port!r} ({spec.type.__name__}) "
                                "is not connected")


FRAMEWORK_SCHEMAS = {"cosim.Event": "/cosim/events", "cosim.RunStatus": "/cosim/status",
                     "cosim.PerfSample": "/perf/tick", "cosim.Checkpoint": "/cosim/checkpoint"}
"""The schema names a recording gives the framework's own channels (:mod:`cosim.record.recorder`)."""
FRAMEWORK_MODULE = "cosim.record.recorder"  # where the framework's own message types are declared


def schema_name(message_type: type[Message]) -> str:
    """The schema name a recording gives ``message_type`` (both codecs' ``cosim.<ClassName>``)."""
    return f"cosim.{message_type.__name__}"


def _check_schema_names(components: dict[str, type[Component]], problems: list[str]) -> None:
    """Two distinct message types on the scene's ports with one schema name (a user's ``Wrench``
    beside components.messages.Wrench), or one with the name of the framework's own channels: a
    recording keeps one schema under a name, and its channels of the other type could not be read
    back (the run said ok all the same)."""
    carriers: dict[str, dict[type[Message], list[str]]] = {}
    for name, cls in components.items():
        for port, spec in (*cls.inputs.items(), *cls.outputs.items()):
            carriers.setdefault(schema_name(spec.type), {}).setdefault(spec.type, []).append(f"{name}.{port}")
    for schema, types in carriers.items():
        said = [f"{t.__module__}.{t.__qualname__} (on {', '.join(ports)})" for t, ports in types.items()]
        own = [t for t in types if schema in FRAMEWORK_SCHEMAS and t.__module__ != FRAMEWORK_MODULE]
        if len(types) > 1:
            problems.append(f"components: message types {' and '.join(said)} have the same class name, "
                            f"which is their schema name {schema} in a recording: rename one of them")
        elif own:
            problems.append(f"components: message type {said[0]} has the schema name {schema} of the "
                            f"framework's own channel {FRAMEWORK_SCHEMAS[schema]}: rename it")


def execution_order(names: list[str], edges: list[Connection]) -> tuple[list[str], list[str] | None]:
    """Topological order along direct edges (ties in declaration order), or a cycle found."""
    direct = [e for e in edges if e.delay == 0]
    succ: dict[str, list[str]] = {n: [] for n in names}
    indeg = dict.fromkeys(names, 0)
    for e in direct:
        succ[e.source].append(e.target)
        indeg[e.target] += 1
    # the ready components by declaration index, a heap: sorting the list by names.index at every
    # release made a thousand components fed by one take 3.5 s, two thousand 24 s
    position = {n: k for k, n in enumerate(names)}
    order: list[str] = []
    ready = [position[n] for n in names if indeg[n] == 0]
    heapq.heapify(ready)
    while ready:
        node = names[heapq.heappop(ready)]
        order.append(node)
        for nxt in succ[node]:
            indeg[nxt] -= 1
            if indeg[nxt] == 0:
                heapq.heappush(ready, position[nxt])
    if len(order) == len(names):
        return order, None
    # report one cycle: every component left has a predecessor left (else it would have been
    # ordered), so walking back along predecessors must come round to a component it met before;
    # walking forward could end at one that merely waits for a cycle
    ordered = set(order)
    left = {n for n in names if n not in ordered}
    pred: dict[str, list[str]] = {n: [] for n in names}
    for e in direct:
        pred[e.target].append(e.source)
    start = next(n for n in names if n in left)
    path, node = [start], start
    while True:
        node = next(s for s in pred[node] if s in left)
        if node in path:
            loop = path[path.index(node):][::-1]  # forward along the edges
            first = min(range(len(loop)), key=lambda k: names.index(loop[k]))  # from the first declared
            loop = loop[first:] + loop[:first]
            return order, [*loop, loop[0]]
        path.append(node)


def machine_memory() -> int | None:
    """The machine's physical memory [bytes], or None where the system does not say."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return None


def _gb(n: float) -> str:
    return f"{n / 1e9:.3g} GB" if n >= 1e9 else f"{n / 1e6:.3g} MB"


def _check_memory(components: dict[str, ComponentConfig], problems: list[str]) -> None:
    """Refuse a scene whose components would need more memory than the machine has (each asked
    through :meth:`cosim.component.Component.estimate_bytes` before anything is built)."""
    needs = {}
    for name, cfg in components.items():
        try:
            needs[name] = max(0, int(cfg.cls.estimate_bytes(cfg.params)))
        except Exception:  # an estimate that fails is no estimate
            needs[name] = 0
    total, memory = sum(needs.values()), machine_memory()
    if memory and total > MEMORY_SHARE * memory:
        parts = ", ".join(f"{n} {_gb(b)}" for n, b in sorted(needs.items(), key=lambda kv: -kv[1]) if b)
        largest = max(needs, key=lambda n: needs[n])
        try:  # the advice of the component that holds the most
            advice = str(components[largest].cls.memory_advice(components[largest].params))
        except Exception:
            advice = "use a smaller grid"
        problems.append(f"components: the scene needs about {_gb(total)} of memory ({parts}), more than this "
                        f"machine's {_gb(memory)} allows ({MEMORY_SHARE:.0%}); {advice}")


_FAILED = object()  # what _asked gives for a component's hook that raised (its problem said)


def _asked(name: str, what: str, hook: Callable[[], Any], problems: list[str]) -> Any:
    """``hook()``, a question the scene's check asks component ``name`` (its stable step, an input's
    age bound, the outputs it needs answered); if its code raises, the problem said on the
    component's key and _FAILED (a user component's max_stable_step raising was an internal error of
    cosim's, the component unnamed, exit 1, where a failing setup is said on its key)."""
    try:
        return hook()
    except Exception as exc:
        problems.append(f"components.{name}: its {what} failed ({type(exc).__name__}: "
                        f"{one_line(str(exc)) or '(no message)'})")
        return _FAILED


def _asked_of_each(built: dict[str, Component], hook: str, problems: list[str]) -> dict[str, Any]:
    """Each component's answer to its method ``hook`` (``needed_outputs``, ``answers``), asked once
    for the checks that use it; a component whose hook raised is said (:func:`_asked`) and left out."""
    answers = {}
    for name, comp in built.items():
        value = _asked(name, f"{hook}()", getattr(comp, hook), problems)
        if value is not _FAILED:
            answers[name] = value
    return answers


def _check_stability(scene: Scene, built: dict[str, Component], problems: list[str]) -> None:
    for name, comp in built.items():
        bound = _asked(name, "max_stable_step()", comp.max_stable_step, problems)
        cause = _asked(name, "stable_step_cause()", comp.stable_step_cause, problems)
        if bound is _FAILED or cause is _FAILED:
            continue
        problems.extend(f"components.{name}: {problem}"
                        for problem in _step_problems(scene, name, bound, later=False, cause=cause))


def _step_problems(scene: Scene, name: str, bound: float, later: bool, cause: str = "") -> list[str]:
    """The problem with component ``name``'s step against a stable step ``bound`` [s], as the run
    would find it: over it under ``on_unstable: error``, or needing more than MAX_SUBSTEPS substeps
    under ``on_unstable: substep``; ``later``: a bound the component will need once the run is under
    way (:meth:`~cosim.component.Component.start_stable_step`), else the one it starts with. ``cause``:
    what sets the bound, if a parameter does (:meth:`~cosim.component.Component.stable_step_cause`)."""
    cfg = scene.components[name]
    step = scene.dt * cfg.every
    if bound >= step:
        return []
    when = "once the run is under way" if later else "from the start"
    when += f", {cause}" if cause else ""
    if not bound > 0:  # (0, negative or NaN: a substep count would divide by it)
        return [f"its stable step {when} is {bound!r} s: no step can be stable"]
    if cfg.on_unstable == "error":
        step_said, bound_said = step_and_bound(step, bound)
        if not later:
            set_by = f" ({cause})" if cause else ""
            return [f"step {step_said} s exceeds its stable step {bound_said} s{set_by} (on_unstable: error); lower "
                    "dt or every, or set on_unstable: substep"]
        return [f"step {step_said} s exceeds the stable step {bound_said} s it will need once the run is under "
                f"way (on_unstable: error); lower dt or every, or set on_unstable: substep"]
    substeps = math.ceil(step / bound)
    if substeps > MAX_SUBSTEPS:  # (the run would fail at its first step: 14557 substeps of a 60 s step)
        return [f"will need {substep_count(substeps)} substeps of its step {step:.6g} s (stable step {bound:.3g} s "
                f"{when}), more than the limit {MAX_SUBSTEPS}; lower dt or every"]
    return []


def _check_freshness(scene: Scene, built: dict[str, Component], problems: list[str]) -> None:
    """Each input port whose component bounds its age (:meth:`~cosim.component.Component.input_max_age`)
    is fed at least that often."""
    for edge in scene.connections:
        target = built[edge.target]
        bound = _asked(edge.target, f"input_max_age({edge.target_port!r})",
                       lambda target=target, port=edge.target_port: target.input_max_age(port), problems)
        if bound is None or bound is _FAILED:
            continue
        max_age, param_name = bound
        held = scene.dt * (scene.components[edge.source].every + edge.delay)  # how long each message stays
        if held > max_age * (1.0 + 1e-9):
            most = math.floor(max_age / scene.dt * (1.0 + 1e-9)) - edge.delay
            faster = (f"components.{edge.source}.every at most {most}" if most >= 1
                      else f"a base step dt of at most {max_age / (1 + edge.delay):.6g} s")
            problems.append(
                f"components.{edge.target}: its input {edge.target_port!r} comes from {edge.source} every "
                f"{held:.6g} s, longer than the {max_age:.6g} s it can bridge ({param_name}); use {faster}, "
                f"or components.{edge.target}.{param_name} of at least {held:.6g} s")


def _check_event_rates(scene: Scene, built: dict[str, Component], problems: list[str]) -> None:
    """An event input receives every message once: one stepping less often than its source receives
    several in a step, which it can take only as their sum (an additive type, such as contact
    impulses); a type that cannot be summed would lose all but the last."""
    for edge in scene.connections:
        spec = built[edge.target].inputs[edge.target_port]
        source_every, target_every = scene.components[edge.source].every, scene.components[edge.target].every
        if spec.event and not spec.type.additive and source_every < target_every:
            problems.append(
                f"components.{edge.target}: its event input {edge.target_port!r} ({spec.type.__name__}) comes from "
                f"{edge.source}, which steps every {source_every} base steps against its {target_every}: up to "
                f"{-(-target_every // source_every)} messages would arrive in one of its steps, and a "
                f"{spec.type.__name__} cannot be summed; step {edge.target} at least as often as {edge.source}")


def _check_needed_outputs(scene: Scene, needed_of: dict[str, dict[str, str]], problems: list[str]) -> None:
    """Each output a component needs consumed (:meth:`~cosim.component.Component.needed_outputs`,
    ``needed_of`` by component) feeds at least one input."""
    for name, needed in needed_of.items():
        for port, why in needed.items():
            if not any(edge.source == name and edge.source_port == port for edge in scene.connections):
                problems.append(f"components.{name}: its output {port!r} feeds nothing, but {why}")


def _senders(scene: Scene, name: str, port: str) -> set[str]:
    """The components whose connections feed input ``port`` of component ``name``."""
    return {e.source for e in scene.connections if e.target == name and e.target_port == port}


def _sends_on(scene: Scene, name: str, port: str) -> bool:
    """Whether component ``name`` feeds an input named ``port`` of any component (a body its state to
    a coupler's ``body``): another body, not a component that only reads the answer (a logger)."""
    return any(e.source == name and e.target_port == port for e in scene.connections)


def _target_port(built: dict[str, Component], edge: Connection) -> tuple[str, type[Message]]:
    """The input ``edge`` reaches, by its name and message type."""
    return edge.target_port, built[edge.target].inputs[edge.target_port].type


def _check_answers(scene: Scene, built: dict[str, Component], answers_of: dict[str, dict[str, str]],
                   needed_of: dict[str, dict[str, str]], problems: list[str]) -> None:
    """Each output that answers an input (:meth:`~cosim.component.Component.answers`, ``answers_of``
    by component) reaches every component sending on that input, and no other component on the port
    it reaches them on: a coupler's wrench or a ground's impulse also fed to a second body (an
    additive port, so nothing else refused it) pushed that body with forces worked out for the first,
    the run "ok"."""
    for name, answers in answers_of.items():
        if name not in needed_of:  # (its needed_outputs() raised: said)
            continue
        needed = needed_of[name]
        for out_port, in_port in answers.items():
            senders = sorted(_senders(scene, name, in_port))
            fed = [e for e in scene.connections if e.source == name and e.source_port == out_port]
            receivers = {e.target for e in fed}
            # the ports the answer reaches its senders on, by name and message type (not by class: a
            # subclass of the body, or an FMU body, each a class of its own, took another's wrench)
            answered = {_target_port(built, e) for e in fed if e.target in senders}
            for edge in fed:
                if (edge.target not in senders and _target_port(built, edge) in answered
                        and _sends_on(scene, edge.target, in_port)):
                    other = f"{edge.target}.{edge.target_port}"
                    problems.append(f"components.{name}: its {out_port!r} answers the {in_port!r} that "
                                    f"{', '.join(senders)} sends it, but also feeds {other}, which sends it "
                                    f"none: {edge.target} would take what was worked out for {senders[0]}; "
                                    f"remove the connection {name}.{out_port} -> {other}")
            for sender in senders:
                if sender in receivers:
                    continue
                # (another answer to the same input reaching it is right: a coupler's wrench and added mass
                # both answer its body)
                wrong = sorted((e.source_port, e.target_port) for e in scene.connections
                               if e.source == name and e.target == sender and e.source_port in answers
                               and answers[e.source_port] != in_port)
                if not wrong and not receivers and out_port in needed:
                    continue  # (said by _check_needed_outputs, with the connection to add)
                if wrong:
                    got, port = wrong[0]
                    problems.append(f"components.{name}: {sender} sends {in_port!r} but is sent {got!r}, the answer "
                                    f"to another: connect {name}.{out_port} -> {sender}.{port} instead")
                else:
                    fed = ", ".join(sorted(receivers)) or "nothing"
                    problems.append(f"components.{name}: {sender} sends {in_port!r}, but {out_port!r}, the answer "
                                    f"to it, feeds {fed}: connect {name}.{out_port} -> {sender}")


def _check_answer_rates(scene: Scene, built: dict[str, Component], answers_of: dict[str, dict[str, str]],
                        problems: list[str]) -> None:
    """An answer that its sender takes as an event (an impulse, received once and summed) is made
    once for each message it answers, so the answering component steps at its sender's rate: a
    ground stepping four times a body step answered the same state four times, and the four
    impulses summed threw a ball dropped from 0.5 m to 49 m, the run "ok"."""
    for name, answers in answers_of.items():
        every = scene.components[name].every
        for out_port, in_port in answers.items():
            senders = _senders(scene, name, in_port)
            for edge in scene.connections:
                if edge.source != name or edge.source_port != out_port or edge.target not in senders:
                    continue
                theirs = scene.components[edge.target].every
                if built[edge.target].inputs[edge.target_port].event and theirs != every:
                    problems.append(
                        f"components.{name}: it steps every {every} base steps and {edge.target} every {theirs}, "
                        f"but its {out_port!r} answers each {in_port!r} {edge.target} sends, which takes it as "
                        f"an event (each one applied once): set components.{name}.every to {theirs}")


def _check_wiring(scene: Scene, built: dict[str, Component], problems: list[str]) -> None:
    """Each component's :meth:`~cosim.component.Component.same_senders` and
    :meth:`~cosim.component.Component.fed_through`: inputs wired to another body's ports (a monitor
    fed one body's state and another's contact, a pond told one body's displacement as another's)
    ran to the end with wrong physics and no word."""
    shared: dict[tuple, list[str]] = {}
    for name, comp in built.items():
        ports = comp.exclusive_inputs()
        if ports:
            key = (type(comp).__name__, tuple(tuple(sorted(_senders(scene, name, p))) for p in ports))
            if all(key[1]):
                shared.setdefault(key, []).append(name)
    for (kind, fed), names in shared.items():
        if len(names) > 1:
            what = ", ".join(f"{p} from {', '.join(s)}" for p, s in zip(built[names[0]].exclusive_inputs(), fed,
                                                                        strict=True))
            problems.append(f"components: {' and '.join(names)} are {kind}s fed alike ({what}): each would act on "
                            "its own, the effect counted twice; keep one")
    for name, comp in built.items():
        for port, other in comp.same_senders().items():
            have, want = _senders(scene, name, port), _senders(scene, name, other)
            if have and want and have != want:
                problems.append(f"components.{name}: its input {port!r} comes from {', '.join(sorted(have))}, but "
                                f"{other!r} from {', '.join(sorted(want))}: both must come from the same component "
                                "(another body's?)")
        for port, other in comp.fed_through().items():
            upstream = _senders(scene, name, other)
            for sender in sorted(_senders(scene, name, port)):
                fed_by = {e.source for e in scene.connections if e.target == sender}
                if upstream and not upstream & fed_by:
                    problems.append(f"components.{name}: its input {port!r} comes from {sender}, which is not fed by "
                                    f"{', '.join(sorted(upstream))}, the sender of its {other!r}: {sender} serves "
                                    "another body")


def _check_told(scene: Scene, built: dict[str, Component], problems: list[str]) -> list[str]:
    """Each component's :meth:`~cosim.component.Component.told_of`: refused when told of answers
    otherwise than directly, at its rate and by exactly the components giving them; a notice (returned)
    when the answers are given and it is told of none."""
    notices = []
    for name, comp in built.items():
        every = scene.components[name].every
        for port, (via, theirs) in comp.told_of().items():
            told = [e for e in scene.connections if e.target == name and e.target_port == port]
            bodies = _senders(scene, name, via)
            answered = [e for e in scene.connections if e.target in bodies and e.target_port == theirs]
            if not told:
                if answered:
                    wire = "; ".join(f"{e.source}.{e.source_port} -> {name}.{port}" for e in answered)
                    notices.append(f"components.{name}: {answered[0].target} is answered on {theirs!r} by "
                                   f"{', '.join(sorted({e.source for e in answered}))}, which it is not told of: "
                                   f"connect {wire} (it meets the state before that answer)")
                continue
            for edge in told:
                if edge.delay:
                    problems.append(f"components.{name}: {edge} is delayed: its {port!r} takes the answer to the "
                                    "state it meets in the same step; connect it without delay")
                theirs_every = scene.components[edge.source].every
                if theirs_every != every:
                    problems.append(f"components.{name}: it steps every {every} base steps and {edge.source} every "
                                    f"{theirs_every}: its {port!r} would take several answers at once; set "
                                    f"components.{name}.every to {theirs_every}")
            have, want = {e.source for e in told}, {e.source for e in answered}
            if have != want:
                problems.append(f"components.{name}: its {port!r} comes from {', '.join(sorted(have))}, but what "
                                f"answers {', '.join(sorted(bodies))} on {theirs!r} from "
                                f"{', '.join(sorted(want)) or 'nothing'}: it must be told of every one of those, "
                                "and of no other")
    return notices


def _check_start(scene: Scene, built: dict[str, Component], problems: list[str]) -> None:
    """Each component's :meth:`~cosim.component.Component.check_start` on what it will receive at
    t = 0: for each input port, its source's initial output (a direct edge) or the edge's ``initial``
    (a delayed one); None for a port fed by nothing or by several edges. A component whose initial
    outputs fail is left to the run, which reports the failure with its name and time."""
    initial: dict[str, dict[str, Message]] = {}
    for name, comp in built.items():
        try:
            initial[name] = comp.initial_outputs()
        except Exception:  # reported when the run starts
            initial[name] = {}
    for name, comp in built.items():
        inputs: dict[str, Message | None] = {}
        sources: dict[str, Component] = {}
        for port in comp.inputs:
            feeding = [c for c in scene.connections if c.target == name and c.target_port == port]
            value = None
            if len(feeding) == 1:
                edge = feeding[0]
                value = edge.initial if edge.delay else initial.get(edge.source, {}).get(edge.source_port)
                if edge.source in built:
                    sources[port] = built[edge.source]
            inputs[port] = value
        try:
            found = comp.check_start(inputs) + comp.check_start_sources(inputs, sources)
            found += comp.check_step(scene.dt * scene.components[name].every, inputs)
            found += _step_problems(scene, name, comp.start_stable_step(inputs), later=True)
        except Exception as exc:
            found = [f"cannot check its start ({type(exc).__name__}: {exc})"]
        problems.extend(f"components.{name}: {problem}" for problem in found)


def default_scene_name(source: str) -> str:
    """The name of a scene without ``name:``: its file's name without the extension, made a safe
    one (:data:`SCENE_NAME_RE`, it names the recording's file): each character outside letters,
    digits, ``_``, ``-`` and ``.`` becomes ``_``, as does a first ``-`` or ``.`` and the second dot
    of ``..``; cut to 100 characters. A name that is safe already is kept as it is."""
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", Path(source).stem)[:100] or "scene"
    name = re.sub(r"\.\.", "._", name)
    if not re.match(r"[A-Za-z0-9_]", name):
        name = "_" + name[1:]
    return name


def scene_folder(source: str) -> Path:
    """Where a scene's relative file names start: the folder of its file, or the working folder for
    a scene that is not a file (text, a recording's attachment)."""
    path = Path(source)
    return (path.parent if path.is_file() else Path.cwd()).resolve()


def loads(text: str, source: str = "<string>", overrides: list[str] | None = None,
          base_dir: str | Path | None = None, default_name: str | None = None) -> Scene:
    """Parse and validate a scene from YAML text; raises ScenarioError listing every problem.
    ``base_dir``: the folder relative file names start from (default :func:`scene_folder`);
    ``default_name``: the name of a scene without ``name:`` (default :func:`default_scene_name` of
    ``source``; a recording's scene keeps the name its run gave it, not its attachment's)."""
    overrides = list(overrides or [])
    folder = Path(base_dir).resolve() if base_dir is not None else scene_folder(source)
    if len(text) > MAX_SCENE_BYTES:
        raise ScenarioError(f"the scene is {len(text) / 2**20:.1f} MiB, more than the {MAX_SCENE_BYTES >> 20} MiB "
                            "a scene may be", source)
    data = _parse_yaml(text, source)
    problems = apply_overrides(data, overrides)
    for key in data:
        if key not in TOP_KEYS:
            problems.append(f"{key}: unknown key (known: {', '.join(sorted(TOP_KEYS))})")
    name = data.get("name", default_name or default_scene_name(source))
    if not isinstance(name, str):
        problems.append(f"name: must be a string (got {name!r})")
    elif "name" in data and (not SCENE_NAME_RE.fullmatch(name) or ".." in name):
        problems.append(f"name: must be letters, digits, _, - and . (not first), at most 100 characters, "
                        f"no '..': it names the recording's file (got {name!r})")
    description = data.get("description", "")
    if not isinstance(description, str):  # (null became the text 'None', a mapping its repr)
        problems.append(f"description: must be text (got {show_value(description)})")
    dt_ns = _seconds(data, "dt", problems, required=True)
    until_ns = _seconds(data, "until", problems, required=True)
    if dt_ns is not None and until_ns is not None and until_ns < dt_ns:
        # the run takes whole base steps: its one step would run it to dt, past the end asked for
        problems.append(f"until: must be at least one base step, dt = {dt_ns / NS_PER_S:g} s "
                        f"(got {until_ns / NS_PER_S:g} s)")
    default_unstable = data.get("on_unstable", "error")
    if default_unstable not in ON_UNSTABLE:
        problems.append(f"on_unstable: must be one of 'error', 'substep' (got {default_unstable!r})")
        default_unstable = "error"

    raw_components = data.get("components")
    components: dict[str, ComponentConfig] = {}
    classes: dict[str, type[Component]] = {}
    no_components = not isinstance(raw_components, dict) or not raw_components
    if raw_components is None:
        problems.append("components: missing (required, a mapping of name -> {type: ..., parameters})")
        raw_components = {}
    elif no_components:
        problems.append(f"components: must be a non-empty mapping (got {raw_components!r})")
        raw_components = {}
    for cname, spec in raw_components.items():
        if not isinstance(cname, str):
            problems.append(f"components: a component is named {as_written(cname)}, not a name: {UNQUOTED_NAMES}")
            continue
        cfg = _component(str(cname), spec, dt_ns, default_unstable, problems, classes, folder)
        if cfg is not None:
            components[str(cname)] = cfg

    raw_edges = data.get("connections")
    if raw_edges is None:  # left out, or written with nothing after it
        raw_edges = []
    edges: list[Connection] = []
    if not isinstance(raw_edges, list):
        problems.append(f"connections: must be a list (got {raw_edges!r})")
        raw_edges = []
    names = {n for n in raw_components if isinstance(n, str)}  # (a name YAML read as a value was refused above)
    spelled = {n: str(spec.get("type")) for n, spec in raw_components.items()
               if isinstance(n, str) and isinstance(spec, dict)}
    for i, item in enumerate(raw_edges if not no_components else []):
        # without components every connection would only repeat that its ends are unknown
        edge = _connection(i, item, classes, names, problems, spelled)
        if edge is not None:
            edges.append(edge)
    # an input the scene does connect, by a connection refused above, is not also "not connected"
    written = {end for end in map(_written_target, raw_edges) if end is not None}
    _check_inputs(classes, edges, problems, written)
    _check_schema_names(classes, problems)

    record = RecordConfig()
    raw_record = data.get("record")
    if raw_record is None:  # (only null is no record block: false, 0, '' and [] were taken for one)
        raw_record = {}
    if not isinstance(raw_record, dict):
        problems.append(f"record: must be a mapping (got {raw_record!r})")
    else:
        record_problems_before = len(problems)
        # a time or rate beyond a float's range is refused by its own range below, not also as no float
        huge = {k for k in ("checkpoint_every", "visual_rate") if beyond_float(raw_record.get(k))}
        built = build(RecordConfig, {k: v for k, v in raw_record.items() if k not in huge}, "record", problems)
        typed = built is not None and len(problems) == record_problems_before and not huge
        if typed:
            record = built
        # the ranges, also of the values that are numbers when another record key is wrong (they were
        # said only once that one was mended); every read as build reads an int (2.0 is 2)
        numbers = {k: whole_number(v) if k == "every" else v for k, v in raw_record.items()
                   if k in RECORD_NUMBERS and _plain_number(v)}
        values = record if typed else RecordConfig(**{k: v for k, v in numbers.items()
                                                      if k != "every" or isinstance(v, int)})
        if values.every < 1:
            problems.append(f"record.every: must be >= 1 (got {values.every})")
        if values.visual_rate < 0:
            problems.append(f"record.visual_rate: must be >= 0 frames/s (got {number_text(values.visual_rate)})")
        elif values.visual_rate > NS_PER_S:
            problems.append(f"record.visual_rate: must be between 0 and {NS_PER_S:g} frames/s (a frame "
                            f"per nanosecond; got {number_text(values.visual_rate)})")
        if typed and record.channels is not None and not any(str(c).strip() for c in record.channels):
            # as --record ',,' is refused: a run whose recording silently holds no exchange at all
            problems.append(f"record.channels: names no channel (got {record.channels!r}); give channel globs "
                            "such as ['/stone/*'], or leave the key out to record every exchange")
        cp = seconds_value(values.checkpoint_every, "record.checkpoint_every", problems,
                           zero="no checkpoints")
        # the value the scene gave, when it is the one checked here: a value refused above (null, a
        # text) leaves the default in its place, which was then said not to fit dt either
        raw_cp = raw_record.get("checkpoint_every")
        given = _plain_number(raw_cp) and raw_cp == values.checkpoint_every
        if cp and dt_ns is not None and cp < dt_ns and not given:
            # the default (about a second) at the whole number of base steps nearest to it, at least
            # one: a scene of dt 2 s that set none was refused for the default, even with --no-record
            record.checkpoint_every = dt_ns / NS_PER_S
        elif cp and dt_ns is not None and cp < dt_ns:
            problems.append(f"record.checkpoint_every: must be 0 (none) or at least dt = {dt_ns / NS_PER_S:g} s "
                            f"(got {values.checkpoint_every:g})")
        elif cp and dt_ns is not None and given and not _whole_multiple(values.checkpoint_every, cp, dt_ns):
            # checkpoints are taken at base steps: one given between them was rounded to the nearest
            # (half to even) without a word; the default (about a second) still is, as any dt gives it
            problems.append(f"record.checkpoint_every: {values.checkpoint_every!r} s is not a whole multiple of "
                            f"dt = {_seconds_text(dt_ns)} s; checkpoints are taken at base steps: use "
                            f"{_nearest_multiples(values.checkpoint_every, cp, dt_ns)}")

    order, cycle = execution_order(list(classes), edges)
    if cycle:
        problems.append(f"connections: cycle without a delayed edge: {' -> '.join(cycle)} "
                        "(mark one edge of the loop with delay: 1 and an initial value)")
    if not problems:
        _check_memory(components, problems)
    if problems or dt_ns is None or until_ns is None:
        raise ScenarioError(problems, source)
    scene = Scene(name=name, description=description, dt_ns=dt_ns, until_ns=until_ns,
                  components=components, connections=edges, record=record, order=order, text=text,
                  data=data, source=source, overrides=overrides, base_dir=str(folder))
    built_components: dict[str, Component] = {}
    for comp_name, cfg in components.items():
        try:
            built_components[comp_name] = cfg.build()
        except Exception as exc:  # a component that cannot be built from valid-looking parameters
            if isinstance(exc, OSError) and exc.errno in NO_ROOM:
                raise  # the machine's limit (an FMU unpacked on a full disk), not the scene's values
            what = ("a number in its set-up leaves a float's range" if isinstance(exc, ArithmeticError)
                    else "cannot be built from these values")
            problems.append(f"components.{comp_name}: {what}: {type(exc).__name__}: {exc}")
    if problems:
        raise ScenarioError(problems, source)
    _check_stability(scene, built_components, problems)
    _check_freshness(scene, built_components, problems)
    _check_event_rates(scene, built_components, problems)
    needed_of = _asked_of_each(built_components, "needed_outputs", problems)
    answers_of = _asked_of_each(built_components, "answers", problems)
    _check_needed_outputs(scene, needed_of, problems)
    _check_answers(scene, built_components, answers_of, needed_of, problems)
    _check_answer_rates(scene, built_components, answers_of, problems)
    _check_wiring(scene, built_components, problems)
    told = _check_told(scene, built_components, problems)
    _check_start(scene, built_components, problems)
    if problems:
        raise ScenarioError(problems, source)
    scene.notices = ([f"components.{name}: {notice}" for name, comp in built_components.items()
                      for notice in comp.notices()] + _idle_connections(scene, built_components)
                     + _unplaced_looks(scene) + told + _long_run(scene))
    return scene


LEAST_STEP_S = 2e-6  # [s] the scheduler's own cost of a component step that does nothing (docs/performance.md)
LEAST_TICK_S = 0.5e-6  # [s] its own cost of a base tick, whatever steps in it
LONG_RUN_S = 2000.0  # [s] the least time (1e9 component steps) beyond which a scene is told it


def _long_run(scene: Scene) -> list[str]:
    """A notice when the run must take more than LONG_RUN_S with no physics at all: LEAST_TICK_S a
    base tick and LEAST_STEP_S a component step, the scheduler alone (a dt of 1e-8 s on the reference
    skip: 6e8 steps, about three days, started without a word; a component stepping every million
    ticks of 1 ns still costs each tick)."""
    ticks = ticks_reaching(scene.until_ns, scene.dt_ns)
    steps = sum(ticks_reaching(scene.until_ns, scene.dt_ns * cfg.every) for cfg in scene.components.values())
    least = ticks * LEAST_TICK_S + steps * LEAST_STEP_S
    if least <= LONG_RUN_S:
        return []
    return [f"until {_seconds_text(scene.until_ns)} s at dt = {_seconds_text(scene.dt_ns)} s is {ticks:.3g} ticks and "
            f"{steps:.3g} component steps: even at the scheduler's own {LEAST_TICK_S * 1e6:g} us a tick and "
            f"{LEAST_STEP_S * 1e6:g} us a step, with no physics, the run takes at least {_duration(least)}; check dt, "
            "until and the components' every"]


def _duration(seconds: float) -> str:
    """A length of time in the largest unit that keeps it above 1 (minutes to years)."""
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("hours", 3600), ("minutes", 60)):
        if seconds >= size:
            return f"{seconds / size:.3g} {unit}"
    return f"{seconds:.3g} s"


def _unplaced_looks(scene: Scene) -> list[str]:
    """A notice when ``record.channels`` keeps a body's looks (``/scene/NAME``, drawn in the body's own
    frame) but not the transforms (``/tf``) that place that frame: the viewer cannot draw the body
    (the recording held /scene/stone and no /tf, without a word)."""
    patterns = scene.record.channels
    if patterns is None or scene.record.visual_rate == 0 or any(fnmatch.fnmatchcase("/tf", p) for p in patterns):
        return []
    if not any(fnmatch.fnmatchcase(f"/scene/{name}", p) for name in scene.components for p in patterns):
        return []
    return ["record.channels: keeps viewer looks (/scene/...) but not /tf, whose transforms place each body's "
            "looks in its frame: the viewer cannot draw the bodies; add '/tf'"]


def _idle_connections(scene: Scene, built: dict[str, Component]) -> list[str]:
    """Notices of connections from outputs their component never publishes with its settings
    (:meth:`~cosim.component.Component.idle_outputs`): they deliver only their initial value. Not
    refused: switching an effect off by ``--set`` leaves its connection, and delivers nothing."""
    notices = []
    for name, comp in built.items():
        for port, why in comp.idle_outputs().items():
            fed = [f"{edge.target}.{edge.target_port}" for edge in scene.connections
                   if edge.source == name and edge.source_port == port]
            if fed:
                notices.append(f"components.{name}: its output {port!r} feeds {', '.join(fed)}, but {why}; the "
                               "connection delivers only its initial value")
    return notices


def read_input(path: str | Path, limit: int = MAX_SCENE_BYTES) -> str:
    """The text of an input file; a missing, unreadable, non-regular or too large file (more than
    ``limit`` bytes) is bad input (ScenarioError), found before it is read."""
    import stat

    if not str(path).strip():  # Path('') is '.', the working folder: it would be named instead
        raise ScenarioError("expected a scene file, got an empty name", repr(str(path)))
    path = Path(path)
    try:
        st = path.stat()
        if stat.S_ISDIR(st.st_mode):
            raise ScenarioError("is a folder, not a scene file", str(path))
        if not stat.S_ISREG(st.st_mode):
            raise ScenarioError("is not a regular file (a device, pipe or socket)", str(path))
        if st.st_size > limit:
            raise ScenarioError(f"is {st.st_size / 2**20:.1f} MiB, more than the {limit / 2**20:g} MiB a scene "
                                "may be", str(path))
        with open(path, encoding="utf-8") as f:
            text = f.read(limit + 1)
    except FileNotFoundError:
        raise ScenarioError("no such file", str(path)) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(f"cannot read: {exc}", str(path)) from None
    if len(text) > limit:
        raise ScenarioError(f"is more than the {limit / 2**20:g} MiB a scene may be", str(path))
    return text


def load(path: str | Path, overrides: list[str] | None = None) -> Scene:
    """Parse and validate a scene file; raises ScenarioError (a missing file is bad input too)."""
    return loads(read_input(path), source=str(path), overrides=overrides)
