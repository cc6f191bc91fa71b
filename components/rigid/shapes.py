"""Shapes, mass and inertia about the centre of mass.

Both shapes are axisymmetric about the body z axis, so the principal moments are (I_d, I_d, I_a):
every rotation routine in :mod:`components.rigid.dynamics` relies on that symmetry (I_x = I_y).

- thin disk (solid cylinder) of radius R and thickness e: I_a = M R^2 / 2 about its axis,
  I_d = M (3 R^2 + e^2) / 12 about a diameter (physics.md section 2);
- sphere of radius R: I = 2/5 M R^2 about any axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from components.messages import Shape


@dataclass(frozen=True)
class MassProperties:
    """What the dynamics needs to know about a body.

    shape; radius [m]; thickness [m] (0 for a sphere); mass [kg]; inertia: (3,) principal moments
    about body x, y, z [kg m^2], with inertia[0] == inertia[1].
    """

    shape: Shape
    radius: float
    thickness: float
    mass: float
    inertia: tuple[float, float, float]

    def __post_init__(self) -> None:
        # the rotation routines read I_x alone for both moments across the axis: a body with I_x != I_y
        # would turn as a wrong one, its energy and momentum not kept (78% off in 50 s for moments 1:2:3)
        if self.inertia[0] != self.inertia[1]:
            raise ValueError(f"the moments about body x and y must be equal, an axisymmetric body "
                             f"(got {self.inertia[0]:g} and {self.inertia[1]:g} kg m^2)")

    @property
    def volume(self) -> float:
        """Volume [m^3]."""
        return shape_volume(self.shape, self.radius, self.thickness)

    @property
    def bounding_radius(self) -> float:
        """Radius [m] of the smallest sphere about the centre of mass holding the body."""
        return math.hypot(self.radius, 0.5 * self.thickness)


def shape_volume(shape: Shape, radius: float, thickness: float) -> float:
    """Volume [m^3] of a disk (pi R^2 e) or a sphere (4/3 pi R^3); inf where it overflows a float."""
    if shape is Shape.DISK:
        return math.pi * radius * radius * thickness
    try:
        return 4.0 / 3.0 * math.pi * radius ** 3
    except OverflowError:  # a float power that overflows raises where a product gives inf
        return math.inf


def disk_inertia(mass: float, radius: float, thickness: float) -> tuple[float, float, float]:
    """Principal moments (I_d, I_d, I_a) [kg m^2] of a solid cylinder with its axis along body z."""
    diameter = mass * (3.0 * radius * radius + thickness * thickness) / 12.0
    return (diameter, diameter, 0.5 * mass * radius * radius)


def sphere_inertia(mass: float, radius: float) -> tuple[float, float, float]:
    """Principal moments (I, I, I) [kg m^2] of a solid sphere."""
    i = 0.4 * mass * radius * radius
    return (i, i, i)


def mass_properties(shape: Shape, radius: float, thickness: float = 0.0, *, density: float | None = None,
                    mass: float | None = None) -> MassProperties:
    """Mass properties from the geometry and either the density [kg/m^3] or the mass [kg] (mass wins).

    A sphere's thickness is ignored (reported as 0).
    """
    if radius <= 0:
        raise ValueError(f"radius must be > 0 m (got {radius})")
    if shape is Shape.DISK and thickness <= 0:
        raise ValueError(f"a disk's thickness must be > 0 m (got {thickness})")
    if shape is Shape.SPHERE:
        thickness = 0.0
    if mass is None:
        if density is None:
            raise ValueError("give either the density or the mass")
        mass = density * shape_volume(shape, radius, thickness)
    if mass <= 0:
        raise ValueError(f"mass must be > 0 kg (got {mass})")
    inertia = disk_inertia(mass, radius, thickness) if shape is Shape.DISK else sphere_inertia(mass, radius)
    return MassProperties(shape, float(radius), float(thickness), float(mass), inertia)
