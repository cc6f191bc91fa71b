"""Component types by name, and what each takes (``cosim components``).

Names come from the ``cosim.components`` entry points (``RigidBody = "components.rigid_body:RigidBody"``)
or are given in full as ``package.module:Class``. A type is imported only when a scene names it, so a
scene without water never imports the water code.

A scene is data, and loading it must not run code it chooses: a ``module:Class`` path is imported
only from an allowed package: ``cosim`` itself, the packages the registered entry points come from
(``components``), and those named in the environment variable ``COSIM_COMPONENT_PACKAGES``
(comma-separated, e.g. ``COSIM_COMPONENT_PACKAGES=mylab,tests``), or given to :func:`resolve`. Any
other module (``os``, ``subprocess``, a file beside the scene) is refused before it is imported.
"""

from __future__ import annotations

import dataclasses
import importlib
import os
import re
import typing
from collections.abc import Iterable
from functools import cache
from importlib.metadata import entry_points
from typing import Any

from cosim.component import Component, Port
from cosim.messages import FieldKind, Message
from cosim.params import ParamRow, describe

_KEYS_IN_ORDER = ("step", "every", "type", "on_unstable")  # as the scene reference lists them
COMPONENT_KEYS = frozenset(_KEYS_IN_ORDER)
"""The keys a scene's component takes for itself; every other key is one of its parameters."""

ENTRY_POINT_GROUP = "cosim.components"
ALLOW_ENV = "COSIM_COMPONENT_PACKAGES"
_MODULE_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*")


@cache
def installed_entry_points() -> Any:
    """Every installed entry point, of every group (``.select(group=..., name=...)`` picks some), from
    one scan of the installed packages, for whatever in this process looks them up: a scan reads each
    package's entry points file, some milliseconds with a hundred packages installed, and costs the
    same for one group as for all."""
    return entry_points()


@cache
def known_types() -> dict[str, str]:
    """Registered type names and their ``module:Class`` targets (nothing is imported)."""
    return {ep.name: ep.value for ep in installed_entry_points().select(group=ENTRY_POINT_GROUP)}


class UnknownComponentType(LookupError):
    """The type name is neither registered nor an importable ``module:Class`` of an allowed package."""


def allowed_packages(extra: Iterable[str] = ()) -> list[str]:
    """The packages whose modules a scene may name as ``module:Class`` (see the module's text)."""
    packages = {"cosim"} | {target.partition(":")[0].partition(".")[0] for target in known_types().values()}
    packages |= {p.strip() for p in os.environ.get(ALLOW_ENV, "").split(",") if p.strip()}
    packages |= set(extra)
    return sorted(packages)


def _allowed(module_name: str, packages: list[str]) -> bool:
    return any(module_name == p or module_name.startswith(p + ".") for p in packages)


def resolve(type_name: str, allow: Iterable[str] = ()) -> type[Component]:
    """The component class for a registered name or a ``module:Class`` path in an allowed package
    (:func:`allowed_packages`, plus ``allow``)."""
    target = known_types().get(type_name)
    if target is None:
        if ":" not in type_name:
            choices = ", ".join(sorted(known_types())) or "none registered"
            raise UnknownComponentType(f"unknown component type {type_name!r} (known: {choices}; "
                                       "or give 'package.module:Class')")
        module_name, _, attr = type_name.partition(":")
        if not _MODULE_RE.fullmatch(module_name) or not attr.isidentifier():
            raise UnknownComponentType(f"component type {type_name!r}: expected 'package.module:Class'")
        packages = allowed_packages(allow)
        if not _allowed(module_name, packages):
            raise UnknownComponentType(
                f"component type {type_name!r}: module {module_name!r} is not in an allowed package "
                f"({', '.join(packages)}); a scene names registered types, or classes of these packages "
                f"(allow more with {ALLOW_ENV}=package[,package])")
        target = type_name
    module_name, _, attr = target.partition(":")
    module = _import(type_name, module_name)
    cls = getattr(module, attr, None)
    if cls is None:
        near = sorted(name for name, value in vars(module).items()
                      if isinstance(value, type) and issubclass(value, Component) and value is not Component)
        registered = f"; {attr} is a registered type: write type: {attr}" if attr in known_types() else ""
        raise UnknownComponentType(f"component type {type_name!r}: module {module_name!r} has no {attr!r} "
                                   f"(its component classes: {', '.join(near) or 'none'}{registered})")
    if not (isinstance(cls, type) and issubclass(cls, Component)):
        raise UnknownComponentType(f"component type {type_name!r}: {target!r} is not a Component class")
    if cls._step_impl is Component._step_impl:  # a base to build on (Component itself): it cannot step
        raise UnknownComponentType(f"component type {type_name!r}: {target!r} does not step (it has no "
                                   "_step_impl of its own): name a component class built on it")
    check_contract(cls, type_name)
    return cls


def check_contract(cls: type[Component], type_name: str) -> None:
    """Refuse (UnknownComponentType naming ``type_name`` and the rule) a component class whose
    ``Params`` is not a dataclass or has a parameter named like a scene's own component key, or whose
    ``inputs``/``outputs`` are not a mapping of port name to :class:`Port` of a message type: each
    came out as an internal error when the scene was built or run, or a parameter silently kept its
    default. Checked once per class (:func:`_contract_problem` is cached)."""
    problem = _contract_problem(cls)
    if problem:
        raise UnknownComponentType(f"component type {type_name!r}: {problem}")


@cache
def _contract_problem(cls: type[Component]) -> str:
    """What breaks the component contract in ``cls`` (see :func:`check_contract`), or ""."""
    return _params_problem(cls.Params) or _ports_problem(cls, "inputs") or _ports_problem(cls, "outputs")


def _params_problem(params: Any) -> str:
    """What is wrong with a component's ``Params`` class, or ""."""
    if not (isinstance(params, type) and dataclasses.is_dataclass(params)):
        return (f"its Params must be a dataclass class (decorate it with @dataclass(frozen=True)); "
                f"got {_what(params)}")
    for field in dataclasses.fields(params):
        if field.name in COMPONENT_KEYS:
            # the scene takes such a key for itself, and the parameter silently kept its default
            return (f"its parameter {field.name!r} has the name of a scene key ({', '.join(_KEYS_IN_ORDER)}): "
                    "rename it")
    return ""


def _ports_problem(cls: type[Component], side: str) -> str:
    """What is wrong with a component's ``inputs`` or ``outputs`` (``side``), or ""."""
    ports = getattr(cls, side)
    if not isinstance(ports, dict):
        return f"its {side} must be a dict of port name -> Port(MessageType), got {_what(ports)}"
    way = side[:-1]
    for name, port in ports.items():
        if not isinstance(name, str):
            return f"its {side} must be named by text, got {name!r}"
        if not isinstance(port, Port):
            return f"its {way} {name!r} must be a Port(MessageType), got {_what(port)}"
        kind = port.type
        if not (isinstance(kind, type) and issubclass(kind, Message) and "__cosim_fields__" in vars(kind)):
            return (f"its {way} {name!r} carries {_what(kind)}, not a message type (a Message subclass "
                    "decorated with @message)")
    return ""


def _what(value: Any) -> str:
    """A value as a contract problem names it: a class by its module and name, else its type."""
    if isinstance(value, type):
        return f"class {value.__module__}.{value.__qualname__}"
    return f"a {type(value).__name__} ({value!r})" if len(repr(value)) <= 60 else f"a {type(value).__name__}"


def _import(type_name: str, module_name: str) -> Any:
    """The module ``module_name`` of component type ``type_name``. A module that fails as it is
    imported, in any way (an ImportError, 1/0, a SyntaxError, ``sys.exit(3)``), is the scene's
    component type that cannot be used (UnknownComponentType, said on its key), not an error inside
    cosim: a SystemExit ended the command with the module's own exit code and nothing said. A
    KeyboardInterrupt (Ctrl-C, SIGTERM) stays what it is."""
    try:
        return importlib.import_module(module_name)
    except KeyboardInterrupt:
        raise
    except BaseException as exc:
        raise UnknownComponentType(f"component type {type_name!r}: cannot import {module_name!r} "
                                   f"({_import_failure(exc)})") from None


def _import_failure(exc: BaseException) -> str:
    """What a failed import says: an ImportError's own text; a SyntaxError's type, text and
    ``file:line``; a SystemExit's code; anything else its type and text."""
    if isinstance(exc, ImportError):
        return str(exc)
    if isinstance(exc, SyntaxError):
        return f"{type(exc).__name__}: {exc.msg} (at {exc.filename}:{exc.lineno})"
    if isinstance(exc, SystemExit):
        return f"it called sys.exit({exc.code!r}) as it was imported"
    return f"{type(exc).__name__}: {exc}"


# --- what each type takes -----------------------------------------------------------------------

class PortRow(typing.NamedTuple):
    """One port of a component type: its name, direction (``input``, ``input, required``,
    ``input, event``, ``output``, ``output, event``), message type and description."""

    name: str
    direction: str
    message: str
    doc: str


class TypeInfo(typing.NamedTuple):
    """A registered component type as ``cosim components`` shows it: its name and the other names it
    is registered under, its ``module:Class``, the first paragraph of its docstring, its parameters,
    its ports (none listed for a type whose ports its parameters make, as an FMU's) and the message
    types they carry; ``problem`` says why a type could not be loaded (a missing extra)."""

    name: str
    aliases: tuple[str, ...]
    target: str
    summary: str
    params: list[ParamRow]
    ports: list[PortRow]
    messages: list[type[Message]]
    problem: str = ""


def registered() -> dict[str, list[str]]:
    """Each registered ``module:Class`` and the names it is registered under, its class's own name
    first."""
    names: dict[str, list[str]] = {}
    for name, target in sorted(known_types().items()):
        names.setdefault(target, []).append(name)
    for target, those in names.items():
        own = target.partition(":")[2]
        those.sort(key=lambda n: (n != own, n))
    return names


def project_types() -> list[str]:
    """The names of this project's own registered types (of ``cosim`` and ``components``), sorted:
    the types docs/components.md describes (another installed package's are not this project's)."""
    return sorted(names[0] for target, names in registered().items()
                  if target.partition(".")[0] in ("cosim", "components"))


def first_paragraph(text: str | None) -> str:
    """The first paragraph of a docstring, on one line."""
    return " ".join((text or "").strip().split("\n\n")[0].split())


def type_info(name: str) -> TypeInfo:
    """What registered type ``name`` takes (a ``module:Class`` of an allowed package works too)."""
    target = known_types().get(name, name)
    aliases = tuple(n for n in registered().get(target, [name]) if n != name)
    try:
        cls = resolve(name)
    except UnknownComponentType as exc:
        return TypeInfo(name, aliases, target, "", [], [], [], str(exc))
    params = describe(cls.Params) if getattr(cls, "Params", None) is not None else []
    ports = [PortRow(port, _direction("input", spec), spec.type.__name__, spec.doc)
             for port, spec in cls.inputs.items()]
    ports += [PortRow(port, _direction("output", spec), spec.type.__name__, spec.doc)
              for port, spec in cls.outputs.items()]
    messages = list(dict.fromkeys(spec.type for spec in (*cls.inputs.values(), *cls.outputs.values())))
    return TypeInfo(name, aliases, target, first_paragraph(cls.__doc__), params, ports, messages)


def _direction(way: str, spec: Port) -> str:
    return ", ".join([way, *(["required"] if spec.required else []), *(["event"] if spec.event else [])])


def message_fields(msg_type: type[Message]) -> str:
    """A message type's fields as a line: ``position (3,), radius, shape (Shape), ...``."""
    parts = []
    for spec in msg_type.__cosim_fields__:
        if spec.kind is FieldKind.ARRAY and spec.array is not None:
            shape = ", ".join("n" if d is None else str(d) for d in spec.array.shape)
            parts.append(f"{spec.name} ({shape}{',' if len(spec.array.shape) == 1 else ''})")
        elif spec.kind is FieldKind.ENUM and spec.enum_type is not None:
            parts.append(f"{spec.name} ({spec.enum_type.__name__}: "
                         f"{', '.join(m.name.lower() for m in spec.enum_type)})")
        else:
            parts.append(f"{spec.name} ({spec.kind.value})")
    return ", ".join(parts)


def type_text(info: TypeInfo) -> list[str]:
    """``cosim components TYPE``: a type's parameters, ports and messages as terminal lines."""
    also = f" (also: {', '.join(info.aliases)})" if info.aliases else ""
    lines = [f"{info.name}{also} - {info.target}"]
    if info.problem:
        return [*lines, f"  unavailable: {info.problem}"]
    lines.append(f"  {info.summary}")
    lines.append("parameters (key: what it takes = default [unit], bounds):" if info.params else "parameters: none")
    for row in info.params:
        unit = f" [{row.unit}]" if row.unit else ""
        bounds = f", {row.bounds}" if row.bounds else ""
        lines.append(f"  {row.name}: {row.kind} = {row.default}{unit}{bounds}")
        if row.doc:
            lines.append(f"      {row.doc}")
    lines.append("ports:" if info.ports else "ports: made from its parameters (see its documentation)")
    lines += [f"  {p.name} ({p.direction}): {p.message}" + (f" - {p.doc}" if p.doc else "") for p in info.ports]
    if info.messages:
        lines.append("messages (fields; units in each type's documentation):")
        lines += [f"  {m.__name__}: {message_fields(m)}" for m in info.messages]
    return lines


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def types_page(names: list[str]) -> str:
    """docs/components.md: the reference of the types ``names``, one section each."""
    out = ["# Components", "",
           "Every component type registered by name, with its parameters (a scene's `components.NAME.KEY`),",
           "its ports (what `connections` wire) and, at the end, the messages they carry, with their",
           "fields and units. Generated from the code by `cosim components --markdown docs/components.md`;",
           "`cosim components TYPE` prints the same in a terminal. A scene may also name a class of an",
           "allowed package as `package.module:Class` (docs/scenes.md): the two toy components of",
           "scenarios/ping_pong.yaml, `cosim.examples:Ping` and `cosim.examples:Pong`, are named so.", ""]
    messages: list[type[Message]] = []
    for name in names:
        info = type_info(name)
        also = f" (also registered as {', '.join(f'`{a}`' for a in info.aliases)})" if info.aliases else ""
        out += [f"## {info.name}", "", f"`{info.target}`{also}", ""]
        if info.problem:
            out += [f"Unavailable here: {_cell(info.problem)}", ""]
            continue
        out += [info.summary, ""]
        if info.params:
            out += ["| parameter | takes | default | unit | bounds | |", "|---|---|---|---|---|---|"]
            out += [f"| `{r.name}` | {_cell(r.kind)} | `{_cell(r.default)}` | {_cell(r.unit)} | {_cell(r.bounds)} | "
                    f"{_cell(r.doc)} |" for r in info.params]
            out.append("")
        if info.ports:
            out += ["| port | direction | message | |", "|---|---|---|---|"]
            out += [f"| `{p.name}` | {p.direction} | [`{p.message}`](#{p.message.lower()}) | {_cell(p.doc)} |"
                    for p in info.ports]
            out.append("")
        else:
            out += ["Its ports are made from its parameters.", ""]
        messages += [m for m in info.messages if m not in messages]
    if messages:
        out += ["## Messages", ""]
    for msg_type in sorted(messages, key=lambda m: m.__name__):
        text = "\n".join(line.strip() for line in (msg_type.__doc__ or "").strip().splitlines())
        out += [f"### {msg_type.__name__}", "", f"`{msg_type.__module__}.{msg_type.__name__}`"
                + (" (additive: several edges into one port are summed)" if msg_type.additive else ""), "",
                text, "", f"Fields: {message_fields(msg_type)}.", ""]
    return "\n".join(out).rstrip("\n") + "\n"
