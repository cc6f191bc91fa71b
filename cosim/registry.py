"""Component types by name.

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

import importlib
import os
import re
from collections.abc import Iterable
from functools import cache
from importlib.metadata import entry_points
from typing import Any

from cosim.component import Component

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
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise UnknownComponentType(f"component type {type_name!r}: cannot import {module_name!r} ({exc})") from None
    cls = getattr(module, attr, None)
    if cls is None:
        near = sorted(name for name, value in vars(module).items()
                      if isinstance(value, type) and issubclass(value, Component) and value is not Component)
        registered = f"; {attr} is a registered type: write type: {attr}" if attr in known_types() else ""
        raise UnknownComponentType(f"component type {type_name!r}: module {module_name!r} has no {attr!r} "
                                   f"(its component classes: {', '.join(near) or 'none'}{registered})")
    if not (isinstance(cls, type) and issubclass(cls, Component)):
        raise UnknownComponentType(f"component type {type_name!r}: {target!r} is not a Component class")
    return cls
