"""Hand-made messages for the coupler's tests and studies: a body in a given pose, still water.

A flat patch at ``level`` is still water. Angles in radians here (these are not scene fields).
"""

from __future__ import annotations

import math

import numpy as np

from components.messages import BodyState, HeightPatch, Shape

SLATE_DENSITY = 2650.0  # [kg/m^3]


def axis_angle(axis: tuple[float, float, float], angle: float) -> np.ndarray:
    """Unit quaternion (w, x, y, z) turning by ``angle`` [rad] about ``axis``."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    return np.array([math.cos(0.5 * angle), *(math.sin(0.5 * angle) * a)])


def pitched(attack: float) -> np.ndarray:
    """Orientation of a disk whose front (+x) edge is raised by the attack angle [rad]."""
    return axis_angle((0.0, 1.0, 0.0), -attack)


def body(shape: Shape = Shape.DISK, position=(0.0, 0.0, 0.0), orientation=(1.0, 0.0, 0.0, 0.0),
         velocity=(0.0, 0.0, 0.0), angular_velocity=(0.0, 0.0, 0.0), radius: float = 0.05,
         thickness: float = 0.006, density: float = SLATE_DENSITY, attitude_locked: bool = False) -> BodyState:
    """A BodyState of a uniform disk or sphere."""
    if shape == Shape.DISK:
        mass = density * math.pi * radius * radius * thickness
        i_d = mass * (3.0 * radius * radius + thickness * thickness) / 12.0
        inertia = (i_d, i_d, 0.5 * mass * radius * radius)
    else:
        thickness = 0.0
        mass = density * 4.0 / 3.0 * math.pi * radius**3
        inertia = (0.4 * mass * radius * radius,) * 3
    v = np.array(velocity, dtype=float)
    w = np.array(angular_velocity, dtype=float)
    ke = 0.5 * mass * float(v @ v)
    return BodyState(np.array(position, dtype=float), np.array(orientation, dtype=float), v, w, shape,
                     float(radius), float(thickness), float(mass), np.array(inertia, dtype=float), 0.0,
                     float(np.linalg.norm(v)), ke, mass * 9.81 * float(position[2]), attitude_locked)


def still_water(cell: float = 0.01, half_width: float = 0.15, level: float = 0.0,
                centre=(0.0, 0.0), surface_velocity: float = 0.0, depth: float = 1.0,
                i0: int = 0, j0: int = 0) -> HeightPatch:
    """A flat patch of n x n columns covering about [centre +- half_width] at ``level``."""
    n = round(2.0 * half_width / cell)
    ox = centre[0] - (n - 1) / 2.0 * cell - i0 * cell
    oy = centre[1] - (n - 1) / 2.0 * cell - j0 * cell
    return HeightPatch(i0, j0, cell, ox, oy, level, np.full((n, n), float(level)),
                       np.full((n, n), float(surface_velocity)), np.full((n, n), float(level - depth)))


def disk_at_depth(depth: float, attack: float, radius: float = 0.05, thickness: float = 0.006,
                  level: float = 0.0) -> tuple[float, float, float]:
    """Centre of a pitched disk whose lowest point is ``depth`` [m] below ``level``."""
    z = level - depth + 0.5 * thickness * math.cos(attack) + radius * math.sin(attack)
    return (0.0, 0.0, z)
