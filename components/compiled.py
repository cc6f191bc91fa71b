"""Numba's one-time start-up, done when a component is built rather than inside its first steps.

The first compiled kernel a process calls starts numba's compiler and code cache (its target context
and libraries); each later kernel only loads its own machine code from the cache (milliseconds).
Components with compiled kernels call :func:`start` in their ``setup``, so a run's wall time and
real-time factor measure the simulation, not that start-up.

Numba's target context probes two optional packages when it starts: it imports ``scipy.linalg``
to see whether BLAS is there (for ``np.dot`` and friends) and ``cffi`` to support cffi functions.
With SciPy 1.17 the first costs about 0.45 s (scipy.linalg clones numpy's namespace, which loads
numpy.f2py, numpy.ma and numpy.testing), the second about 0.1 s: together more than importing
numba itself, for features no kernel here uses. :func:`start` therefore starts numba with both
probes answered "not here"; nothing else is affected: they can be imported normally afterwards, and a
kernel that does call BLAS still compiles (numba imports SciPy again when it types such a call).

The first call of a kernel with an array of a kind not seen before types that array in Python, and
numba's typing of arrays first refuses masked arrays with ``isinstance(val, np.ma.MaskedArray)``:
reading ``np.ma`` imports numpy.ma (7 ms, more while the garbage collector runs, in every
run's first step). An array whose type is
exactly ``np.ndarray`` is never masked (masked arrays are a subclass), so :func:`start` has numba type
such an array without that check, to the same type (tests compare them); any other array still goes
through numba's own typing.

Numba's start also looks for its extensions (entry points ``numba_extensions``, name ``init``) with
a scan of every installed package of its own; :func:`start` looks in the scan the component registry
has made already (:func:`cosim.registry.installed_entry_points`) and, when there are none, tells numba
its extensions are loaded; when there are some, numba loads them itself, as it always does.
"""

from __future__ import annotations

import importlib.abc
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache

import numpy as np
from numba import njit
from numba.core import errors, types
from numba.core.typing.typeof import typeof_impl
from numba.np import numpy_support

from cosim.jit_time import watch_compiles

PROBED = ("scipy.linalg", "cffi")  # imported by numba's start-up only to probe optional features


@njit(cache=True)
def _touch(x: float) -> float:  # pragma: no cover - compiled
    return x + 1.0


class _Absent(importlib.abc.MetaPathFinder):
    """A finder that reports the probed packages as missing (only while installed)."""

    def find_spec(self, fullname: str, path: object = None, target: object = None) -> None:
        if fullname in PROBED:
            raise ModuleNotFoundError(f"{fullname} is left out of numba's start-up", name=fullname)
        return None


@contextmanager
def _without_probes() -> Iterator[None]:
    """While inside, the probed packages that are not imported yet look absent."""
    finder = _Absent()
    sys.meta_path.insert(0, finder)
    try:
        yield
    finally:
        sys.meta_path.remove(finder)


numba_typeof_ndarray = typeof_impl.dispatch(np.ndarray)  # numba's own typing of array arguments


def typeof_plain_ndarray(val: np.ndarray, c: object) -> types.Array:
    """numba's type of an array argument, without the masked-array check for an exact ``np.ndarray``
    (never masked): the check would import numpy.ma. Other arrays, and dtypes numba does not
    support (for its error), go to numba's own typing."""
    if type(val) is not np.ndarray:
        return numba_typeof_ndarray(val, c)
    try:
        dtype = numpy_support.from_dtype(val.dtype)
    except errors.NumbaNotImplementedError:
        return numba_typeof_ndarray(val, c)
    return types.Array(dtype, val.ndim, numpy_support.map_layout(val), readonly=not val.flags.writeable)


def _no_extensions_to_load() -> None:
    """Spare numba's scan for extensions when the registry's scan found none (see the module's text)."""
    from numba.core import entrypoints

    from cosim.registry import installed_entry_points

    if hasattr(entrypoints, "_already_initialized") and not installed_entry_points().select(
            group="numba_extensions", name="init"):
        entrypoints._already_initialized = True


@cache
def start() -> None:
    """Start numba's compiler and code cache, once per process."""
    watch_compiles()  # a run's start-up that compiles leaves garbage to collect (cosim.cli.start_up_done)
    typeof_impl.register(np.ndarray)(typeof_plain_ndarray)
    _no_extensions_to_load()
    with _without_probes():
        _touch(0.0)
