"""cosim: a fixed-step co-simulation framework with typed messages and MCAP recording.

The framework knows nothing about stones or water: components are found by name through the
``cosim.components`` entry points (or given as ``module:Class``) and imported only when a scene
names them. The layers, lowest first (``docs/architecture.md`` draws them):

- the contract: :mod:`cosim.timebase`, :mod:`cosim.errors`, :mod:`cosim.messages`, :mod:`cosim.params`,
  :mod:`cosim.component`, :mod:`cosim.registry`;
- :mod:`cosim.codec`: a message's exact wire form (JSON schema and text, records, plain state);
- scenes and the master: :mod:`cosim.scenario`, :mod:`cosim.scheduler`;
- :mod:`cosim.record`: the recorder observer, the writer process, reading recordings back;
- :mod:`cosim.view`: viewer items, Foxglove conversion, live streaming;
- running: :mod:`cosim.runner`, :mod:`cosim.replay`, :mod:`cosim.progress`, :mod:`cosim.cli`;
- :mod:`cosim.sweep`: many runs of one scene, on a pool or Dask.

The names below are imported on first use, so that a process needing one light module (the
recording's writer imports only :mod:`cosim.codec.jsontext`) does not pay for numpy.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

_EXPORTS = {
    "Component": "cosim.component", "Port": "cosim.component",
    "RecordingError": "cosim.errors", "ScenarioError": "cosim.errors", "SimulationError": "cosim.errors",
    "Array": "cosim.messages", "Message": "cosim.messages", "Quat": "cosim.messages",
    "Vec3": "cosim.messages", "message": "cosim.messages",
    "param": "cosim.params",
}

__all__ = ["Array", "Component", "Message", "Port", "Quat", "RecordingError", "ScenarioError",
           "SimulationError", "Vec3", "__version__", "message", "param"]

if TYPE_CHECKING:
    from cosim.component import Component, Port
    from cosim.errors import RecordingError, ScenarioError, SimulationError
    from cosim.messages import Array, Message, Quat, Vec3, message
    from cosim.params import param


def lazy_exports(package: str, exports: dict[str, str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """A package's ``__getattr__`` and ``__dir__`` for ``exports`` (public name -> module holding it):
    each name is imported from its module on first use and then kept in the package's namespace."""
    namespace = sys.modules[package].__dict__

    def getattr_(name: str) -> Any:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        namespace[name] = value
        return value

    def dir_() -> list[str]:
        return sorted([*namespace, *exports])

    return getattr_, dir_


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
