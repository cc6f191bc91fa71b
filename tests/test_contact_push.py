"""tools/contact_push.py: a contact's push as a peak and as a sensor's windowed mean."""

from __future__ import annotations

import numpy as np
import pytest

from cosim.scenario import load
from cosim.scheduler import Simulation
from tools import contact_push


def test_window_peak_is_the_largest_mean_over_the_window():
    """A triangle pulse 0, 1, ..., 10, ..., 1, 0 (one value a millisecond): the raw peak is 10, the
    largest mean of 5 values 44/5 (8, 9, 10, 9, 8), of 9 values 70/9; a pulse shorter than the window
    gives its mean."""
    push = np.concatenate((np.arange(11.0), np.arange(9.0, -1.0, -1.0)))
    assert contact_push.window_peak(push, 0.001, 0.001) == 10.0
    assert contact_push.window_peak(push, 0.001, 0.005) == pytest.approx(44.0 / 5.0, rel=1e-15)
    assert contact_push.window_peak(push, 0.001, 0.009) == pytest.approx(70.0 / 9.0, rel=1e-15)
    assert contact_push.window_peak(push, 0.001, 0.050) == pytest.approx(push.mean(), rel=1e-15)


def test_contact_pushes_peaks_are_the_stage_monitors():
    """The held skip: one contact a skip plus the one it surfs on, each raw peak the stage
    monitor's SkipRecord.peak_g (and its last contact's), the windowed means below it."""
    scene = load(contact_push.ROOT / "scenarios" / "held_skip.yaml", ["record.visual_rate=0"])
    contacts = contact_push.contact_pushes(scene)
    sim = Simulation(scene)
    sim.run()
    monitor = sim.components["stages"]
    assert [kind for kind, _, _ in contacts] == ["bounce"] * len(monitor.records) + ["surf"]
    assert [float(push.max()) for _, push, _ in contacts[:-1]] == [r.peak_g for r in monitor.records]
    assert float(contacts[-1][1].max()) == monitor.track.peak_g
    for _, push, dt in contacts:
        assert contact_push.window_peak(push, dt, 0.010) <= push.max()
