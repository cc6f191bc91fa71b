"""A component that keeps a state between steps but whose class saves none (the base ``get_state``)
is said as its run writes its first checkpoint, and a restart from its checkpoints is refused,
naming it and the attributes it changed: restarted, it began as set up, not as it was, and the run
diverged without a word. A component that keeps no state, or saves the one it keeps, is not said."""

from __future__ import annotations

from pathlib import Path

import pytest

from cosim.cli import main
from cosim.component import Component, Port
from cosim.examples import Number
from tests.cli_toys import one_error_line

HERE = "tests.test_unsaved_state"


class Tally(Component):
    """A running sum that forgets to save it."""

    inputs = {"inp": Port(Number, "what to add")}
    outputs = {"out": Port(Number)}

    def setup(self) -> None:
        self.total = 0.0
        self.rate = 2.0  # set up, never changed: not a state

    def _step_impl(self, t, dt, inputs):
        self.total += inputs["inp"].value if inputs["inp"] is not None else 0.0
        return {"out": Number(self.total)}


class SavedTally(Tally):
    """The same sum, saved."""

    def get_state(self):
        return {"total": self.total}

    def set_state(self, state):
        self.total = float(state["total"])


class Double(Component):
    """No state: out = 2 inp."""

    inputs = {"inp": Port(Number, "the number")}
    outputs = {"out": Port(Number)}

    def setup(self) -> None:
        self.factor = 2.0

    def _step_impl(self, t, dt, inputs):
        return {"out": Number(self.factor * (inputs["inp"].value if inputs["inp"] is not None else 0.0))}


SCENE = """
name: tally
dt: 0.001
until: 0.02
components:
  ping: {{type: "cosim.examples:Ping"}}
  sum: {{type: "{kind}"}}
connections:
  - {{from: sum.out, to: ping.inp, delay: 1, initial: {{value: 0.0}}}}
  - ping.out -> sum.inp
record: {{checkpoint_every: 0.005}}
"""


def run(tmp_path: Path, kind: str, capsys) -> tuple[Path, str]:
    scene = tmp_path / "tally.yaml"
    scene.write_text(SCENE.format(kind=f"{HERE}:{kind}"))
    out = tmp_path / f"{kind}.mcap"
    assert main(["run", str(scene), "-o", str(out), "-q"]) == 0
    return out, capsys.readouterr().err


def test_a_state_kept_but_not_saved_is_said_and_its_restart_refused(tmp_path, capsys):
    with pytest.warns(UserWarning) as said:
        out, _ = run(tmp_path, "Tally", capsys)
    assert [str(w.message) for w in said] == [
        "component 'sum' (Tally) keeps a state between steps that its class does not save (its attribute total "
        "changed since it was set up, its get_state the base one, saving nothing): a restart from this run's "
        "checkpoints is refused; give the class get_state and set_state"]  # once, though four checkpoints followed
    again = tmp_path / "again.mcap"
    assert main(["replay", str(out), "--from", "0.01", "-o", str(again), "-q"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert "cannot restart from the checkpoint at 0.01 s: component 'sum' kept a state between steps that it " \
           "did not save (its attribute total changed since it was set up" in line
    assert not again.exists()


def test_a_state_saved_restarts_as_it_was(tmp_path, capsys):
    out, err = run(tmp_path, "SavedTally", capsys)
    assert "warning" not in err
    again = tmp_path / "again.mcap"
    assert main(["replay", str(out), "--from", "0.01", "-o", str(again), "-q"]) == 0


def test_no_state_is_not_said(tmp_path, capsys):
    out, err = run(tmp_path, "Double", capsys)
    assert "warning" not in err
    assert main(["replay", str(out), "--from", "0.01", "-o", str(tmp_path / "again.mcap"), "-q"]) == 0
