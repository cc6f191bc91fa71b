"""Let a pythonfmu binary release its hold on Python before the process's C exit handlers run.

pythonfmu 0.7's Linux binary keeps its Python state in a global shared pointer and releases it
twice when the process exits: once by the pointer's static destructor (a C++ exit handler), and
then again from the library's unload hook, ``finalizePythonInterpreter``, which runs after it
(the library is never unloaded before exit: its unique symbols make it stay) and decrements a
count inside the block the first release freed. Where the freed block landed in the heap decides
what that write breaks: often nothing, sometimes the allocator's lists, so that a later free at
exit aborts the process ("corrupted double-linked list", exit 134; about half the runs of
``fmpy simulate`` on an exported scene started after t = 0).

Calling ``finalizePythonInterpreter`` from Python's own exit (an ``atexit`` function, which runs
before the C exit handlers) empties the global first, so that neither later release finds
anything to free: 0 aborts in 60 runs against 24 in 40, the results the same to the byte.
"""

from __future__ import annotations

import atexit
import ctypes
import os
import sys
import threading
from pathlib import Path

_guarded: set[str] = set()  # the binaries whose release is registered, by resolved path


def release_at_exit(library: str | Path) -> bool:
    """Register the pythonfmu binary ``library`` (a ``.so`` file)'s ``finalizePythonInterpreter`` to
    run at this process's Python exit, once per binary; whether it was registered (False: not on
    Linux, not a Python process's main interpreter, or not a pythonfmu binary)."""
    # only where the binary shares a Python process's interpreter (a Python master such as FMPy or
    # cosim itself); a C master's Python is the binary's own, which it finalizes as it means to
    if not sys.platform.startswith("linux") or threading.main_thread().native_id != os.getpid():
        return False
    key = str(Path(library).resolve())
    if key in _guarded:
        return True
    try:
        release = ctypes.CDLL(key).finalizePythonInterpreter
    except (OSError, AttributeError):  # not loadable here, or not a pythonfmu binary
        return False
    release.argtypes, release.restype = [], None
    _guarded.add(key)
    atexit.register(release)
    return True


def release_binaries_at_exit(resources: str | Path) -> None:
    """:func:`release_at_exit` for each Linux binary of the unpacked FMU whose ``resources`` folder
    is given (its binaries are in ``binaries/linux64`` beside it)."""
    for library in sorted((Path(resources).parent / "binaries" / "linux64").glob("*.so")):
        release_at_exit(library)
