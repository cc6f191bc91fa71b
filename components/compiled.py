"""Numba's one-time start-up, done when a component is built rather than inside its first steps.

The first compiled kernel a process calls starts numba's compiler and code cache (its target context
and libraries: about half a second here); each later kernel only loads its own machine code from the
cache (milliseconds). Components with compiled kernels call :func:`start` in their ``setup``, so a
run's wall time and real-time factor measure the simulation, not that start-up.
"""

from __future__ import annotations

from functools import cache

from numba import njit


@njit(cache=True)
def _touch(x: float) -> float:  # pragma: no cover - compiled
    return x + 1.0


@cache
def start() -> None:
    """Start numba's compiler and code cache, once per process."""
    _touch(0.0)
