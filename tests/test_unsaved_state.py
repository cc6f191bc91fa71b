"""A component that keeps a state between steps but whose class saves none (the base ``get_state``)
is said as its run writes its first checkpoint, and again by a restart from its checkpoints, naming
it and the attributes it changed: restarted, it began as set up, not as it was, and the run diverged
without a word. A component that keeps no state, or saves the one it keeps, or says with a
``get_state`` of its own that its attributes are no state, is not said."""

from __future__ import annotations

from pathlib import Path

import pytest

from cosim.cli import main
from cosim.component import Component, Port
from cosim.examples import Number

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


class LoggedDouble(Double):
    """Doubles, and keeps a log of what it was given, which its outputs do not depend on."""

    def setup(self) -> None:
        super().setup()
        self.log = []

    def get_state(self):
        return {}  # the log is no state

    def _step_impl(self, t, dt, inputs):
        self.log.append(t)
        return super()._step_impl(t, dt, inputs)


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


def test_a_state_kept_but_not_saved_is_said_by_the_run_and_by_its_restart(tmp_path, capsys):
    with pytest.warns(UserWarning) as said:
        out, _ = run(tmp_path, "Tally", capsys)
    assert [str(w.message) for w in said] == [
        "component 'sum' (Tally) changes its attribute total between steps but its class saves no state (its "
        "get_state the base one): a restart from this run's checkpoints would start it as set up, not as it was; "
        "give the class get_state and set_state (returning {} where those attributes are no state: a log, a "
        "cache)"]  # once, though four checkpoints followed
    again = tmp_path / "again.mcap"
    with pytest.warns(UserWarning) as said:
        assert main(["replay", str(out), "--from", "0.01", "-o", str(again), "-q"]) == 0
    restart, own = [str(w.message) for w in said]  # the restart's, then its own run's checkpoints'
    assert restart == ("component 'sum' changed its attribute total between steps before this checkpoint but "
                       "saves no state (its get_state the base one): it restarts as set up, not as it was, and "
                       "the run from here differs from the original wherever those attributes decide its outputs")
    assert own.startswith("component 'sum' (Tally) changes its attribute total between steps")


def test_attributes_that_are_no_state_are_said_so_by_a_get_state_of_none(tmp_path, capsys):
    _, err = run(tmp_path, "LoggedDouble", capsys)
    assert "warning" not in err


def test_a_state_saved_restarts_as_it_was(tmp_path, capsys):
    out, err = run(tmp_path, "SavedTally", capsys)
    assert "warning" not in err
    again = tmp_path / "again.mcap"
    assert main(["replay", str(out), "--from", "0.01", "-o", str(again), "-q"]) == 0


def test_no_state_is_not_said(tmp_path, capsys):
    out, err = run(tmp_path, "Double", capsys)
    assert "warning" not in err
    assert main(["replay", str(out), "--from", "0.01", "-o", str(tmp_path / "again.mcap"), "-q"]) == 0


class Rebuilt(Double):
    """Keeps no state, but rebuilds equal values each step: a set in another order, a dict whose keys
    come in another order, equal strings that are not one object, a constant set after setup."""

    def __init__(self, name, params=None):
        super().__init__(name, params)
        self.gain = 3.0  # set in __init__, after the base class's setup

    def setup(self) -> None:
        super().setup()
        self.ids, self.table, self.labels = {8, 16, 24}, {"a": 1, "b": 2}, ["x" * 40, "x" * 40]

    def _step_impl(self, t, dt, inputs):
        self.ids = {24, 16, 8} if len(self.labels) % 2 == 0 else {8, 16, 24}
        self.table = {"b": 2, "a": 1}
        self.labels = ["".join(["x"] * 40), "".join(["x"] * 40)]
        return super()._step_impl(t, dt, inputs)


class TableInPlace(Double):
    """Keeps its state in an array it changes in place."""

    def setup(self) -> None:
        super().setup()
        import numpy as np

        self.history = np.zeros(4)

    def _step_impl(self, t, dt, inputs):
        self.history[0] += 1.0
        return super()._step_impl(t, dt, inputs)


def test_equal_values_rebuilt_between_steps_are_no_state(tmp_path, capsys):
    """Compared by pickle, a set rebuilt in another order, two equal strings that were one object,
    and a constant a subclass sets after the base class's setup were said to be a state."""
    _, err = run(tmp_path, "Rebuilt", capsys)
    assert "warning" not in err


def test_an_array_changed_in_place_is_a_state(tmp_path, capsys):
    with pytest.warns(UserWarning, match=r"^component 'sum' \(TableInPlace\) changes its attribute history between"):
        run(tmp_path, "TableInPlace", capsys)


def test_the_framework_attributes_named_are_those_the_base_sets():
    """The framework's own attributes are named (reading vars(self) as a component is built made
    CPython keep its attributes in a dict of their own, every step's reads 0.2 us slower): the names
    are exactly what the base class sets, so that none is taken for a component's own state."""
    from cosim.component import FRAMEWORK_ATTRIBUTES
    from cosim.examples import Ping

    assert set(vars(Ping("p"))) == FRAMEWORK_ATTRIBUTES
