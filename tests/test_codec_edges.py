"""What a component hands the codecs that they cannot give back as it was, end to end: a state for a
checkpoint that is not plain data, or an output whose enum field holds no member, is the
component's failure (one line naming it, exit 1, the recording kept with a ``failed`` status); a
state holding a ``np.str_`` or a 0-d array is recorded and read back as it was.

Before, a ``np.str_`` or a lone surrogate in a state failed the recording's writer and no file was
left; an object array was recorded as pointers; a datetime64 array was an internal error; int keys
and structured arrays came back as something else without a word; an out-of-range enum was recorded
and the recording could not be read."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from components.messages import Stage, StageId
from cosim.cli import main
from cosim.component import Component, Port
from cosim.params import param
from cosim.record.reader import Recording
from tests.cli_toys import one_error_line
from tests.toys import Scalar

ODD_STATES = {
    "np_str": lambda: np.str_("hello"),
    "zero_d": lambda: np.array(2.5),
    "surrogate": lambda: "file\udcff.dat",
    "int_keys": lambda: {1: 2.0, "1": 3.0},
    "object_array": lambda: np.array([1.5, "a", None], dtype=object),
    "datetime_array": lambda: np.array(["2020-01-01"], dtype="datetime64[D]"),
    "structured_array": lambda: np.zeros(2, dtype=[("a", "<f8"), ("b", "<i4")]),
}


class OddState(Component):
    """Counts its steps and publishes the count; from its fifth step on, its state for a checkpoint
    holds ``ODD_STATES[kind]`` beside the count."""

    @dataclass(frozen=True)
    class Params:
        kind: str = param("np_str")

    outputs = {"out": Port(Scalar)}

    def setup(self) -> None:
        self.steps = 0
        self.restored = None

    def _step_impl(self, t, dt, inputs):
        self.steps += 1
        return {"out": Scalar(float(self.steps))}

    def get_state(self):
        return {"steps": self.steps, "odd": ODD_STATES[self.params.kind]() if self.steps >= 5 else None}

    def set_state(self, state):
        self.steps, self.restored = state["steps"], state["odd"]


class BadStage(Component):
    """Publishes a stage change every step, its third one with the stage id 99 (no StageId)."""

    outputs = {"stage": Port(Stage)}

    def setup(self) -> None:
        self.steps = 0

    def _step_impl(self, t, dt, inputs):
        self.steps += 1
        return {"stage": Stage(99 if self.steps == 3 else StageId.HIT, "hit", 0, 0.0, 0.0, t)}


SCENE = """
dt: 0.001
until: 0.01
components:
  odd: {{type: "tests.test_codec_edges:{type}"{params}}}
record: {{checkpoint_every: 0.005}}
"""


def _run(tmp_path, component: str, params: str = "") -> tuple[int, Recording]:
    """`cosim run` of the scene of one ``component``: its exit code and its recording."""
    scene = tmp_path / "odd.yaml"
    scene.write_text(SCENE.format(type=component, params=params))
    out = tmp_path / "odd.mcap"
    return main(["run", str(scene), "-q", "-o", str(out)]), Recording(out)


@pytest.mark.parametrize(("kind", "said"), [
    ("surrogate", "state.odd: text 'file\\udcff.dat' holds the lone surrogate '\\udcff': a checkpoint's text "
                  "must be valid UTF-8"),
    ("int_keys", "state.odd: key 1 (int) is not a string: a checkpoint's keys are strings (written as text, it "
                 "would come back as one)"),
    ("object_array", "state.odd: an array of dtype object is not plain data (a checkpoint holds arrays of "
                     "booleans, numbers, or bytes or text of fixed size)"),
    ("datetime_array", "state.odd: an array of dtype datetime64[D] is not plain data (a checkpoint holds arrays "
                       "of booleans, numbers, or bytes or text of fixed size)"),
    ("structured_array", "state.odd: an array of dtype [('a', '<f8'), ('b', '<i4')] is not plain data (a "
                         "checkpoint holds arrays of booleans, numbers, or bytes or text of fixed size)"),
], ids=["surrogate", "int_keys", "object_array", "datetime_array", "structured_array"])
def test_a_state_a_checkpoint_cannot_give_back_is_the_components_failure(kind, said, tmp_path, capsys):
    """One line naming the component, the time and where in its state the value is; exit 1; the
    recording kept, everything up to the failure in it, with the failed status."""
    code, recording = _run(tmp_path, "OddState", f", kind: {kind}")
    reason = f"component 'odd' failed at t = 0.005 s: its state for a checkpoint: {said}"
    assert code == 1
    assert one_error_line(capsys.readouterr().err) == f"error: {reason}"
    status = recording.status()
    assert status is not None and (status.status, status.reason) == ("failed", reason)
    assert [t for t, _ in recording.checkpoints()] == [0]
    assert len(recording.messages("/odd/out", Scalar)) == 5


def test_a_np_str_and_a_0d_array_in_a_state_are_recorded_and_read_back_as_they_were(tmp_path):
    """A ``np.str_`` comes back a str and a 0-d array 0-d, from every checkpoint of the recording."""
    for kind, check in (("np_str", lambda odd: type(odd) is str and odd == "hello"),
                        ("zero_d", lambda odd: odd.shape == () and odd == 2.5)):
        code, recording = _run(tmp_path, "OddState", f", kind: {kind}")
        assert code == 0, kind
        checkpoints = recording.checkpoints()
        assert [t for t, _ in checkpoints] == [0, 5_000_000, 10_000_000]
        assert all(check(cp["components"]["odd"]["state"]["odd"]) for _, cp in checkpoints[1:]), kind


def test_an_output_whose_enum_field_holds_no_member_is_the_components_failure(tmp_path, capsys):
    """A stage id of 99 is said as the component's failure naming the port, the field, the value and
    the members; the recording keeps the stages before it and reads back (it recorded the 99, and
    reading the recording failed on it)."""
    code, recording = _run(tmp_path, "BadStage")
    members = ", ".join(f"{int(m)} {m.name.lower()}" for m in StageId)
    reason = f"component 'odd' failed at t = 0.002 s: output 'stage' field 'stage': 99 is not a StageId ({members})"
    assert code == 1
    assert one_error_line(capsys.readouterr().err) == f"error: {reason}"
    assert recording.status().reason == reason
    assert [msg.stage for _, msg in recording.messages("/odd/stage", Stage)] == [StageId.HIT, StageId.HIT]
