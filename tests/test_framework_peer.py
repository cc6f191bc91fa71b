"""The framework benchmark's peer: the ping-pong scene in mosaik is the same loop as cosim's."""

from __future__ import annotations

import pytest

from cosim.scenario import load
from cosim.scheduler import BaseObserver, Simulation
from tools import bench_framework, mosaik_peer


class _Last(BaseObserver):
    """Keeps the last value pong sends."""

    def __init__(self):
        self.value = None

    def on_exchange(self, t_ns, source, port, message):
        if source == "pong" and port == "out":
            self.value = message.value


@pytest.mark.parametrize("ticks", [1, 5, 12])
def test_mosaik_runs_the_same_loop_as_cosims_ping_pong(ticks):
    """After n ticks pong holds 1 - 2^-n in both frameworks: ping adds one to what pong sent a tick
    before (0 at first), pong halves it, so the peer is timed on the same work."""
    _, mosaik_value = mosaik_peer.run(ticks)
    last = _Last()
    sim = Simulation(load(bench_framework.SCENE, [f"until={ticks * 0.001}", "record.checkpoint_every=0"]),
                     observers=[last])
    sim.run()
    assert mosaik_value == last.value == 1.0 - 2.0 ** -ticks


def test_framework_benchmark_puts_mosaik_beside_cosim(tmp_path):
    """The written section has the peer's row and judges cosim's overhead against it (25x)."""
    doc = tmp_path / "performance.md"
    bench_framework.main(["--ticks", "50", "--repeats", "1", "--write", str(doc)])
    text = doc.read_text()
    assert "| mosaik " in text and "`tools/mosaik_peer.py`" in text
    assert "less than mosaik's" in text and "(target: at least 25x: " in text
