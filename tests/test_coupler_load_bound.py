"""The coupler's stable step judged at load is the one the run applies near the water: a scene the
load check passes does not fail at its first step."""

from __future__ import annotations

from pathlib import Path

from cosim.cli import main

SKIP = str(Path(__file__).resolve().parent.parent / "scenarios" / "skip.yaml")


def test_a_step_too_long_for_the_stones_motion_near_the_water_is_refused_at_load(capsys):
    """The reference skip at dt = 1 ms under on_unstable: error: near the water a step may carry the
    stone a quarter of its radius, 0.85 ms at its 11 m/s and 12 rev/s. `validate` said ok and the
    run failed at t = 1 ms with the stone 9 cm above the water (exit 1)."""
    assert main(["validate", SKIP, "--set", "dt=0.001", "--set", "on_unstable=error"]) == 2
    err = capsys.readouterr().err
    assert "components.coupler: step 0.001 s exceeds the stable step 0.000846 s it will need" in err
    # substepped, it is no bad input; and a step under the bound passes
    assert main(["validate", SKIP, "--set", "dt=0.001", "--set", "on_unstable=substep"]) == 0
    assert main(["validate", SKIP, "--set", "dt=0.0008", "--set", "on_unstable=error"]) == 0
