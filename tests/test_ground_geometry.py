"""Planes and the lowest points of disks and spheres (components.contact.geometry)."""

from __future__ import annotations

import math

import pytest

from components.contact.geometry import Plane, contact_geometry, slope_plane
from components.messages import Shape
from components.rigid import quaternion as quat

FLOOR = Plane((0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
R, E = 0.05, 0.006


def test_slope_plane_normal_tilts_towards_the_downhill_direction():
    """A 30 degree slope descending towards +y has normal (0, sin 30, cos 30)."""
    plane = slope_plane((0.0, 0.0, 0.0), 30.0, 90.0)
    assert plane.normal == pytest.approx((0.0, 0.5, math.sqrt(3) / 2), abs=2e-16)
    assert slope_plane((1.0, 2.0, 3.0), 0.0).normal == (0.0, 0.0, 1.0)


def test_plane_height_is_the_signed_distance():
    """height(p) = n.(p - point): positive above, negative inside."""
    plane = slope_plane((0.0, 0.0, -1.0), 0.0)
    assert plane.height((5.0, 5.0, -0.5)) == 0.5
    assert plane.height((0.0, 0.0, -1.5)) == -0.5


def test_sphere_touches_at_its_bottom():
    """A sphere's lowest point is R below its centre along the normal; gap = height - R."""
    g = contact_geometry(Shape.SPHERE, 0.02, 0.0, (0.0, 0.0, 0.03), quat.IDENTITY, FLOOR, 1e-5)
    assert g.r_low == (-0.0, -0.0, -0.02)
    assert g.gap == pytest.approx(0.01)
    assert not g.face


@pytest.mark.parametrize("tilt_deg", [5.0, 30.0, 60.0, 89.0])
def test_tilted_disk_touches_at_the_rim_corner(tilt_deg):
    """A disk tilted by theta about x touches at its lower rim corner, R sin(theta) + (e/2) cos(theta)
    below the centre."""
    th = math.radians(tilt_deg)
    q = quat.from_axis_angle((1.0, 0.0, 0.0), th)
    g = contact_geometry(Shape.DISK, R, E, (0.0, 0.0, 0.1), q, FLOOR, 1e-5)
    assert g.gap == pytest.approx(0.1 - R * math.sin(th) - 0.5 * E * math.cos(th), rel=1e-14)
    expected = (0.0, -R * math.cos(th) + 0.5 * E * math.sin(th), -R * math.sin(th) - 0.5 * E * math.cos(th))
    assert g.r_low == pytest.approx(expected, rel=1e-14, abs=1e-18)
    assert not g.face


def test_disk_on_its_edge_touches_at_mid_thickness():
    """A vertical disk touches on its rim band: R below the centre, within the thickness."""
    q = quat.from_axis_angle((1.0, 0.0, 0.0), math.pi / 2)
    g = contact_geometry(Shape.DISK, R, E, (0.0, 0.0, R), q, FLOOR, 1e-5)
    assert g.gap == pytest.approx(0.0, abs=1e-17)
    assert g.r_low[2] == pytest.approx(-R, abs=1e-17)
    assert abs(g.r_low[1]) <= 0.5 * E


def test_flat_disk_is_a_face_contact_at_its_face_centre():
    """A flat disk (either face down) is a face contact acting at the centre of the lower face."""
    for q in (quat.IDENTITY, quat.from_axis_angle((1.0, 0.0, 0.0), math.pi)):
        g = contact_geometry(Shape.DISK, R, E, (0.0, 0.0, 0.5 * E), q, FLOOR, 1e-5)
        assert g.face
        assert g.gap == pytest.approx(0.0, abs=1e-17)
        assert g.r_ref == pytest.approx((0.0, 0.0, -0.5 * E), abs=1e-17)


def test_disk_flat_on_a_slope_to_round_off_has_an_exact_gap():
    """A disk laid on a 20 degree slope (its axis equal to the normal only to round-off) is a face
    contact with a gap of round-off size, not the height of an arbitrary rim point."""
    plane = slope_plane((0.0, 0.0, 0.0), 20.0)
    q = quat.from_axis_angle((0.0, 1.0, 0.0), math.radians(20.0))
    centre = tuple(0.5 * E * c for c in plane.normal)
    g = contact_geometry(Shape.DISK, R, E, centre, q, plane, 1e-5)
    assert g.face
    assert abs(g.gap) < 1e-17


def test_face_tolerance_bounds_the_rim_height_spread():
    """The face contact holds while 2 R sin(tilt) <= face_tolerance, and the rim corner is used beyond."""
    tol = 1e-5
    inside = quat.from_axis_angle((1.0, 0.0, 0.0), math.asin(0.99 * tol / (2 * R)))
    outside = quat.from_axis_angle((1.0, 0.0, 0.0), math.asin(1.01 * tol / (2 * R)))
    assert contact_geometry(Shape.DISK, R, E, (0.0, 0.0, 0.01), inside, FLOOR, tol).face
    g = contact_geometry(Shape.DISK, R, E, (0.0, 0.0, 0.01), outside, FLOOR, tol)
    assert not g.face and g.r_ref == g.r_low
