"""A checkpoint of the water leaves out its columns at rest (components/water/sparse.py) and still
restores the water bit for bit: packed and unpacked, the surface is the same to every bit, a negative
zero included, and the held skip restarted from a recorded checkpoint goes on exactly as the run
that recorded it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from components.water import sparse
from cosim.record.reader import Recording
from cosim.replay import restart_simulation
from cosim.runner import run_scene
from cosim.scenario import load
from cosim.scheduler import BaseObserver, Simulation

SCENES = Path(__file__).resolve().parents[1] / "scenarios"


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and np.array_equal(a.view(np.uint64), b.view(np.uint64))


def test_packed_and_unpacked_the_surface_is_the_same_to_every_bit():
    """Blocks cut by the grid's edges, a lone negative zero and a value of 1e-300 are kept; blocks
    of zeros are not written."""
    rng = np.random.default_rng(7)
    h, v = np.zeros((70, 101)), np.zeros((70, 101))
    h[5:9, 40:45] = rng.normal(size=(4, 5))
    h[0, 0] = 1e-300
    v[69, 100] = -0.0  # in the last, cut block
    packed = sparse.pack(h, v, 32)
    assert packed["mask"].tolist() == [[1, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1]]
    assert packed["h"].size == 32 * 32 + 32 * 32 + 6 * 5  # two whole blocks and the corner's 6 x 5
    h2, v2 = np.full_like(h, np.nan), np.full_like(v, np.nan)
    sparse.unpack(packed, h2, v2)
    assert same_bits(h, h2) and same_bits(v, v2)


def test_a_surface_at_rest_packs_to_nothing_and_a_wrong_grid_is_named():
    packed = sparse.pack(np.zeros((40, 40)), np.zeros((40, 40)))
    assert not packed["mask"].any() and packed["h"].size == 0
    h = np.ones((40, 40))
    sparse.unpack(packed, h, np.ones((40, 40)))
    assert not h.any()
    with pytest.raises(ValueError, match=r"shape \(40, 40\), the grid is \(40, 41\)"):
        sparse.unpack(packed, np.zeros((40, 41)), np.zeros((40, 41)))


class Stone(BaseObserver):
    """The stone's published states: (t [ns], position, velocity)."""

    def __init__(self):
        self.states: list[tuple[int, bytes]] = []

    def on_exchange(self, time_ns, component, port, msg):
        if component == "stone" and port == "state":
            self.states.append((time_ns, msg.position.tobytes() + msg.velocity.tobytes()))


def test_the_held_skip_restarted_from_its_recorded_checkpoint_goes_on_exactly(tmp_path):
    """The checkpoint at 0.5 s (the stone between its third and fourth contact, its waves spread
    behind it) writes only the blocks that move, well under half the pond; restored from the
    recording, the run goes on to 0.7 s with the stone's every state and the water's final surface
    those of the run that went straight on."""
    overrides = ["until=0.7", "record.visual_rate=0"]
    straight = Stone()
    sim = Simulation(load(SCENES / "held_skip.yaml", overrides), observers=[straight])
    path = tmp_path / "held.mcap"
    run_scene(sim.scene, path, progress=False, simulation=sim)

    rec = Recording(path)
    (stamp, checkpoint), = [(t, cp) for t, cp in rec.checkpoints() if t == 500_000_000]
    surface = checkpoint["components"]["pond"]["state"]["surface"]
    assert "h" not in checkpoint["components"]["pond"]["state"]
    assert 0 < np.asarray(surface["h"]).size < 0.5 * np.prod(surface["shape"])

    again = Stone()
    resumed, at = restart_simulation(rec, stamp, observers=[again])
    assert at == stamp
    resumed.run()
    tail = [s for s in straight.states if s[0] > stamp]
    assert again.states[-len(tail):] == tail
    for key in ("h", "v"):
        assert same_bits(resumed.components["pond"].get_state()[key], sim.components["pond"].get_state()[key])
