"""Integer simulation time."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from cosim.timebase import NS_PER_S, seconds_to_ns, tick_time_ns


@given(st.integers(1, 10**9), st.integers(0, 10**9))
def test_tick_time_is_exact_product(dt_ns, k):
    """t_k = k * dt_ns exactly, for any step and tick."""
    assert tick_time_ns(k, dt_ns) == k * dt_ns


@given(st.integers(1, 10**12))
def test_seconds_to_ns_round_trips_whole_nanoseconds(ns):
    """A whole number of nanoseconds given in seconds converts back exactly."""
    assert seconds_to_ns(ns / NS_PER_S) == ns


def test_fractional_nanoseconds_are_refused():
    """A step that is not a whole number of nanoseconds is an error, not a rounding."""
    with pytest.raises(ValueError, match=r"dt must be a whole number of nanoseconds \(got 1e-10 s\)"):
        seconds_to_ns(1e-10, what="dt")
