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
