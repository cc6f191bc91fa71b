"""A progress bar over simulated time (tqdm), shown only for runs that last more than a second."""

from __future__ import annotations

import sys
from typing import Any

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

    def on_initialized(self, sim: Simulation) -> None:
        from tqdm import tqdm  # here, not at import: tqdm and what it loads cost tens of ms at start-up

        total_ticks = max(1, (self.until_ns - sim.time_ns) // sim.dt_ns)
        self.every = max(1, total_ticks // UPDATES)
        self.shown_ns = sim.time_ns
        self.bar = tqdm(total=round(self.until_ns / NS_PER_S, 6), initial=round(sim.time_ns / NS_PER_S, 6),
                        unit="sim s", desc=self.label, delay=1.0, file=sys.stderr, leave=False,
                        disable=not sys.stderr.isatty(),
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
