"""Numba's start-up (components.compiled.start) leaves out only its probes of optional packages."""

from __future__ import annotations

import subprocess
import sys
import textwrap


def run_fresh(code: str) -> str:
    """Run ``code`` in a new interpreter (nothing imported yet) and return what it printed."""
    done = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], capture_output=True, text=True,
                          check=True, timeout=300)
    return done.stdout.strip()


def test_start_does_not_import_the_probed_packages_and_they_still_work():
    """After start(), scipy.linalg and cffi are not loaded, import normally, and a kernel calling
    BLAS (np.dot) still compiles and runs."""
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
    """)
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
