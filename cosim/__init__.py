"""cosim: a fixed-step co-simulation framework with typed messages and MCAP recording.

The framework knows nothing about stones or water: components are found by name through the
``cosim.components`` entry points (or given as ``module:Class``) and imported only when a scene
names them.

The names below are imported on first use, so that a process needing one light module (the
recording's writer imports only :mod:`cosim.jsontext`) does not pay for numpy.
"""

from __future__ import annotations

import importlib
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


def __getattr__(name: str) -> Any:
    module = _EXPORTS.get(name)
    if module is None:
        raise AttributeError(f"module 'cosim' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_EXPORTS])
