"""The viewer channels of a recording: made by the writer process where it can, here where it cannot.

:class:`RecordedVisuals` is the recorder's default deriver (``record.visual_rate`` frames per
second, :func:`cosim.runner.default_derivers`). For a port whose message type has its looks from an
installed package (the ``cosim.visuals`` entry points), the writer process makes the frames from the
recorded messages (:mod:`cosim.record.derive`), off the simulation's core; this process then never
imports the viewer modules at all. It makes them all here instead, as a
:func:`cosim.view.foxglove.visual_deriver` does, when a component overrides its own looks
(``Component.visuals``, which needs the component itself), when looks were registered in this
process only (:func:`cosim.view.items.register`), and when the recording keeps only some messages
(``record.every``) or some channels (``record.channels``), since the writer sees only what is
recorded: all or none, so that a topic such as ``/tf`` is never made by both. Either way the frames
are the same, byte for byte.
"""

from __future__ import annotations

import math
import sys
from typing import Any

from cosim.view.lookup import draws_itself, has_installed_visuals

RECIPE_MODULE = "cosim.view.foxglove"  # where the writer's deriver is made: visual_deriver(rate, reserved)


def registered_here() -> dict[type, Any]:
    """The looks registered in this process (:func:`cosim.view.items.register`), by message type;
    none when the viewer items were never imported."""
    items = sys.modules.get("cosim.view.items")
    return {} if items is None else items._REGISTERED


class RecordedVisuals:
    """The viewer channels at ``rate`` frames/s; ``reserved_topics`` (the physics channels) may not be
    used by viewer items."""

    def __init__(self, rate: float, reserved_topics: frozenset[str] = frozenset()):
        if not (rate > 0 and math.isfinite(rate)):
            raise ValueError(f"visual rate must be a positive number of frames/s (got {rate!r})")
        self.rate = rate
        self.reserved_topics = frozenset(reserved_topics)
        # how the writer process makes the same deriver (cosim.record.derive.make_deriver)
        self.writer_recipe = (RECIPE_MODULE, "visual_deriver", (rate, tuple(sorted(self.reserved_topics))))
        self.components: dict[str, Any] = {}
        self._here: Any = None  # the deriver for the ports made here, once one is
        self._writer_makes: bool | None = None  # whether the writer makes the run's frames (in_writer)

    def bind(self, components: dict[str, Any]) -> None:
        """Give the running components (their ``visuals`` overrides take precedence)."""
        self.components = dict(components)
        self._writer_makes = None
        if self._here is not None:
            self._here.bind(self.components)

    def in_writer(self, component: str, port: str, message_type: type) -> bool:
        """Whether the writer process makes this port's frames from its recorded messages (the
        recorder asks only when it records every exchange in full). All of them or none: as soon as
        one component draws itself or looks are registered in this process, every port is made here,
        so that a topic such as ``/tf`` is never made by both processes (decided at the first port
        asked about, for the run)."""
        if self._writer_makes is None:
            self._writer_makes = not (any(map(draws_itself, self.components.values())) or registered_here())
        return self._writer_makes and self._looks(component, message_type) == "installed"

    def _looks(self, component: str, message_type: type) -> str | None:
        """Who gives a port's looks: "component" (its own ``visuals``), "registered" (in this
        process), "installed" (an installed package), or None (nobody: it has no frames)."""
        comp = self.components.get(component)
        if comp is not None and draws_itself(comp):
            return "component"
        if message_type in registered_here():
            return "registered"
        return "installed" if has_installed_visuals(message_type) else None

    # --- the ports made here: the deriver protocol of cosim.record.recorder ----------------------

    def _deriver(self) -> Any:
        if self._here is None:
            from cosim.view.foxglove import visual_deriver

            self._here = visual_deriver(self.rate, self.reserved_topics)
            self._here.bind(self.components)
        return self._here

    def watches(self, component: str, port: str, message_type: type) -> bool:
        # a port without looks is told apart without the viewer modules
        return self._looks(component, message_type) is not None and self._deriver().watches(
            component, port, message_type)

    def due_ns(self, component: str, port: str) -> int:
        return self._deriver().due_ns(component, port)

    draws_final = True  # (cosim.view.items.VisualDeriver's final frame)

    def __call__(self, time_ns: int, component: str, port: str, msg: Any, final: bool = False) -> Any:
        return self._deriver()(time_ns, component, port, msg, final=final)
