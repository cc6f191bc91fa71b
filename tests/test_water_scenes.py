"""The water scenes load, validate and run: wave_pulse keeps its volume, drop_ripple goes quiet."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from cosim.errors import ScenarioError
from cosim.scenario import load
from cosim.scheduler import BaseObserver, Simulation

SCENES = Path(__file__).resolve().parent.parent / "scenarios"


class Frames(BaseObserver):
    """Counts the whole-field frames the water publishes."""

    def __init__(self) -> None:
        self.times: list[int] = []

    def on_exchange(self, time_ns, component, port, msg) -> None:
        if port == "field":
            self.times.append(time_ns)


def test_wave_pulse_keeps_its_volume_and_energy():
    """pond (alone, reflecting): the bump spreads and reflects; volume to 1e-12, energy kept."""
    scene = load(SCENES / "wave_pulse.yaml")
    frames = Frames()
    sim = Simulation(scene, observers=[frames])
    pond = sim.components["pond"]
    v0, e0 = pond.volume(), pond.energy()
    assert sim.run().status == "ok"
    assert abs(pond.volume() - v0) <= 1e-12 * v0
    assert pond.energy() == pytest.approx(e0, rel=0.05)
    assert np.abs(pond.height).max() < 0.5 * 0.01  # the 1 cm bump has spread out
    assert len(frames.times) == 61  # t = 0 plus 30 frames per second for 2 s


def test_drop_ripple_leaves_through_the_absorbing_edges():
    """drop -> pond.occupied: the displaced water rings out and leaves; under 0.1% of the energy stays."""
    scene = load(SCENES / "drop_ripple.yaml")
    assert scene.order == ["drop", "pond"]
    sim = Simulation(scene)
    pond = sim.components["pond"]
    sim.initialize()
    peak = 0.0
    while sim.time_ns < scene.until_ns:
        sim.step()
        peak = max(peak, pond.energy()) if sim.tick % 25 == 0 else peak
    assert peak > 0.0
    assert pond.energy() < 1e-3 * peak
    assert np.abs(pond.height).max() < 1e-4  # back to the rest level within 0.1 mm


def test_too_long_a_step_is_refused_at_load_time():
    """The explicit water at c dt / s = 0.89 fails validation, naming the component and the bound."""
    with pytest.raises(ScenarioError, match=r"components.pond: step 0.004 s exceeds its stable step 0.00319"):
        load(SCENES / "wave_pulse.yaml", overrides=["dt=0.004", "until=0.1"])


def test_a_water_answering_less_often_than_the_look_ahead_is_refused():
    """The coupler asks for a window reaching 60 ms ahead of the stone; a water stepping every 0.5 s
    leaves the stone beyond its last patch (it then fell through as if off the pond's edge, and the
    summary said it had left the pond over the middle of it). At 120 ticks of 0.5 ms it loads."""
    skip = SCENES / "skip.yaml"
    with pytest.raises(ScenarioError, match=r"components\.coupler: its input 'water' comes from pond every 0\.5 s, "
                       r"longer than the 0\.06 s it can bridge \(lookahead\); use components\.pond\.every at most "
                       r"120, or components\.coupler\.lookahead of at least 0\.5 s"):
        load(skip, overrides=["components.pond.every=1000"])
    assert load(skip, overrides=["components.pond.every=120"]).components["pond"].every == 120
    assert load(skip, overrides=["components.pond.every=1000", "components.coupler.lookahead=0.5"])


def test_too_long_a_step_can_be_substepped():
    """With on_unstable: substep the same scene runs, two substeps per step, and keeps its volume."""
    scene = load(SCENES / "wave_pulse.yaml", overrides=["dt=0.004", "until=0.2", "on_unstable=substep"])
    sim = Simulation(scene)
    pond = sim.components["pond"]
    v0 = pond.volume()
    assert sim.run().status == "ok"
    assert pond.last_substeps == 2
    assert abs(pond.volume() - v0) <= 1e-12 * v0
