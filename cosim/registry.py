"""Component types by name.

Names come from the ``cosim.components`` entry points (``RigidBody = "components.rigid_body:RigidBody"``)
or are given in full as ``package.module:Class``. A type is imported only when a scene names it, so a
scene without water never imports the water code.
"""

from __future__ import annotations

import importlib
from functools import cache
from importlib.metadata import entry_points

from cosim.component import Component

ENTRY_POINT_GROUP = "cosim.components"


@cache
def known_types() -> dict[str, str]:
    """Registered type names and their ``module:Class`` targets (nothing is imported)."""
    return {ep.name: ep.value for ep in entry_points(group=ENTRY_POINT_GROUP)}


class UnknownComponentType(LookupError):
    """The type name is neither registered nor an importable ``module:Class``."""


def resolve(type_name: str) -> type[Component]:
    """The component class for a registered name or a ``module:Class`` path."""
    target = known_types().get(type_name)
    if target is None:
        if ":" not in type_name:
            choices = ", ".join(sorted(known_types())) or "none registered"
            raise UnknownComponentType(f"unknown component type {type_name!r} (known: {choices}; "
                                       "or give 'package.module:Class')")
        target = type_name
    module_name, _, attr = target.partition(":")
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise UnknownComponentType(f"component type {type_name!r}: cannot import {module_name!r} ({exc})") from None
    cls = getattr(module, attr, None)
    if not (isinstance(cls, type) and issubclass(cls, Component)):
        raise UnknownComponentType(f"component type {type_name!r}: {target!r} is not a Component class")
    return cls
