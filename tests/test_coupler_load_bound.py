"""The coupler's stable step judged at load is the one the run applies near the water: a scene the
load check passes does not fail at its first step."""

from __future__ import annotations

from pathlib import Path

from cosim.cli import main
from cosim.scenario import load
from cosim.scheduler import BaseObserver, Simulation

SKIP = str(Path(__file__).resolve().parent.parent / "scenarios" / "skip.yaml")


def test_a_step_too_long_for_the_stones_motion_near_the_water_is_refused_at_load(capsys):
    """The reference skip at dt = 1 ms under on_unstable: error: near the water a step may carry the
    stone a quarter of its radius, 0.85 ms at its 11 m/s and 12 rev/s. `validate` said ok and the
    run failed at t = 1 ms with the stone 9 cm above the water (exit 1)."""
    assert main(["validate", SKIP, "--set", "dt=0.001", "--set", "on_unstable=error"]) == 2
    err = capsys.readouterr().err
    assert "components.coupler: step 0.001 s exceeds the stable step 0.000846294 s it will need" in err
    # substepped, it is no bad input; and a step under the bound passes
    assert main(["validate", SKIP, "--set", "dt=0.001", "--set", "on_unstable=substep"]) == 0
    assert main(["validate", SKIP, "--set", "dt=0.0008", "--set", "on_unstable=error"]) == 0


class _FirstWet(BaseObserver):
    """The times [ns] of the steps in which the coupler says the stone touches the water."""

    def __init__(self) -> None:
        self.wet: list[int] = []

    def on_exchange(self, time_ns, component, port, msg) -> None:
        if component == "coupler" and port == "contact" and msg.wetted:
            self.wet.append(time_ns)


def test_a_step_the_load_check_passes_runs_through_the_first_contact():
    """What `validate` passed above (dt = 0.8 ms under on_unstable: error) runs: not only its first
    step (where the 1 ms step failed, 9 cm above the water) but on through the stone's first contact
    (at t = 59.2 ms at this step: the throw from 10 cm at 1.15 m/s down), where the coupler's own
    bound takes over; a step over it would end the run failed (a SimulationError)."""
    scene = load(Path(SKIP), ["dt=0.0008", "on_unstable=error"])
    contact = _FirstWet()
    result = Simulation(scene, observers=[contact]).run(70_000_000)
    assert result.status == "ok", result.reason
    assert result.time_ns == 88 * 800_000  # every step taken: whole 0.8 ms steps to 70 ms
    assert contact.wet[0] == 74 * 800_000 and len(contact.wet) > 5  # in the water from 59.2 ms on
