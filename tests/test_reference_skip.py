"""The reference skip (scenarios/skip.yaml) is a thrown stone: its attitude free and a person's spin
holding it. It skips several times, more with spin where the spin limits it, and the sideways curve
the spin gives is reported per skip and stays on the pond (docs/validation.md, sections 2 and 6)."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np
import pytest

from components.rigid.quaternion import body_axis
from components.stages import LEFT_POND
from cosim.scenario import load
from cosim.scheduler import Simulation

SKIP = Path(__file__).resolve().parents[1] / "scenarios" / "skip.yaml"


def run(*overrides: str) -> Simulation:
    """The reference skip with ``overrides``, run to its end, recording off."""
    sim = Simulation(load(SKIP, ["record.visual_rate=0", *overrides]))
    sim.run()
    return sim


@functools.cache
def throw(*overrides: str):
    """The stage monitor after the reference skip with ``overrides``, run to its end (each throw once
    in a session: two tests ask for 10 rev/s)."""
    return run(*overrides).components["stages"]


def spun(rev_s: float) -> str:
    return f"components.stone.spin={2 * math.pi * rev_s!r}"


@pytest.fixture(scope="module")
def reference_run():
    return run()


@pytest.fixture(scope="module")
def reference(reference_run):
    return reference_run.components["stages"]


@pytest.fixture(scope="module")
def held_unspun():
    """The stage monitor after the same throw with its attitude held and no spin."""
    return throw("components.stone.lock_attitude=true", "components.stone.spin=0")


def test_the_scene_throws_the_stone_free_with_a_persons_spin():
    stone = load(SKIP).components["stone"].params
    assert not stone.lock_attitude
    assert 10.0 <= stone.spin / (2 * math.pi) <= 14.0


def test_it_skips_three_times_curving_left_and_sinks_on_the_pond(reference):
    """Three skips; after the first, the heading each skip reports has turned to the left (+y, the
    sense of the spin: +1.6 and +1.0 deg) and the stone lies left of its line by the last; the stone
    sinks on the pond, not off its edge."""
    assert reference.track.skips == 3
    assert [label for _, label in reference.timeline][-1] == "sink"
    assert all(r.heading_deg > 0.5 for r in reference.records[1:])
    assert reference.records[-1].drift > 0.0


def test_the_distances_are_measured_from_where_the_stone_was_thrown(reference_run):
    """The monitor's start is the stone's state at t = 0 (it was the state after the first step,
    5.5 mm on, and the summary said 11.92 m for 11.93): the first skip's distance is its touchdown
    less the scene's start, and the distance travelled where the stone sank less it, not where it
    had drifted to under water when the run ended 0.3 s later (11.93 m)."""
    reference = reference_run.components["stages"]
    start = load(SKIP).components["stone"].params.position
    assert (reference.track.start_x, reference.track.start_y) == (start[0], start[1])
    assert reference.records[0].distance == reference.records[0].touchdown_x - start[0]
    sank_x = reference.final_x
    assert f"distance travelled: {sank_x - start[0]:.2f} m" in "\n".join(reference.summary())
    assert f"{sank_x - start[0]:.2f}" == "11.80"
    assert float(reference_run.components["stone"].body_state().position[0]) - sank_x > 0.1  # drifted on


@pytest.mark.parametrize("rev_s", [10.0, 14.0])
def test_at_a_persons_spin_it_skips_several_times(rev_s):
    stages = throw(spun(rev_s))
    assert stages.track.skips >= 3
    assert [label for _, label in stages.timeline][-1] not in (LEFT_POND,)


def test_the_count_grows_with_the_spin_where_the_spin_limits_it():
    """Without spin the stone skips once, at 6 rev/s twice, at 10 rev/s three times: more with
    every step of a person's spin."""
    counts = [throw(spun(s)).track.skips for s in (0.0, 6.0, 10.0)]
    assert counts == [1, 2, 3]


def test_held_the_same_throw_skips_lower(reference, held_unspun):
    """With its attitude held (the infinite-spin limit) the throw leaves the water at a few degrees
    at each skip, where the free stone leaves at least 3 deg higher at each of its skips (12.8, 8.6
    and 5.4 against 4.6, 2.8 and 1.7 deg): the spin's small turns of the lean raise its attack angle
    from contact to contact."""
    assert max(r.takeoff_angle_deg for r in held_unspun.records) < 6.0
    for free, held in zip(reference.records, held_unspun.records, strict=False):
        assert free.takeoff_angle_deg > held.takeoff_angle_deg + 3.0


def test_at_the_experiments_65_rev_per_s_the_free_stone_skips_as_if_held(held_unspun):
    """Spun at 65 rev/s (Clanet et al.'s catapult) the attitude hardly turns: the free stone leaves
    the water at each of its three skips within half a degree of the same throw, at the same spin,
    with its attitude held (4.6, 2.7 and 1.2 deg against 4.5, 2.7 and 1.5). The held throw skips
    once more, at 0.4 deg, where the free stone planes on instead (the spin row of
    docs/validation.md's table, not held). The spin itself costs the held throw nothing: spun or
    not, it skips four times."""
    free = throw(spun(65.0))
    held = throw(spun(65.0), "components.stone.lock_attitude=true")
    assert free.track.skips >= 3
    for f, h in zip(free.records, held.records, strict=False):
        assert f.takeoff_angle_deg == pytest.approx(h.takeoff_angle_deg, abs=0.5)
    assert held_unspun.track.skips == held.track.skips == 4


def test_the_waters_friction_slows_the_spin(reference_run):
    """The skin friction on the wetted trailing edge takes spin away: by the time the stone sinks it
    turns slower than thrown, and still the same way, as the run's summary reports."""
    stone = reference_run.components["stone"]
    thrown = load(SKIP).components["stone"].params.spin
    state = stone.body_state()
    spin = float(np.dot(state.angular_velocity, body_axis(state.orientation)))
    assert 0.0 < spin < 0.99 * thrown
    (line,) = stone.summary()  # and the run's summary says so
    assert line.endswith(f", spin {spin / (2 * math.pi):.3g} rev/s (thrown at {thrown / (2 * math.pi):.3g})")
