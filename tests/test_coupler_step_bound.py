"""The coupler's step is stable for the state it evaluates: its bound, which the scheduler asks
before the step, is that of the body's previous state, so a step whose own state needs a shorter
one is taken again in substeps (on_unstable: substep) or fails (error) before its force is
published; and the bound a scene is judged by at load is that of the body, not of its bounding
sphere.

    stone.state --> coupler.body          the coupler evaluates the stone's state at the end of its
    coupler.wrench --(delay 1)--> stone   step; the wrench it publishes is held over the stone's next
                                          step, from that state
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from cosim.cli import main
from cosim.component import Component
from cosim.errors import ScenarioError, SimulationError
from cosim.record.reader import Recording
from cosim.scenario import load
from cosim.scheduler import BaseObserver, Simulation

FREE_DISK = Path(__file__).resolve().parent.parent / "scenarios" / "free_disk.yaml"

# a 1.6 g disk, 10 cm across, into the water at 10 m/s, 65 degrees down: at the step ending 5.2 ms its
# state's bound was 16.3 us, the step taken whole on the 110 us bound of the state before (vz -4.8 ->
# +8.9 m/s, its energy 0.050 -> 0.179 J); at dt = 20 us, every step within its bound, the water stops it
STEEP = ["components.pond.every=1", "components.stone.radius=0.05", "components.stone.thickness=0.002",
         "components.stone.density=100", "components.stone.tilt_deg=30.92", "components.stone.spin=0",
         "components.stone.velocity=[4.2589, 0, -9.0477]", "components.stone.position=[0, 0, 0.0407]"]
# a 4 g disk at 20 m/s, 34 degrees down, on a 0.2 ms step: it skipped off at 24 m/s (6.6 m/s at 10 us)
FLAT = ["components.pond.every=1", "components.stone.radius=0.05", "components.stone.thickness=0.005",
        "components.stone.density=100", "components.stone.tilt_deg=11.38", "components.stone.spin=0",
        "components.stone.velocity=[16.52, 0, -11.27]", "components.stone.position=[0, 0, 0.0286]", "dt=0.0002"]
# a 54 mg disk let go under the water at 14 m/s, 45 degrees down and nose up 45 degrees, on a 2 ms step
# (2,413 substeps in its first): turned 10 degrees in it, it left at 36 m/s while the coupler's private
# copy carried its water along its turning axis, the body along the axis it began the step with
SUNK = ["dt=0.002", "components.pond.every=1", "components.stone.density=10", "components.stone.tilt_deg=45",
        "components.stone.spin=0", "components.stone.velocity=[10, 0, -10]", "components.stone.position=[0, 0, -0.05]"]
# the scene's disk, 50 kg/m^3, at 40 m/s on a 5 ms step: its lowest point 10.5 mm above the water, its
# bounding sphere's 4.7 mm under it
LIGHT = ["dt=0.005", "components.pond.every=1", "components.stone.density=50",
         "components.stone.velocity=[37.588, 0, -13.681]"]


class _Book(BaseObserver):
    """The stone's energy (kinetic and potential) [J] in each state it publishes, and after each
    tick the step of the coupler per substep and the bound of the state it evaluated [s]."""

    def __init__(self) -> None:
        self.energy: list[float] = []
        self.steps: list[tuple[int, float, float]] = []  # (tick, dt / substeps, bound after the step)

    def on_exchange(self, time_ns, component, port, msg) -> None:
        if component == "stone" and port == "state":
            self.energy.append(msg.kinetic_energy + msg.potential_energy)

    def on_step_complete(self, sim) -> None:
        coupler = sim.components["coupler"]
        self.steps.append((sim.tick, sim.dt_ns / 1e9 / coupler.last_substeps, coupler.bound))


def _run(overrides: list[str], until_ns: int) -> _Book:
    book = _Book()
    Simulation(load(FREE_DISK, overrides), observers=[book]).run(until_ns)
    return book


@pytest.mark.parametrize("overrides", [STEEP, FLAT, LIGHT, SUNK], ids=["steep", "flat", "light", "sunk"])
def test_the_water_gives_a_stone_no_energy_when_its_bound_falls_within_a_step(overrides):
    """The stone's energy never exceeds its energy at the start by more than 1% (the water only takes
    it; its waves give back far less): with the steps that met a shorter bound taken whole, the flat
    throw gained 60%, the steep one 125%, the light one 210,000 times (18 km/s) within 12 ms; the
    sunk one, its water carried along another axis than the body's, 14 times."""
    book = _run(overrides, 12_000_000)
    assert len(book.energy) > 2
    assert max(book.energy) <= 1.01 * book.energy[0], (book.energy[0], max(book.energy))


def test_each_step_of_the_coupler_is_within_the_bound_of_the_state_it_evaluated():
    """Per substep, no step of the coupler is longer than the bound of the body's state it evaluated
    (substep mode): the steps that meet a shorter bound than the last state's are redone in substeps
    and said so, as the scheduler says its own (last_substeps, the substep event)."""
    book = _run(FLAT, 12_000_000)
    over = [(tick, h, bound) for tick, h, bound in book.steps if h > bound]
    assert not over, over[:3]
    assert max(1e-4 * 2 / h for _, h, _ in book.steps) >= 10  # the contact's first step: 12 substeps


def test_under_on_unstable_error_the_step_meeting_a_shorter_bound_fails_before_its_force_is_published():
    """A step of 50 us passes the load check and runs into the water; the step whose state needs
    17.8 us fails, naming step and bound, and no step completes with a bound under its length (it
    was published, and the run failed a step later)."""
    book = _Book()
    sim = Simulation(load(FREE_DISK, [*FLAT, "dt=0.00005", "on_unstable=error"]), observers=[book])
    with pytest.raises(SimulationError, match=r"step 5e-05 s exceeds the stable step 1\.7\d+e-05 s \(on_unstable"):
        sim.run(12_000_000)
    assert len(book.steps) > 40  # it did run into the water
    assert all(bound >= h for _, h, bound in book.steps), [s for s in book.steps if s[2] < s[1]][:3]
    assert max(book.energy) <= 1.01 * book.energy[0]


@pytest.mark.parametrize("dt", ["0.005", "0.002"])
def test_a_disk_whose_bounding_sphere_dips_under_the_level_is_judged_by_its_motion_at_load(dt):
    """The light disk's bounding sphere reaches 4.7 mm under the water; the disk stays 10.5 mm above
    it. It was judged as in the water, by its buoyancy's 7.98 ms alone, and the scene loaded: at
    5 ms to fail a step later with its blow-up recorded, at 2 ms at its first step. Its motion and
    its face meeting the water at 40 m/s bound it far shorter: refused as it loads."""
    with pytest.raises(ScenarioError, match=rf"components\.coupler: step {dt} s exceeds the stable step "
                                            r"1\.12\d+e-05 s it will need once the run is under way"):
        load(FREE_DISK, [*LIGHT, f"dt={dt}", "on_unstable=error"])
    load(FREE_DISK, [*LIGHT, f"dt={dt}"])  # substepped, it runs (test above)


def test_a_restart_redoes_the_steps_the_original_redid(tmp_path):
    """A run restarted from a checkpoint before the contact records what the original did from there,
    the redone steps (the 12 substeps at 2.4 ms) and their substep events included."""
    original, restarted = tmp_path / "flat.mcap", tmp_path / "restarted.mcap"
    sets = [arg for o in FLAT for arg in ("--set", o)]
    assert main(["run", str(FREE_DISK), "-q", *sets, "--set", "record.checkpoint_every=0.002", "--until", "0.006",
                 "-o", str(original)]) == 0
    assert main(["replay", str(original), "--from", "0.002", "-q", "-o", str(restarted)]) == 0

    def after(path: Path) -> list[tuple[str, int, bytes]]:
        return [(topic, stamp, payload) for topic, stamp, payload in Recording(path).raw()
                if stamp > 2_000_000 and not topic.startswith("/scene") and topic not in ("/tf", "/cosim/status")]

    before = after(original)
    assert any(topic == "/cosim/events" and b"12 substeps" in payload for topic, _, payload in before)
    assert sorted(after(restarted)) == sorted(before)


class _Learns(Component):
    """Finds, inside its step, that the step needs a stable step of ``fresh`` [s]."""

    def setup(self) -> None:
        self.fresh = math.inf
        self.taken: list[int | None] = []

    def max_stable_step(self) -> float:
        return 1.0

    def _step_impl(self, t, dt, inputs):
        self.taken.append(self.restep(self.fresh))
        return {}


def test_restep_counts_and_says_substeps_as_the_scheduler_does():
    """Component.restep: the substeps a step needs under a bound found inside it, said as taken; the
    scheduler's refusals under on_unstable: error and past MAX_SUBSTEPS; None outside a step."""
    learns = _Learns("learns")
    learns.fresh = 3e-4
    learns.step(0, 1_000_000, {}, "substep")
    assert (learns.taken[-1], learns.last_substeps, learns.last_stable_step) == (4, 4, 3e-4)
    learns.fresh = 2e-3
    learns.step(1_000_000, 1_000_000, {}, "substep")
    assert (learns.taken[-1], learns.last_substeps, learns.last_stable_step) == (1, 1, 1.0)
    assert learns.restep(1e-9) is None
    with pytest.raises(SimulationError, match=r"needs 1e\+06 substeps \(stable step 1e-09 s\), more than the limit"):
        learns.fresh = 1e-9
        learns.step(2_000_000, 1_000_000, {}, "substep")
    learns = _Learns("learns")
    learns.fresh = 3e-4
    with pytest.raises(SimulationError, match=r"t = 0.002 s: step 0.001 s exceeds the stable step 0.0003 s"):
        learns.step(2_000_000, 1_000_000, {}, "error")
    assert learns.status == "failed"
