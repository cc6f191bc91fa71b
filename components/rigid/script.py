"""Scripted motion: piecewise-linear keyframes with their exact rate and integral.

Used by RigidBody's scripted attitude and scripted horizontal velocity (the proposal's objective 5:
test the water with "pre-scripted changes to the orientation and horizontal velocities"). Values are
held constant before the first and after the last keyframe.
"""

from __future__ import annotations

import bisect
import itertools
from collections.abc import Sequence


def keyframe_problems(rows: Sequence[Sequence[float]]) -> list[str]:
    """Problems with keyframe rows ``[t, value...]``: times must be >= 0 and strictly increasing."""
    problems = []
    times = [row[0] for row in rows]
    if times and times[0] < 0:
        problems.append(f"keyframe times must be >= 0 s (got {times[0]:g})")
    for a, b in itertools.pairwise(times):
        if not b > a:
            problems.append(f"keyframe times must increase strictly (got {a:g} then {b:g})")
            break
    return problems


class Keyframes:
    """A piecewise-linear function of time [s] through rows ``[t, v_1, ..., v_k]``.

    :meth:`value` interpolates, :meth:`rate` is the slope of the segment holding t (right-continuous,
    0 outside the keyframes) and :meth:`integral` is the exact integral from 0 to t.
    """

    def __init__(self, rows: Sequence[Sequence[float]]):
        if not rows:
            raise ValueError("keyframes need at least one row")
        problems = keyframe_problems(rows)
        if problems:
            raise ValueError("; ".join(problems))
        self.times = [float(r[0]) for r in rows]
        self.values = [tuple(float(x) for x in r[1:]) for r in rows]
        self.width = len(self.values[0])
        # cumulative integral at each keyframe time (from t = 0, holding the first value before it)
        acc = tuple(self.times[0] * v for v in self.values[0])
        self._cumulative = [acc]
        for i in range(1, len(self.times)):
            h = self.times[i] - self.times[i - 1]
            pairs = zip(acc, self.values[i - 1], self.values[i], strict=True)
            acc = tuple(a + 0.5 * h * (p + c) for a, p, c in pairs)
            self._cumulative.append(acc)

    def _segment(self, t: float) -> int:
        """Index i of the keyframe segment [t_i, t_{i+1}) holding t (-1 before, last index after)."""
        return bisect.bisect_right(self.times, t) - 1

    def value(self, t: float) -> tuple[float, ...]:
        i = self._segment(t)
        if i < 0:
            return self.values[0]
        if i >= len(self.times) - 1:
            return self.values[-1]
        t0, t1 = self.times[i], self.times[i + 1]
        s = (t - t0) / (t1 - t0)
        return tuple(a + s * (b - a) for a, b in zip(self.values[i], self.values[i + 1], strict=True))

    def rate(self, t: float) -> tuple[float, ...]:
        i = self._segment(t)
        if i < 0 or i >= len(self.times) - 1:
            return (0.0,) * self.width
        h = self.times[i + 1] - self.times[i]
        return tuple((b - a) / h for a, b in zip(self.values[i], self.values[i + 1], strict=True))

    def integral(self, t: float) -> tuple[float, ...]:
        """Exact integral of the function from 0 to t."""
        i = self._segment(t)
        if i < 0:
            return tuple(t * v for v in self.values[0])
        here = self.value(t)
        dt = t - self.times[i]
        rows = zip(self._cumulative[i], self.values[i], here, strict=True)
        return tuple(c + 0.5 * dt * (a + b) for c, a, b in rows)
