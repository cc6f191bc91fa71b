"""Which message types have installed looks: the ``cosim.visuals`` entry points, read without
importing any of them (nor the viewer machinery of :mod:`cosim.view.items`); and which components
draw themselves (:func:`draws_itself`).

The recorder asks this of every recorded port to decide where its viewer channels are made: from the
recorded messages in the writer process, when the looks are an installed package's (the writer can
import them too), or here (see :mod:`cosim.view.channels`).
"""

from __future__ import annotations

from functools import cache
from importlib.metadata import EntryPoint
from typing import Any

VISUALS_GROUP = "cosim.visuals"


def type_key(message_type: type) -> str:
    """The registry name of a message type: its module and qualified name."""
    return f"{message_type.__module__}.{message_type.__qualname__}"


@cache
def installed_visuals() -> dict[str, EntryPoint]:
    """Registry name -> entry point of every installed visuals function (none loaded).

    Read from the one scan of the installed packages that the component registry and numba's start
    share (a scan costs 5-10 ms, for one group as for all)."""
    from cosim.registry import installed_entry_points

    return {ep.name: ep for ep in installed_entry_points().select(group=VISUALS_GROUP)}


def has_installed_visuals(message_type: type) -> bool:
    """Whether an installed package gives this message type's looks."""
    return type_key(message_type) in installed_visuals()


def draws_itself(comp: Any) -> bool:
    """Whether a component overrides its own looks (``Component.visuals``): then they need the
    component itself, not only its messages."""
    return type_draws_itself(type(comp))


def type_draws_itself(cls: type) -> bool:
    """:func:`draws_itself` of the components of class ``cls`` (known before any is built)."""
    from cosim.component import Component

    return cls.visuals is not Component.visuals
