"""The reference stone set gliding just under the surface at the pond's wave speed: the hard case of
a body's own waves (tests/test_displacement_band.py, tests/test_airy_water.py)."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np

from cosim.scenario import load
from cosim.scheduler import BaseObserver, Simulation

SKIP_SCENE = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"


class _Watch(BaseObserver):
    """The largest vertical surface speed [m/s] in the water's patches, and the highest the stone's
    centre rose [m]."""

    def __init__(self):
        self.peak = 0.0
        self.top = -np.inf

    def on_exchange(self, time_ns, component, port, msg):
        if component == "pond" and port == "patch" and msg.velocity.size:
            self.peak = max(self.peak, float(np.abs(msg.velocity).max()))
        elif component == "stone" and port == "state":
            self.top = max(self.top, float(msg.position[2]))


@cache  # the same run serves both test files: it is read, never changed
def glide(cell: float, *sets: str) -> tuple[float, float]:
    """The reference stone (R = 5 cm, 15 mm thick) set moving at 2.2 m/s, the 0.5 m deep pond's
    sqrt(g d), with its top 4.5 mm under the surface, for 0.8 s on a 2.5 m x 0.6 m pond of columns of
    ``cell`` [m] (the water stepping every cell / 2.5 ms), with ``sets`` besides: (the largest
    vertical surface speed [m/s], the highest its centre rose [m])."""
    scene = ["components.stone.position=[0.3, 0.3, -0.012]", "components.stone.velocity=[2.2, 0.0, 0.0]",
             "components.stone.tilt_deg=3", "components.stone.spin=56.5", f"components.pond.cell={cell}",
             f"components.pond.nx={round(2.5 / cell)}", f"components.pond.ny={round(0.6 / cell)}",
             f"components.pond.every={round(cell / 0.0025)}", "until=0.8", "record.visual_rate=0",
             "components.stages.stop_after=0",
             "components.pond.wave_length=null",  # the long waves' sqrt(g d): the hard case, kept on purpose
             *sets]
    watch = _Watch()
    Simulation(load(SKIP_SCENE, scene), observers=[watch]).run()
    return watch.peak, watch.top
