"""cosim: a fixed-step co-simulation framework with typed messages and MCAP recording.

The framework knows nothing about stones or water: components are found by name through the
``cosim.components`` entry points (or given as ``module:Class``) and imported only when a scene
names them.
"""

from cosim.component import Component, Port
from cosim.errors import RecordingError, ScenarioError, SimulationError
from cosim.messages import Array, Message, Quat, Vec3, message
from cosim.params import param

__version__ = "0.1.0"

__all__ = ["Array", "Component", "Message", "Port", "Quat", "RecordingError", "ScenarioError",
           "SimulationError", "Vec3", "__version__", "message", "param"]
