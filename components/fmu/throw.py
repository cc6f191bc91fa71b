"""The ``throw`` preset of ``cosim fmu export``: a stone run shown as an FMU.

Parameters: the throw of the scene's one RigidBody: ``speed`` [m/s] and ``angle_deg`` (below the
horizontal) [deg] of its initial velocity, ``tilt_deg`` (its attack angle) [deg] and ``spin``
[rad/s], each left out where a script of the body's sets it instead (``scripted_velocity``,
``scripted_tilt_deg``). Outputs: the body's position ``x, y, z`` [m] and velocity ``vx, vy, vz`` [m/s], and, when
the scene has a StageMonitor, the ``stage`` (a StageId) and the ``skips`` so far.

Speed and angle are derived values: set either, and the initial velocity becomes
speed * (cos(angle) u, -sin(angle)) with u the horizontal direction of the scene's throw; left at
their start values, the velocity stays exactly as the scene writes it.
"""

from __future__ import annotations

import math
from typing import Any

from components.messages import StageId
from components.rigid_body import RigidBody
from components.stages import STAGE_NAMES, StageMonitor
from cosim.fmi.spec import Output, Parameter
from cosim.scenario import Scene


def _one(scene: Scene, cls: type) -> str | None:
    """The name of the scene's one component of class ``cls`` (None if none or several)."""
    names = [n for n in scene.order if issubclass(scene.components[n].cls, cls)]
    return names[0] if len(names) == 1 else None


def parameters(scene: Scene) -> list[Parameter]:
    stone = _one(scene, RigidBody)
    if stone is None:
        return []
    p = scene.components[stone].params
    vx, vy, vz = p.velocity
    horizontal = math.hypot(vx, vy)
    found = []
    # a script that sets a quantity over time leaves its parameter nothing to do (the scripted
    # velocity, the throw's speed and angle; the scripted tilt, its attack angle, which with both
    # would make the FMU fail to initialize; with both, the spin moves no output)
    if not p.scripted_velocity:
        found += [Parameter("speed", math.sqrt(vx * vx + vy * vy + vz * vz), "m/s", f"initial speed of {stone}"),
                  Parameter("angle_deg", math.degrees(math.atan2(-vz, horizontal)), "deg",
                            f"initial velocity of {stone}: angle below the horizontal")]
    if not p.scripted_tilt_deg:
        found.append(Parameter("tilt_deg", p.tilt_deg, "deg", f"{stone}'s attack angle",
                               key=f"components.{stone}.tilt_deg"))
    if not (p.scripted_velocity and p.scripted_tilt_deg):
        found.append(Parameter("spin", p.spin, "rad/s", f"{stone}'s spin about its axis",
                               key=f"components.{stone}.spin"))
    return found


def outputs(scene: Scene) -> list[Output]:
    stone = _one(scene, RigidBody)
    if stone is None:
        return []
    found = [Output(name, stone, "state", field, i, "real", unit, f"{stone} {what} {axis} (world)")
             for field, unit, what, names in (("position", "m", "position", ("x", "y", "z")),
                                              ("velocity", "m/s", "velocity", ("vx", "vy", "vz")))
             for i, (name, axis) in enumerate(zip(names, "xyz", strict=True))]
    stages = _one(scene, StageMonitor)
    if stages is not None:
        found += [Output("stage", stages, "stage", "stage", None, "integer", "",
                         "stage id: " + ", ".join(f"{s.value} {STAGE_NAMES[s]}" for s in StageId)),
                  Output("skips", stages, "stage", "skips", None, "integer", "", "skips so far")]
    return found


def overrides(scene: Scene, values: dict[str, Any]) -> list[str]:
    """The stone's new initial velocity from a changed ``speed`` or ``angle_deg``."""
    stone = _one(scene, RigidBody)
    start = {p.name: p.start for p in parameters(scene)} if stone is not None else {}
    if "speed" not in start or not ({"speed", "angle_deg"} & set(values)):
        return []
    speed = float(values.get("speed", start["speed"]))
    angle = math.radians(float(values.get("angle_deg", start["angle_deg"])))
    vx, vy, _ = scene.components[stone].params.velocity
    horizontal = math.hypot(vx, vy)
    ux, uy = (vx / horizontal, vy / horizontal) if horizontal > 0 else (1.0, 0.0)
    h = speed * math.cos(angle)
    return [f"components.{stone}.velocity=[{h * ux!r}, {h * uy!r}, {-speed * math.sin(angle)!r}]"]
