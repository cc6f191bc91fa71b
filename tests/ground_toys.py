"""A disk lying flat on one SolidGround plane, as scene text: the ground's friction tests throw it."""

from __future__ import annotations

import math


def disk_on_plane(*, dt: float, until: float, radius: float, thickness: float, mu_static: float,
                  mu_kinetic: float, slope_deg: float = 0.0, velocity: tuple[float, float, float] = (0.0, 0.0, 0.0),
                  spin: float = 0.0, integrator: str = "verlet", restitution: float = 0.5,
                  density: float = 2700.0) -> str:
    """A scene (YAML text) of a slate disk ``disk`` lying flat on a SolidGround ``ground`` through the
    origin descending towards +x at ``slope_deg``, its lower face's centre at the origin, moving at
    ``velocity`` [m/s] and spun at ``spin`` [rad/s] about its axis; SI units."""
    p = math.radians(slope_deg)
    centre = [0.5 * thickness * math.sin(p), 0.0, 0.5 * thickness * math.cos(p)]
    return f"""
name: disk_on_plane
dt: {dt}
until: {until}
on_unstable: error
components:
  disk:
    type: RigidBody
    shape: disk
    radius: {radius}
    thickness: {thickness}
    density: {density}
    tilt_deg: {slope_deg}
    tilt_axis: [0.0, 1.0, 0.0]
    position: {centre}
    velocity: {list(velocity)}
    spin: {spin}
    integrator: {integrator}
  ground:
    type: SolidGround
    slope_deg: {slope_deg}
    mu_static: {mu_static}
    mu_kinetic: {mu_kinetic}
    restitution: {restitution}
connections:
  - disk.state -> ground.body
  - {{from: ground.impulse, to: disk.impulse, delay: 1,
     initial: {{linear: [0, 0, 0], angular: [0, 0, 0], correction: [0, 0, 0]}}}}
"""
