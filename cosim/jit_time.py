"""Time a run spends compiling JIT kernels: a one-time cost, reported apart from the simulation's.

Compiled kernels (numba, ``cache=True``) are compiled the first time a process calls them and
written to an on-disk cache; later processes load them in milliseconds. On a fresh checkout the
first run therefore pays several seconds of compiling inside its first steps, which says nothing
about how fast the simulation runs. :func:`compile_timer` measures that time (numba's
``numba:compile`` event fires only on a real compile, not on a cache load) so the summary can say
it and the real-time factor can leave it out.
"""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager


@contextmanager
def compile_timer() -> Iterator[Callable[[], float]]:
    """Yield a function giving the seconds spent compiling JIT kernels since the ``with`` began.

    Zero when numba is not in use (it is never imported here: a scene without compiled components
    does not pay for it).
    """
    if "numba" not in sys.modules:
        yield lambda: 0.0
        return
    from numba.core import event

    listener = event.TimingListener()
    with event.install_listener("numba:compile", listener):
        yield lambda: listener.duration if listener.done else 0.0


@contextmanager
def compile_notice(say: Callable[[], None]) -> Iterator[None]:
    """Call ``say()`` once, when the first JIT compile inside the ``with`` starts (so a first run
    that sits for seconds in the compiler says why, rather than seeming stuck)."""
    if "numba" not in sys.modules:
        yield
        return
    from numba.core import event

    class Notice(event.Listener):
        said = False

        def on_start(self, ev: event.Event) -> None:
            if not self.said:
                self.said = True
                say()

        def on_end(self, ev: event.Event) -> None:
            pass

    with event.install_listener("numba:compile", Notice()):
        yield


_watch: dict[str, object] = {"listener": None}


def watch_compiles() -> None:
    """From now on, remember whether this process compiles a kernel (:func:`may_have_compiled`).
    Called once numba is imported and before any kernel is called (``components.compiled.start``)."""
    if _watch["listener"] is not None:
        return
    from numba.core import event

    class Seen(event.Listener):
        compiled = False

        def on_start(self, ev: event.Event) -> None:
            self.compiled = True

        def on_end(self, ev: event.Event) -> None:
            pass

    _watch["listener"] = listener = Seen()
    event.register("numba:compile", listener)


def may_have_compiled() -> bool:
    """False when this process has certainly compiled no kernel: numba is not imported, or it was
    watched (:func:`watch_compiles`) and nothing compiled; True otherwise."""
    if "numba" not in sys.modules:
        return False
    listener = _watch["listener"]
    return listener is None or bool(getattr(listener, "compiled", True))
