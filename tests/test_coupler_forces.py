"""Water force laws (components.coupler.forces) against their closed forms."""

import math

import pytest

from components.coupler.forces import (
    C_MIN,
    friction_factor,
    plate_force,
    pressure_magnitude,
    segment_area,
    ventilation,
    wave_drag_magnitude,
)


def test_c_min_is_the_capillary_gravity_minimum():
    """c_min = (4 g gamma / rho)^(1/4) is 0.23 m/s for water."""
    assert C_MIN == pytest.approx(0.23, abs=1e-3)


def test_pressure_only_on_faces_moving_into_the_water():
    """The pressure is zero for u.n <= 0 and 1/2 rho (C_L |u| u.n + C_N (u.n)^2) otherwise."""
    assert pressure_magnitude(3.0, -0.5, 1000.0, 1.0, 1.4) == 0.0
    assert pressure_magnitude(3.0, 0.0, 1000.0, 1.0, 1.4) == 0.0
    assert pressure_magnitude(3.0, 0.5, 1000.0, 1.0, 0.0) == pytest.approx(750.0)
    assert pressure_magnitude(3.0, 0.5, 1000.0, 1.0, 1.4) == pytest.approx(750.0 + 175.0)


def test_impact_pressure_only_where_a_blunt_body_advances():
    """A blunt body's pressure (the law with C_L = 0, C_N = C_B) is zero for u.n <= 0 and
    1/2 rho C_B (u.n)^2 otherwise, whatever the speed along the surface."""
    assert pressure_magnitude(3.0, -0.5, 1000.0, 0.0, 1.0) == 0.0
    assert pressure_magnitude(3.0, 0.0, 1000.0, 0.0, 1.0) == 0.0
    assert pressure_magnitude(3.0, 2.0, 1000.0, 0.0, 1.0) == pytest.approx(2000.0)
    assert pressure_magnitude(3.0, 2.0, 1000.0, 0.0, 0.5) == pytest.approx(1000.0)


def test_pressure_on_a_plate_is_the_rosellini_law():
    """With u.n = U sin(alpha + beta), pressure times area is 1/2 rho C_L U^2 S sin(alpha + beta)."""
    u, alpha, beta, area = 4.0, math.radians(20), math.radians(15), 0.003
    p = pressure_magnitude(u, u * math.sin(alpha + beta), 1000.0, 1.0, 0.0)
    assert p * area == pytest.approx(plate_force(1000.0, 1.0, u, area, alpha, beta))


def test_friction_factor():
    """The friction traction is -1/2 rho C_f |u| u_t."""
    assert friction_factor(2.0, 1000.0, 0.1) == pytest.approx(100.0)


def test_wave_drag_vanishes_below_c_min_and_grows_above():
    """Wave drag is zero up to c_min, continuous there, and 1/2 rho C_W (V/L)(U^2 - c_min^2) / (1 + Fr^2)."""
    args = (1e-5, 0.1, 1000.0, 0.3, C_MIN, 9.81)
    assert wave_drag_magnitude(0.2, *args) == 0.0
    assert wave_drag_magnitude(C_MIN, *args) == 0.0
    assert wave_drag_magnitude(C_MIN * 1.0001, *args) < 1e-6
    assert wave_drag_magnitude(1.0, *args) == pytest.approx(
        0.5 * 1000 * 0.3 * 1e-4 * (1 - C_MIN**2) / (1 + 1 / 0.981))
    assert wave_drag_magnitude(1.0, 0.0, 0.1, 1000.0, 0.3, C_MIN, 9.81) == 0.0


def test_wave_drag_fades_with_the_depth_of_the_body_under_the_surface():
    """A body whose top is d under the surface makes waves through the pressure it sets up there:
    Havelock's factor exp(-2 g d / U^2) on the surface-piercing law, 1 at d = 0 (continuous as the
    water closes over the body), 0.0293 for a top 18 cm under at 1 m/s."""
    args = (4.0 / 3.0 * math.pi * 0.02**3, 0.04, 1000.0, 0.3, C_MIN, 9.81)
    at_surface = wave_drag_magnitude(1.0, *args)
    assert wave_drag_magnitude(1.0, *args, 0.0) == at_surface
    assert wave_drag_magnitude(1.0, *args, -0.01) == at_surface
    assert wave_drag_magnitude(1.0, *args, 1e-9) == pytest.approx(at_surface, rel=1e-7)
    assert wave_drag_magnitude(1.0, *args, 0.18) == pytest.approx(at_surface * math.exp(-2 * 9.81 * 0.18), rel=1e-12)
    assert wave_drag_magnitude(1.0, *args, 0.18) / at_surface == pytest.approx(0.0293, abs=1e-4)
    assert wave_drag_magnitude(4.0, *args, 0.18) / wave_drag_magnitude(4.0, *args) == pytest.approx(
        math.exp(-2 * 9.81 * 0.18 / 16.0), rel=1e-12)  # faster: longer waves, which reach deeper


def test_wave_drag_saturates_past_the_hull_speed():
    """Far above sqrt(g L) the wave drag tends to 1/2 C_W rho g V_sub, a share of the displaced weight."""
    far = wave_drag_magnitude(200.0, 1e-5, 0.1, 1000.0, 0.3, C_MIN, 9.81)
    assert far == pytest.approx(0.5 * 0.3 * 1000 * 9.81 * 1e-5, rel=1e-3)
    assert wave_drag_magnitude(8.0, 1e-5, 0.1, 1000.0, 0.3, C_MIN, 9.81) < far


def test_segment_area_limits():
    """The circular segment grows from 0 to a half disk at s_f = R and to the full disk at 2R."""
    r = 0.05
    assert segment_area(r, 0.0) == 0.0
    assert segment_area(r, r) == pytest.approx(math.pi * r * r / 2)
    assert segment_area(r, 2 * r) == pytest.approx(math.pi * r * r)
    assert segment_area(r, 3 * r) == pytest.approx(math.pi * r * r)
    # small immersion: S ~ (4 sqrt(2) / 3) sqrt(R) s_f^(3/2)
    s = 1e-6
    assert segment_area(r, s) == pytest.approx(4 * math.sqrt(2) / 3 * math.sqrt(r) * s**1.5, rel=1e-4)


def test_ventilation_dries_fast_receding_faces():
    """A face receding faster than sqrt(2 g d) is mostly in air; one sliding along itself stays wet."""
    assert ventilation(0.5, 0.01, 9.81) == 1.0
    assert ventilation(0.0, 0.0, 9.81) == 1.0
    assert ventilation(-math.sqrt(2 * 9.81 * 0.05), 0.05, 9.81) == pytest.approx(0.5)
    assert ventilation(-4.0, 0.01, 9.81) < 0.02
    assert ventilation(-0.1, 0.05, 9.81) > 0.98
    assert ventilation(-0.1, 0.0, 9.81) == 0.0
