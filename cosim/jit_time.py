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
