"""Numba's one-time start-up, done when a component is built rather than inside its first steps.

The first compiled kernel a process calls starts numba (its target context, its runtime and, numba's
own way even for a kernel read from its cache, its whole compiler); each later kernel only loads its
own machine code from the cache (milliseconds).
Components with compiled kernels call :func:`start` in their ``setup``, so a run's wall time and
real-time factor measure the simulation, not that start-up.

Numba's compiler probes two optional packages when it starts (its typing and target contexts): it
imports ``scipy.linalg`` to see whether BLAS is there (for ``np.dot`` and friends) and ``cffi`` to
support cffi functions. With SciPy 1.17 the first costs about 0.45 s (scipy.linalg clones numpy's
namespace, which loads numpy.f2py, numpy.ma and numpy.testing), the second about 0.1 s: together
more than importing numba itself, for features no kernel here uses. :func:`start` therefore has
that start, whenever it comes (in :func:`start` on a cold cache, else at the first kernel
compiled), find both absent; nothing else is affected: they can be imported normally afterwards,
and a kernel that does call BLAS still compiles (numba imports SciPy again when it types such a
call).

The first call of a kernel with an array of a kind not seen before types that array in Python, and
numba's typing of arrays first refuses masked arrays with ``isinstance(val, np.ma.MaskedArray)``:
reading ``np.ma`` imports numpy.ma (7 ms, more while the garbage collector runs, in every
run's first step). An array whose type is
exactly ``np.ndarray`` is never masked (masked arrays are a subclass), so :func:`start` has numba type
such an array without that check, to the same type (tests compare them); any other array still goes
through numba's own typing.

Loading a kernel from the cache needs almost none of that start. Numba's cache load first starts
the compiler in full (its typing and lowering registries: some 40 modules of numba's own, about
0.1 s, a third of ``import numba``), though machine code read from the cache is only linked against
numba's runtime and C helpers, which are there as soon as the target exists. With no numba
extension installed (whose ``typeof`` of its own types a cached kernel's arguments might need),
:func:`start` has a cache load start only the runtime; the first kernel that is really compiled
starts the compiler in full, as numba always does before compiling. Either way the code run is the
machine code the cache holds.

Numba's start also looks for its extensions (entry points ``numba_extensions``, name ``init``) with
a scan of every installed package of its own; :func:`start` looks in the scan the component registry
has made already (:func:`cosim.registry.installed_entry_points`) and, when there are none, tells numba
its extensions are loaded; when there are some, numba loads them itself, as it always does.
"""

from __future__ import annotations

import importlib.abc
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import cache

import numpy as np
from numba import njit
from numba.core import caching, errors, types
from numba.core.cpu import CPUContext
from numba.core.runtime import rtsys
from numba.core.typing.context import Context as TypingContext
from numba.core.typing.typeof import typeof_impl
from numba.np import numpy_support

from components import kernel_cache
from cosim.jit_time import watch_compiles

kernel_cache.install()  # before the cached kernels below: their cache keyed on every kernel source

PROBED = ("scipy.linalg", "cffi")  # imported by numba's start-up only to probe optional features
_CACHE_LOAD_PARTS = ("load_overload", "_load_overload", "_guard_against_spurious_io_errors")  # numba's, used
# by _cache_loads_link_only: a numba without them loads from its cache its own way


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


def _no_extensions_to_load() -> bool:
    """Spare numba's scan for extensions when the registry's scan found none (see the module's text);
    True when numba has none to load."""
    from numba.core import entrypoints

    from cosim.registry import installed_entry_points

    if hasattr(entrypoints, "_already_initialized") and not installed_entry_points().select(
            group="numba_extensions", name="init"):
        entrypoints._already_initialized = True
        return True
    return False


def _compiler_start_without_probes() -> None:
    """Have numba's compiler start (whenever it comes: its typing context's, then its target
    context's) see the probed packages as absent."""
    for context in (TypingContext, CPUContext):
        full_start = context.refresh

        def refresh(self: object, full_start: Callable[[object], None] = full_start) -> None:
            with _without_probes():
                full_start(self)

        context.refresh = refresh


def _cache_loads_link_only() -> None:
    """Have a cache load of a CPU kernel start numba's runtime only, not its whole compiler."""
    full_load = caching.Cache.load_overload

    def load_overload(self: caching.Cache, sig: object, target_context: object) -> object:
        if not isinstance(target_context, CPUContext):
            return full_load(self, sig, target_context)
        rtsys.initialize(target_context)  # the runtime's symbols, which the cached code links against
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    caching.Cache.load_overload = load_overload


@cache
def start() -> None:
    """Start numba's runtime and code cache (its compiler too when a kernel must be compiled), once per process."""
    watch_compiles()  # a run's start-up that compiles leaves garbage to collect (cosim.cli.start_up_done)
    typeof_impl.register(np.ndarray)(typeof_plain_ndarray)
    _compiler_start_without_probes()
    if _no_extensions_to_load() and all(hasattr(caching.Cache, name) for name in _CACHE_LOAD_PARTS):
        _cache_loads_link_only()
    _touch(0.0)  # loads the runtime, or on a cold cache compiles: the compiler's start
