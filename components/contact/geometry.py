"""Contact geometry: planes and the lowest point(s) of a disk or a sphere against a plane.

A disk of radius R and thickness e with symmetry axis a (world) against a plane with outward unit
normal n: the lowest point lies on the rim of the face turned towards the plane,

    r_low = R rho - (e/2) sign(n.a) a,     rho = -(n - (n.a) a) / |n - (n.a) a|,

and the spread of heights over that rim is 2 R sin(tilt), sin(tilt) = |n - (n.a) a|. When the spread
is within ``face_tolerance`` the disk lies flat: a *face* contact, whose impulse acts at the centre of
the bottom face (r_face = -(e/2) sign(n.a) a) and whose support can supply any couple keeping the
centre of pressure inside the face, so the disk neither rocks between rim points nor jitters.
A sphere touches at r_low = -R n.
"""

from __future__ import annotations

import math
from typing import NamedTuple

from components.messages import Shape
from components.rigid import quaternion as quat
from components.rigid.quaternion import Quat
from components.rigid.vec import Vec, dot

FLAT_SIN = 1e-9  # below this sin(tilt) the rim direction of a disk is round-off: use the face centre


class Plane(NamedTuple):
    """A plane through ``point`` [m] with unit ``normal`` pointing out of the solid (world frame)."""

    normal: Vec
    point: Vec

    def height(self, p: Vec) -> float:
        """Signed distance [m] of point p above the plane (negative: inside the solid)."""
        n, o = self.normal, self.point
        return n[0] * (p[0] - o[0]) + n[1] * (p[1] - o[1]) + n[2] * (p[2] - o[2])


def slope_plane(point: Vec, slope_deg: float, downhill_deg: float = 0.0) -> Plane:
    """A plane through ``point`` rising at ``slope_deg`` from horizontal, descending towards the
    azimuth ``downhill_deg`` (from +x towards +y). A slope of 0 is the horizontal plane, normal +z."""
    phi, psi = math.radians(slope_deg), math.radians(downhill_deg)
    s = math.sin(phi)
    return Plane((s * math.cos(psi), s * math.sin(psi), math.cos(phi)), point)


class ContactGeometry(NamedTuple):
    """Where a body meets a plane.

    r_low: (3,) offset [m] of the lowest body point from the centre of mass (world frame);
    r_ref: (3,) offset [m] of the point where the contact impulse acts (r_low, or the bottom face
    centre for a face contact); gap: height [m] of the lowest point above the plane (negative:
    penetration); face: true for a disk lying flat within the face tolerance.
    """

    r_low: Vec
    r_ref: Vec
    gap: float
    face: bool


def contact_geometry(shape: Shape, radius: float, thickness: float, position: Vec, q: Quat,
                     plane: Plane, face_tolerance: float) -> ContactGeometry:
    """The lowest point of a disk or sphere at (position, q) relative to ``plane``."""
    n = plane.normal
    if shape is Shape.SPHERE:
        r = (-radius * n[0], -radius * n[1], -radius * n[2])
        return ContactGeometry(r, r, plane.height(position) - radius, False)
    a = quat.body_axis(q)
    ca = dot(n, a)
    side = 0.5 * thickness * (1.0 if ca > 0 else (-1.0 if ca < 0 else 0.0))
    r_face = (-side * a[0], -side * a[1], -side * a[2])
    p = (n[0] - ca * a[0], n[1] - ca * a[1], n[2] - ca * a[2])
    sin_tilt = math.sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2])
    # The lowest rim point is R sin(tilt) below the face centre. Computing the gap that way keeps it
    # exact for a flat disk, where p is round-off noise and its direction (rho) is meaningless.
    gap = plane.height((position[0] + r_face[0], position[1] + r_face[1], position[2] + r_face[2]))
    gap -= radius * sin_tilt
    face = 2.0 * radius * sin_tilt <= face_tolerance
    if sin_tilt > FLAT_SIN:
        k = -radius / sin_tilt
        r_low = (r_face[0] + k * p[0], r_face[1] + k * p[1], r_face[2] + k * p[2])
    else:
        r_low = r_face  # flat: the whole bottom face is equally low
    return ContactGeometry(r_low, r_face if face else r_low, gap, face)
