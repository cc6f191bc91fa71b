"""Progress on standard error: a bar over simulated time (tqdm) for runs that last more than a
second, and, for counted work (a sweep's runs), a bar on a terminal or a few plain lines in a log."""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

from cosim.scheduler import BaseObserver, RunResult, Simulation
from cosim.timebase import NS_PER_S

UPDATES = 200  # bar refreshes per run; keeps the observer's cost per tick negligible


class ProgressBar(BaseObserver):
    """Shows simulated seconds done / to do, with the real-time factor, on stderr."""

    def __init__(self, until_ns: int, label: str = "simulating"):
        self.until_ns = until_ns
        self.label = label
        self.bar: Any = None  # a tqdm bar, made when the run starts
        self.every = 1
        self.shown_ns = 0
        # tqdm (tens of ms with what it loads) only for a terminal, and here, before the run's clock
        # starts: imported as the run began, it was timed as the run (a 50 ms ping-pong run said a
        # real-time factor of 3 without -q, 170 with it, piped, where no bar is drawn)
        self._tqdm = None
        if sys.stderr is not None and sys.stderr.isatty():
            from tqdm import tqdm

            self._tqdm = tqdm

    def on_initialized(self, sim: Simulation) -> None:
        tqdm = self._tqdm
        if tqdm is None:  # not a terminal: no bar
            return
        total_ticks = max(1, (self.until_ns - sim.time_ns) // sim.dt_ns)
        self.every = max(1, total_ticks // UPDATES)
        self.shown_ns = sim.time_ns
        self.bar = tqdm(total=round(self.until_ns / NS_PER_S, 6), initial=round(sim.time_ns / NS_PER_S, 6),
                        unit="sim s", desc=self.label, delay=1.0, file=sys.stderr, leave=False,
                        bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.3f}/{total:.3f} sim s "
                                   "[{elapsed}<{remaining}, {rate_fmt}]", dynamic_ncols=True)

    def on_step_complete(self, sim: Simulation) -> None:
        if sim.tick % self.every == 0 and self.bar is not None:
            now = sim.time_ns
            self.bar.update((now - self.shown_ns) / NS_PER_S)
            self.shown_ns = now

    def on_finished(self, sim: Simulation, result: RunResult) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


class LogLines:
    """Progress of counted work as plain lines, for a stream that is not a terminal (a log, a pipe).

    A terminal bar redraws itself with carriage returns: in a log that is one line of hundreds of
    redraws. This says ``DESC: N/TOTAL UNIT (P%), T s`` each time another tenth of the work is done
    (and at the end), so a long sweep's log shows how far it got in about ten lines. It takes the
    calls of a tqdm bar that counted work makes (``update``, ``set_postfix``, ``close``).
    """

    STEPS = 10  # lines over the whole work

    def __init__(self, total: int, initial: int = 0, desc: str = "", unit: str = "it",
                 file: TextIO | None = None):
        self.total, self.n, self.desc, self.unit = max(0, int(total)), int(initial), desc, unit
        self.file = file if file is not None else sys.stderr
        self.postfix: dict[str, Any] = {}
        self.start = time.perf_counter()
        self.said = self._tenth(self.n)

    def _tenth(self, n: int) -> int:
        return n * self.STEPS // self.total if self.total else self.STEPS

    def update(self, n: int = 1) -> None:
        self.n += n
        if self._tenth(self.n) > self.said:
            self.said = self._tenth(self.n)
            self._say()

    def set_postfix(self, refresh: bool = False, **values: Any) -> None:
        self.postfix = dict(values)

    def close(self) -> None:
        pass

    def _say(self) -> None:
        share = f" ({100 * self.n / self.total:.0f}%)" if self.total else ""
        extra = "".join(f", {key} {value}" for key, value in self.postfix.items())
        print(f"{self.desc}: {self.n}/{self.total} {self.unit}s{share}{extra}, "
              f"{time.perf_counter() - self.start:.0f} s", file=self.file, flush=True)


def work_progress(total: int, *, initial: int = 0, desc: str, unit: str, shown: bool = True, **bar: Any) -> Any:
    """Progress over ``total`` pieces of work on standard error: a tqdm bar (``bar``: its further
    options) on a terminal, :class:`LogLines` elsewhere, nothing shown unless ``shown``."""
    if shown and not sys.stderr.isatty():
        return LogLines(total, initial=initial, desc=desc, unit=unit, file=sys.stderr)
    from tqdm import tqdm  # here, not at import: tqdm costs tens of ms at start-up

    return tqdm(total=total, initial=initial, desc=desc, unit=unit, file=sys.stderr, disable=not shown, **bar)
