"""Numba's on-disk kernel cache, dropped whenever the source of any compiled kernel changes.

Numba keeps a kernel's machine code in ``__pycache__`` beside the file that defines it and trusts it
for as long as *that file* is unchanged. A kernel also holds, compiled into it, the kernels it calls
from other files and the constants it reads from them (``kernel.evaluate_into`` inside
``step_kernel.ring_step``, the effect flags of ``coupler.effects``): when only one of those files
changes, numba keeps loading the old code, and a checkout updated by ``git pull`` would simulate
with the previous physics. So :func:`refresh` fingerprints the text of every file compiled code is
built from (:data:`KERNEL_SOURCES`, kept complete by ``tests/test_kernel_cache.py``); when the
fingerprint differs from the one written beside the cache, the cached kernels of these files are
deleted and the next run compiles afresh the kernels it calls (about 20 s on two cores; a kernel no
run has called yet, or called with other argument types, is compiled by the first run that does).

It runs when the ``components`` package is imported, before any kernel can be called: reading and
checksumming the sources takes a fraction of a millisecond.

That alone does not cover a process that read the sources before they changed: it still compiles
from the old text, and what it writes to the cache after another process has dropped it (a sweep
left running across a ``git pull``, a test run beside an edit) was loaded by every later run, its
kernel's own file unchanged (numba keys a kernel's cache on that file alone): a coupler edited in
``kernel.py`` ran the old code through ``step_kernel.ring_step`` for as long as that cache lasted. So
each module of :data:`KERNEL_SOURCES` with cached kernels calls :func:`install` before them, and
numba's cache of this package's kernels is keyed on the fingerprint of all of them besides: a
kernel written from other sources than those on disk is never loaded, only compiled again.
"""

from __future__ import annotations

import os
import zlib
from pathlib import Path

PACKAGE = Path(__file__).resolve().parent
KERNEL_SOURCES = (  # relative to the package: the files whose code or constants compiled kernels hold
    "compiled.py",
    "coupler/effects.py",
    "coupler/forces.py",
    "coupler/geometry.py",
    "coupler/kernel.py",
    "coupler/met_surface.py",
    "coupler/step_kernel.py",
    "water/kernels_numba.py",
    "water/tiles.py",
    "water/windows.py",
)
STAMP = PACKAGE / "__pycache__" / "kernel-sources.stamp"
CACHE_SUFFIXES = (".nbi", ".nbc")  # numba's index and code files


def fingerprint() -> str:
    """Checksum (CRC-32) and length of the text of every kernel source, one line each: a change is to
    be noticed, not guarded against."""
    lines = []
    for name in KERNEL_SOURCES:
        text = (PACKAGE / name).read_bytes()
        lines.append(f"{name} {len(text)} {zlib.crc32(text):08x}")
    return "\n".join(lines) + "\n"


def cache_dirs(source: Path) -> list[Path]:
    """Where numba may keep the cache of ``source``'s kernels: its ``__pycache__``, and the folder
    mirroring it under ``NUMBA_CACHE_DIR`` when that is set."""
    dirs = [source.parent / "__pycache__"]
    user = os.environ.get("NUMBA_CACHE_DIR")
    if user:
        dirs.append(Path(user) / source.parent.relative_to(source.parent.anchor))
    return dirs


def cached_files() -> list[Path]:
    """The cache files numba wrote for the kernels of :data:`KERNEL_SOURCES`."""
    found = []
    for name in KERNEL_SOURCES:
        source = PACKAGE / name
        for folder in cache_dirs(source):
            if folder.is_dir():
                found += [p for p in folder.glob(f"{source.stem}.*") if p.suffix in CACHE_SUFFIXES]
    return found


def refresh() -> bool:
    """Drop the cached kernels if their sources changed since the cache was written; True if so.
    A package folder that cannot be written (an installed copy) is left as it is."""
    try:
        current = fingerprint()
        if STAMP.is_file() and STAMP.read_text() == current:
            return False
        for path in cached_files():
            path.unlink(missing_ok=True)
        STAMP.parent.mkdir(exist_ok=True)
        STAMP.write_text(current)
    except OSError:
        return False
    return True


_installed = False


def install() -> None:
    """Key numba's cache of the kernels of :data:`KERNEL_SOURCES` on the fingerprint of all of them
    (:func:`fingerprint`, as read now) besides the kernel's own file: numba's own cache locators, the
    one under ``NUMBA_CACHE_DIR`` and the one in ``__pycache__``, each with that added to the stamp
    its index is checked against. Other files' kernels are left to numba's locators. Once a process;
    to be called before a module's cached kernels are defined (numba picks a kernel's locator then)."""
    global _installed
    if _installed:
        return
    from numba.core import caching

    sources = {os.path.normcase(os.path.abspath(PACKAGE / name)) for name in KERNEL_SOURCES}
    stamp = fingerprint()

    def fingerprinted(base: type) -> type:
        class Fingerprinted(base):  # type: ignore[misc, valid-type]
            @classmethod
            def from_function(cls, py_func, py_file):  # type: ignore[no-untyped-def]
                if os.path.normcase(os.path.abspath(py_file)) not in sources:
                    return None
                return super().from_function(py_func, py_file)

            def get_source_stamp(self):  # type: ignore[no-untyped-def]
                return super().get_source_stamp(), stamp

        Fingerprinted.__name__ = Fingerprinted.__qualname__ = f"Fingerprinted{base.__name__}"
        return Fingerprinted

    caching.CacheImpl._locator_classes[:0] = [fingerprinted(caching.UserProvidedCacheLocator),
                                              fingerprinted(caching.InTreeCacheLocator)]
    _installed = True
