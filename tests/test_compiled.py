"""Numba's start-up (components.compiled.start) leaves out only its probes of optional packages."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest


def run_fresh(code: str, cache: Path | None = None) -> str:
    """Run ``code`` in a new interpreter (nothing imported yet; numba's kernel cache in ``cache``
    when given) and return what it printed."""
    env = None if cache is None else {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          check=True, timeout=300, env=env)
    return done.stdout.strip()


@pytest.mark.parametrize("cache", ["cold", "warm"])
def test_start_does_not_import_the_probed_packages_and_they_still_work(cache, tmp_path):
    """After start(), whether it compiled its own kernel (a cold cache: the compiler starts then)
    or loaded it, scipy.linalg and cffi are not loaded, import normally, and a kernel calling BLAS
    (np.dot) still compiles and runs."""
    folder = tmp_path / "kernels"
    if cache == "warm":
        run_fresh("from components import compiled; compiled.start()", folder)
    out = run_fresh("""
        import sys
        import numpy as np
        from numba import njit
        from components import compiled
        compiled.start()
        print(sorted(m for m in ("scipy.linalg", "cffi") if m in sys.modules))
        import scipy.linalg
        @njit
        def dot(a, b):
            return np.dot(a, b)
        print(dot(np.arange(3.0), np.arange(3.0)), scipy.linalg.solve(np.eye(2), np.ones(2)).tolist())
    """, folder)
    assert out.splitlines() == ["[]", "5.0 [1.0, 1.0]"]


def test_start_twice_is_harmless_and_restores_the_import_system():
    """start() runs once per process and leaves no finder of its own behind."""
    out = run_fresh("""
        import sys
        from components import compiled
        before = list(sys.meta_path)
        compiled.start()
        compiled.start()
        print(sys.meta_path == before)
    """)
    assert out == "True"


def test_arrays_are_typed_as_numba_types_them_and_numpy_ma_is_not_imported():
    """After start(), kernels called with arrays of every layout, a read-only view, several dtypes
    (records included) get the type numba's own typing gives, without numpy.ma being imported; a
    masked array and an unsupported dtype are still refused with numba's own errors."""
    out = run_fresh("""
        import sys
        import numpy as np
        from numba import njit, typeof
        from components import compiled
        compiled.start()

        @njit
        def first(a):
            return a.flat[0]

        base = np.arange(24.0).reshape(4, 6)
        readonly = np.broadcast_to(np.float64(2.0), (3, 3))
        record = np.zeros(3, dtype=[("x", "f8"), ("n", "i4")])
        arrays = [base, base.T, base[:, ::2], base[1], np.asfortranarray(base), readonly, np.array(5.0),
                  np.zeros(4, np.int8), np.zeros(2, np.complex128), np.zeros(3, bool), record,
                  np.zeros(2, "datetime64[ns]"), np.ones((2, 2, 2, 2), np.float32)]
        print(first(base), first(readonly), first(np.zeros(4, np.int8)))
        ours = [typeof(a) for a in arrays]
        print("numpy.ma" in sys.modules)  # numba's own typing, compared with below, imports it
        same = [t == compiled.numba_typeof_ndarray(a, None) for t, a in zip(ours, arrays)]
        print(all(same), [i for i, s in enumerate(same) if not s])
        for bad in (np.ma.masked_array([1.0, 2.0], mask=[0, 1]), np.zeros(2, ">f8")):
            try:
                typeof(bad)
            except Exception as exc:
                print(type(exc).__name__)
    """)
    assert out.splitlines() == ["0.0 2.0 0", "False", "True []", "NumbaTypeError", "NumbaValueError"]


def test_numba_extensions_are_still_loaded_when_installed_and_not_looked_for_again_when_not(tmp_path):
    """With no numba extension installed, start() spares numba's own scan of the installed packages
    (one scan in all, the registry's); with one installed, numba loads it."""
    (tmp_path / "fake_numba_extension.py").write_text("def init():\n    print('extension loaded')\n")
    code = """
        import importlib.metadata, sys
        sys.path.insert(0, {folder!r})
        scans = []
        def counted(**kw):  # the installed packages: the fake extension, or nothing
            scans.append(kw)
            found = importlib.metadata.EntryPoints([importlib.metadata.EntryPoint(
                "init", "fake_numba_extension:init", "numba_extensions")] if {installed} else [])
            return found.select(**kw) if kw else found
        importlib.metadata.entry_points = counted
        from components import compiled
        compiled.start()
        print(len(scans), "scans")
    """
    assert run_fresh(code.format(folder=str(tmp_path), installed=True)) == "extension loaded\n2 scans"
    assert run_fresh(code.format(folder=str(tmp_path), installed=False)) == "1 scans"


def test_a_kernel_from_the_cache_runs_without_the_compiler_and_a_new_kernel_still_compiles(tmp_path):
    """After start(), kernels loaded from numba's disk cache (one that allocates an array, so it needs
    numba's runtime; one with a parallel loop, which needs numba's threads) run without numba's
    compiler starting (its lowering modules stay unimported); a kernel compiled afterwards starts the
    compiler then, still without the probed packages."""
    (tmp_path / "ramp_kernel.py").write_text(textwrap.dedent("""
        import numpy as np
        from numba import njit, prange

        @njit(cache=True)
        def ramp(n):
            out = np.empty(n)
            for i in range(n):
                out[i] = 0.5 * i
            return out

        @njit(cache=True, parallel=True)
        def doubled(a):
            out = np.empty_like(a)
            for i in prange(a.size):
                out[i] = 2.0 * a[i]
            return out
    """))
    code = f"""
        import sys
        sys.path.insert(0, {str(tmp_path)!r})
        from components import compiled
        compiled.start()
        import ramp_kernel
        ramp = ramp_kernel.ramp(4)
        doubled = ramp_kernel.doubled(ramp)
        hits = sum(ramp_kernel.ramp.stats.cache_hits.values()) + sum(ramp_kernel.doubled.stats.cache_hits.values())
        print(ramp.tolist(), doubled.tolist(), hits, "numba.np.arraymath" in sys.modules)
    """
    compiled = "[0.0, 0.5, 1.0, 1.5] [0.0, 1.0, 2.0, 3.0]"
    assert run_fresh(code) == compiled + " 0 True"  # compiled, so the compiler started
    again = code + """
        import numpy as np
        from numba import njit
        @njit
        def total(a):
            return np.sum(a)
        print(total(ramp_kernel.ramp(4)), "numba.np.arraymath" in sys.modules, "scipy.linalg" in sys.modules)
    """
    assert run_fresh(again).splitlines() == [compiled + " 2 False", "3.0 True False"]


def test_the_reference_skip_from_the_kernel_cache_never_starts_numba_compiler():
    """A run of the reference skip whose kernels are in numba's disk cache (a second run) loads them
    all without numba's compiler starting: nothing compiles and numba's lowering modules stay
    unimported (each process's start-up saves their 0.1 s; a kernel missing from the cache, or a
    load that starts the compiler, would show here)."""
    scene = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"
    code = f"""
        import sys
        from cosim.jit_time import may_have_compiled
        from cosim.runner import run_scene
        from cosim.scenario import load
        outcome = run_scene(load({str(scene)!r}, ["until=0.15"]), None, progress=False)
        print(outcome.result.status, may_have_compiled(), "numba.np.arraymath" in sys.modules)
    """
    run_fresh(code)  # a cold cache (a fresh checkout) compiles here
    assert run_fresh(code) == "ok False False"
