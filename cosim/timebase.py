"""Integer simulation time.

The master clock counts ticks; tick k sits at ``t_k = k * dt_ns`` nanoseconds. Time is never
accumulated as ``t += dt`` in floating point, so a run of any length lands exactly on its ticks and
two runs with the same inputs agree to the nanosecond.
"""

from __future__ import annotations

import math

NS_PER_S = 1_000_000_000


def seconds_to_ns(seconds: float, *, what: str = "time") -> int:
    """Convert seconds to an integer number of nanoseconds.

    Raises ValueError when ``seconds`` is not a whole number of nanoseconds, because a silently
    rounded step would make ``t_k = k * dt`` drift away from the time the user asked for. What is
    allowed off a whole number is the float's own round-off, 8 of its last bits. (It was a millionth
    of the time: from 0.5 ms up, a dt of 0.0012345678912 s ran as 1234568 ns without a word, while
    1.2345e-6 s was refused.)
    """
    exact = seconds * NS_PER_S
    ns = round(exact)
    if abs(exact - ns) > 8.0 * math.ulp(exact):
        raise ValueError(f"{what} must be a whole number of nanoseconds (got {seconds!r} s)")
    return int(ns)


def ns_to_seconds(ns: int) -> float:
    """Nanoseconds to seconds as a float (the only place floats enter the clock)."""
    return ns / NS_PER_S


def tick_time_ns(tick: int, dt_ns: int) -> int:
    """Time of tick ``tick`` in nanoseconds: ``tick * dt_ns`` exactly."""
    return tick * dt_ns


def ticks_reaching(t_ns: int, step_ns: int) -> int:
    """How many steps of ``step_ns`` a run takes to reach ``t_ns`` [ns]: its last step reaches or
    passes it (a run's end off the step grid ends on the step after it)."""
    return -(-t_ns // step_ns)


def format_time(ns: int) -> str:
    """Human-readable simulation time, e.g. ``1.2345 s``."""
    return f"{ns / NS_PER_S:.6g} s"


def exact_seconds(ns: int) -> str:
    """A time of ``ns`` whole nanoseconds in seconds, every digit it has and no more (``10.00004``,
    ``0.5``, ``10``): two times :g would both write 10 never read alike."""
    whole, part = divmod(abs(ns), NS_PER_S)
    digits = f"{part:09d}".rstrip("0")
    return f"{'-' if ns < 0 else ''}{whole}{'.' + digits if digits else ''}"


def exact_milliseconds(ns: int) -> str:
    """A time of ``ns`` whole nanoseconds in milliseconds, every digit it has and no more (``0.5``,
    ``1.234567``), as :func:`exact_seconds` writes seconds."""
    return exact_seconds(ns * 1000)


def step_decimals(step_ns: int) -> int:
    """The decimals [of a second] a time on a grid of ``step_ns`` needs to be written exactly: 4 for
    0.5 ms, 5 for 0.25 ms, 3 for 1 ms, 0 for whole seconds."""
    if step_ns <= 0:
        return 9
    decimals = 9
    while decimals > 0 and step_ns % 10 == 0:
        step_ns //= 10
        decimals -= 1
    return decimals
