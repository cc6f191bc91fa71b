"""Piecewise-linear keyframes for scripted motion (components.rigid.script)."""

from __future__ import annotations

import pytest
from scipy.integrate import quad

from components.rigid.script import Keyframes, keyframe_problems

ROWS = [(0.5, 10.0, 0.0), (1.0, 20.0, -2.0), (3.0, 0.0, 2.0)]


def test_value_interpolates_between_keyframes_and_holds_outside():
    """Values are linear between keyframes and held before the first and after the last."""
    k = Keyframes(ROWS)
    assert k.value(0.75) == pytest.approx((15.0, -1.0))
    assert k.value(0.0) == (10.0, 0.0)
    assert k.value(9.0) == (0.0, 2.0)


def test_rate_is_the_slope_of_the_current_segment():
    """The rate is the segment's slope (right-continuous at keyframes) and zero outside."""
    k = Keyframes(ROWS)
    assert k.rate(0.6) == pytest.approx((20.0, -4.0))
    assert k.rate(1.0) == pytest.approx((-10.0, 2.0))
    assert k.rate(0.2) == (0.0, 0.0)
    assert k.rate(3.0) == (0.0, 0.0)


@pytest.mark.parametrize("t", [0.3, 0.5, 0.8, 1.0, 2.2, 3.0, 4.5])
def test_integral_is_exact(t):
    """integral(t) equals the quadrature of value() from 0 to t."""
    k = Keyframes(ROWS)
    for i in range(2):
        expected = quad(lambda s, i=i: k.value(s)[i], 0.0, t, points=[0.5, 1.0, 3.0], epsabs=1e-13)[0]
        assert k.integral(t)[i] == pytest.approx(expected, abs=1e-12)


def test_keyframe_problems_name_the_rule():
    """Negative or non-increasing times are reported in plain words."""
    assert keyframe_problems([(-1.0, 0.0)]) == ["keyframe times must be >= 0 s (got -1)"]
    assert keyframe_problems([(0.0, 0.0), (1.0, 0.0), (1.0, 2.0)]) == [
        "keyframe times must increase strictly (got 1 then 1)"]
    assert keyframe_problems([]) == []


def test_bad_keyframes_are_rejected():
    """Keyframes need at least one row and increasing times."""
    with pytest.raises(ValueError, match="at least one row"):
        Keyframes([])
    with pytest.raises(ValueError, match="increase strictly"):
        Keyframes([(1.0, 0.0), (0.5, 1.0)])


def test_a_scripted_body_at_a_keyframe_is_published_as_the_script_is_there():
    """The script is read at the step's end as the scheduler's clock has it: 1.599 + 0.001 is
    1.5999999999999999 in floating point, and a body whose tilt and velocity come to rest at their
    1.6 s keyframe was published there still turning at the segment before's rate, 9e-16 m/s along x
    and 5e-15 deg tilted."""
    from components.rigid_body import RigidBody
    from cosim.params import build

    problems: list[str] = []
    params = build(RigidBody.Params, {"scripted_tilt_deg": [[0, 15], [1.0, 15], [1.6, 0]],
                                      "scripted_velocity": [[0, 2.5, 0], [1.0, 2.5, 0], [1.6, 0, 0]],
                                      "gravity": [0, 0, 0]}, "disk", problems)
    assert problems == []
    body, dt = RigidBody("disk", params), 1_000_000
    for k in range(1600):
        state = body.step(k * dt, dt, {"wrench": None, "impulse": None})["state"]
        if k + 1 == 1000:  # right-continuous: the rate of the segment that starts there
            assert state.angular_velocity[1] == pytest.approx(15 / 0.6 * 3.141592653589793 / 180)
    assert state.angular_velocity[1] == 0.0
    assert state.velocity[0] == 0.0 and state.attack_angle_deg == 0.0
    assert state.position[0] == pytest.approx(2.5 * 1.0 + 2.5 * 0.6 / 2, abs=1e-12)


def test_a_velocity_along_the_water_beside_a_scripted_one_is_refused():
    """The script sets the horizontal velocity from t = 0: a velocity's x and y given too were dropped
    without a word (3 m/s given, 2.5 m/s run). They are refused as a tilt beside a scripted tilt is;
    the vertical velocity stays free."""
    from components.rigid_body import RigidBody
    from cosim.params import build

    problems: list[str] = []
    build(RigidBody.Params, {"scripted_velocity": [[0, 2.5, 0]], "velocity": [3, 0, -1]}, "disk", problems)
    assert problems == ["disk.velocity: its x and y are set by scripted_velocity; leave them 0 (z, the vertical "
                        "velocity, stays free) (got [3.0, 0.0, -1.0])"]
    problems.clear()
    build(RigidBody.Params, {"scripted_velocity": [[0, 2.5, 0]], "velocity": [0, 0, -1]}, "disk", problems)
    assert problems == []
