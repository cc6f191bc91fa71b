"""The ping-pong scene in mosaik: the framework benchmark's peer, run in the same process.

mosaik (https://mosaik.offis.de, from PyPI: ``pip install -e '.[test]'`` brings it) is the
co-simulation framework cosim's overhead is measured against (DESIGN.md section 5: at least 25x
less per component-step). The scene is ``scenarios/ping_pong.yaml`` written for it: two simulators
in the same process (mosaik's ``python`` simulators, no sockets), ``ping.out -> pong.inp`` direct and
``pong.out -> ping.inp`` time-shifted by one step with 0 as its first value, each simulator stepping
once per time unit. Ping adds one to what it receives and Pong halves it, so the loop settles at 1,
as in cosim.

    python tools/mosaik_peer.py [--ticks 20000]     # seconds and us per component-step
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import mosaik
import mosaik_api_v3

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from tools.options import description, positive_int  # noqa: E402


def _meta(model: str) -> dict:
    return {"api_version": "3.0", "type": "time-based",
            "models": {model: {"public": True, "params": [], "attrs": ["inp", "out"]}}}


class _Sim(mosaik_api_v3.Simulator):
    """One entity whose ``out`` is a function of its ``inp``, stepped every time unit (the methods
    keep mosaik's signatures, arguments unused here included)."""

    model = ""
    started: dict[str, _Sim] = {}  # the instance of each model mosaik made, newest, to read back

    def __init__(self) -> None:
        super().__init__(_meta(self.model))
        self.out = 0.0
        _Sim.started[self.model] = self

    def init(self, sid, time_resolution=1.0, **sim_params):
        return self.meta

    def create(self, num, model, **model_params):
        return [{"eid": self.model, "type": model}]

    def step(self, time, inputs, max_advance):
        # inputs: {eid: {attr: {source entity: value}}}, one source here
        (value,) = inputs[self.model]["inp"].values()
        self.out = self.apply(value)
        return time + 1

    def get_data(self, outputs):
        return {self.model: {"out": self.out}}

    def apply(self, value: float) -> float:
        raise NotImplementedError


class PingSim(_Sim):
    """out = inp + 1."""

    model = "Ping"

    def apply(self, value: float) -> float:
        return value + 1.0


class PongSim(_Sim):
    """out = inp / 2."""

    model = "Pong"

    def apply(self, value: float) -> float:
        return value * 0.5


def run(ticks: int) -> tuple[float, float]:
    """(seconds, the loop's last value) of ``ticks`` time units of the ping-pong loop in mosaik: the
    run alone, timed after the world is built and the simulators started (2 component-steps a
    tick)."""
    sims = {"Ping": {"python": f"{__name__}:PingSim"}, "Pong": {"python": f"{__name__}:PongSim"}}
    world = mosaik.World(sims, skip_greetings=True, configure_logging=False)
    try:
        ping = world.start("Ping").Ping()
        pong = world.start("Pong").Pong()
        world.connect(ping, pong, ("out", "inp"))
        world.connect(pong, ping, ("out", "inp"), time_shifted=True, initial_data={"out": 0.0})
        start = time.perf_counter()
        world.run(until=ticks, print_progress=False)
        elapsed = time.perf_counter() - start
        last = _Sim.started["Pong"].out
    finally:
        world.shutdown()
    return elapsed, last


def main() -> None:
    parser = argparse.ArgumentParser(description=description(__doc__))
    parser.add_argument("--ticks", type=positive_int, default=20000, help="ticks of the scene (default %(default)s)")
    args = parser.parse_args()
    seconds, last = run(args.ticks)
    print(f"mosaik {getattr(mosaik, '__version__', '')}: {args.ticks} ticks in {seconds:.3f} s, "
          f"{seconds / (2 * args.ticks) * 1e6:.1f} us per component-step; the loop's value {last}")


if __name__ == "__main__":
    main()
