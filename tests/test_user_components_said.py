"""A user's component or message type that breaks a rule is said as the scene loads, naming it and
the rule, exit 2; a component publishing a wrong array shape fails naming its output and field.

Before: a user's ``Wrench`` beside components.messages.Wrench shared one schema in the recording
(the run said ok, the recording could not be inspected or replayed); a parameter named ``step`` was
taken by the scene as the component's step and silently kept its default; a 2-vector force ended in
"internal error ProtoError ... (an int beyond 64 bits?)" naming no component; Params without
@dataclass, ``inputs = ["inp"]`` and ``Port(float)`` were internal errors; the example of
cosim/component.py named a message type, Scalar, that exists nowhere.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Annotated, ClassVar

import numpy as np
import pytest

import cosim.component
from components.messages import BodyState
from cosim.cli import main
from cosim.component import Component, Port
from cosim.errors import RecordingError
from cosim.examples import Number
from cosim.messages import Array, Message, message
from cosim.params import param
from cosim.registry import UnknownComponentType, resolve
from cosim.scenario import loads
from tests.cli_toys import one_error_line

HERE = "tests.test_user_components_said"
KEYS_SAID = "(step, every, type, on_unstable)"

ON_A_BODY = """
dt: 0.001
until: 0.005
components:
  stone: {{type: RigidBody, position: [0, 0, 1]}}
  {extra}
  push: {{type: "{push}"}}
connections:
  - {{from: push.wrench, to: stone.wrench, delay: 1, initial: {{force: [0, 0, 0], torque: [0, 0, 0]}}}}
  {edge}
record: {{visual_rate: 0}}
"""


@message
class Wrench(Message):
    """A user's own reading that happens to be called Wrench."""

    speed: float
    label: str


@message
class Event(Message):
    """A user's type named like the framework's own events."""

    what: str


@message
class UserNumber(Message):
    """A number with its unit (recorded as cosim.UserNumber)."""

    value: float
    unit: str


UserNumber.__name__ = "Number"  # a user's Number(value, unit) beside cosim.examples' Number


@message
class Patch(Message):
    """Heights of n points in 3 columns: a free first dimension."""

    h: Annotated[np.ndarray, Array("float64", (None, 3))]


def _body_wrench() -> type[Message]:
    from components.messages import Wrench as BodyWrench
    return BodyWrench


class Gauge(Component):
    """Publishes a reading of its own Wrench type."""

    inputs: ClassVar[dict[str, Port]] = {"body": Port(BodyState, required=True)}
    outputs: ClassVar[dict[str, Port]] = {"reading": Port(Wrench)}

    def _step_impl(self, t: float, dt: float, inputs: dict) -> dict:
        return {"reading": Wrench(float(inputs["body"].position[2]), "z")}


class Announcer(Component):
    """Publishes a message type named Event."""

    outputs: ClassVar[dict[str, Port]] = {"said": Port(Event)}

    def _step_impl(self, t: float, dt: float, inputs: dict) -> dict:
        return {"said": Event("hello")}


class Lift(Component):
    """A constant lift (the body's own Wrench type)."""

    outputs: ClassVar[dict[str, Port]] = {"wrench": Port(_body_wrench())}

    def _step_impl(self, t: float, dt: float, inputs: dict) -> dict:
        return {"wrench": _body_wrench()(np.array([0.0, 0.0, 0.1]), np.zeros(3))}


class FlatPush(Component):
    """A push whose force is a 2-vector by mistake (from t = 2 ms on)."""

    outputs: ClassVar[dict[str, Port]] = {"wrench": Port(_body_wrench())}

    def _step_impl(self, t: float, dt: float, inputs: dict) -> dict:
        force = np.array([0.5, 0.0]) if t >= 0.002 else np.zeros(3)
        return {"wrench": _body_wrench()(force, np.zeros(3))}


class StepParam(Lift):
    """A lift with a parameter named like the scene's 'step'."""

    @dataclass(frozen=True)
    class Params:
        step: float = param(0.5, unit="N", doc="push")


class EveryParam(Lift):
    """A lift with a parameter named 'every'."""

    @dataclass(frozen=True)
    class Params:
        every: int = param(1)


class NoDataclass(Lift):
    """Params forgot @dataclass."""

    class Params:
        gain: float = param(1.0)


class ListInputs(Lift):
    """Inputs given as a list of names."""

    inputs = ["inp"]  # type: ignore[assignment]


class FloatPort(Lift):
    """A port of float, not of a message type."""

    inputs: ClassVar[dict[str, Port]] = {"inp": Port(float)}  # type: ignore[arg-type]


def test_two_message_types_of_one_class_name_are_refused_as_the_scene_loads(tmp_path, capsys):
    """A user's Wrench beside the body's components.messages.Wrench: exit 2 naming both classes,
    their modules and ports, and no recording (the run said ok over one that could not be read)."""
    scene = tmp_path / "a.yaml"
    scene.write_text(ON_A_BODY.format(push=f"{HERE}:Lift", extra=f'gauge: {{type: "{HERE}:Gauge"}}',
                                      edge="- stone.state -> gauge.body"))
    out = tmp_path / "a.mcap"
    assert main(["run", str(scene), "-q", "-o", str(out)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line == (f"error: {scene}: components: message types components.messages.Wrench (on stone.wrench, "
                    f"push.wrench) and {HERE}.Wrench (on gauge.reading) have the same class name, which is "
                    "their schema name cosim.Wrench in a recording: rename one of them")
    assert not out.exists()


def test_a_users_number_beside_the_examples_number_is_refused(tmp_path, capsys):
    """cosim.examples' Number on ping's ports and a user's Number(value, unit): exit 2."""
    scene = tmp_path / "n.yaml"
    scene.write_text("dt: 0.001\nuntil: 0.002\ncomponents:\n  ping: {type: 'cosim.examples:Ping'}\n"
                     f"  talk: {{type: '{HERE}:Talk'}}\n"
                     "connections:\n  - {from: ping.out, to: ping.inp, delay: 1, initial: {value: 0.0}}\n")
    assert main(["validate", str(scene)]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert "cosim.examples.Number (on ping.inp, ping.out)" in line
    assert f"{HERE}.UserNumber (on talk.out)" in line and "schema name cosim.Number" in line


class Talk(Component):
    """Publishes a number with its unit."""

    outputs: ClassVar[dict[str, Port]] = {"out": Port(UserNumber)}

    def _step_impl(self, t: float, dt: float, inputs: dict) -> dict:
        return {"out": UserNumber(1.0, "m")}


def test_a_message_type_named_like_the_frameworks_own_is_refused(tmp_path, capsys):
    """A user's Event would share the schema of /cosim/events."""
    scene = tmp_path / "e.yaml"
    scene.write_text(f"dt: 0.001\nuntil: 0.002\ncomponents:\n  talk: {{type: '{HERE}:Announcer'}}\n")
    assert main(["validate", str(scene)]) == 2
    assert one_error_line(capsys.readouterr().err) == (
        f"error: {scene}: components: message type {HERE}.Event (on talk.said) has the schema name "
        "cosim.Event of the framework's own channel /cosim/events: rename it")


def test_the_framework_schemas_are_the_recorders():
    """The names the scene keeps for the framework's channels are those the recorder gives them."""
    from cosim.codec import state_proto
    from cosim.record import recorder
    from cosim.scenario import FRAMEWORK_SCHEMAS  # (new with the rule)

    assert FRAMEWORK_SCHEMAS == {f"cosim.{recorder.Event.__name__}": recorder.EVENTS_TOPIC,
                                 f"cosim.{recorder.RunStatus.__name__}": recorder.STATUS_TOPIC,
                                 f"cosim.{recorder.PerfSample.__name__}": recorder.PERF_TOPIC,
                                 state_proto.SCHEMA_NAME: recorder.CHECKPOINT_TOPIC}


def test_the_recorder_never_ties_a_channel_to_another_types_schema(tmp_path):
    """Asked for a second schema under a name it holds, the recorder refuses (it tied the channel to
    the first type's schema, silently); the same schema again is the one it has."""
    from cosim.record.recorder import Recorder

    scene = loads("dt: 0.001\nuntil: 0.002\ncomponents:\n  ping: {type: 'cosim.examples:Ping'}\n"
                  "connections:\n  - {from: ping.out, to: ping.inp, delay: 1, initial: {value: 0.0}}\n")
    recorder = Recorder(tmp_path / "r.mcap", scene, background=False)
    try:
        first = recorder._message_channel("/a/out", Number)
        assert recorder._message_channel("/b/out", Number) != first  # its own channel, the same schema
        with pytest.raises(RecordingError, match=r"^/c/out: its schema cosim\.Number .* rename one of them$"):
            recorder._message_channel("/c/out", UserNumber)
    finally:
        recorder.discard()


@pytest.mark.parametrize(("cls", "key"), [("StepParam", "step"), ("EveryParam", "every")])
def test_a_parameter_named_like_a_scene_key_is_refused(tmp_path, capsys, cls, key):
    """``step: 0.002`` became the scheduling step and the parameter kept its default: now the type is
    refused, in a scene and by ``cosim components``, exit 2."""
    said = (f"component type '{HERE}:{cls}': its parameter '{key}' has the name of a scene key {KEYS_SAID}: "
            "rename it")
    scene = tmp_path / "b.yaml"
    scene.write_text(ON_A_BODY.format(push=f"{HERE}:{cls}", extra="", edge=""))
    assert main(["validate", str(scene)]) == 2
    assert one_error_line(capsys.readouterr().err) == f"error: {scene}: components.push.type: {said}"
    assert main(["components", f"{HERE}:{cls}"]) == 2
    assert one_error_line(capsys.readouterr().err) == f"error: cosim components: {said}"


def test_a_wrong_array_shape_is_the_components_failure(tmp_path, capsys):
    """A 2-vector force in a Wrench of force (3,): the component fails naming its output and field
    (it was an internal ProtoError of the recorder naming no component)."""
    scene = tmp_path / "c.yaml"
    scene.write_text(ON_A_BODY.format(push=f"{HERE}:FlatPush", extra="", edge=""))
    out = tmp_path / "c.mcap"
    assert main(["run", str(scene), "-q", "-o", str(out)]) == 1
    assert one_error_line(capsys.readouterr().err) == (
        "error: component 'push' failed at t = 0.002 s: output 'wrench' field 'force': "
        "must have shape (3,), got (2,)")


def test_first_invalid_judges_shapes_as_declared():
    """Each fixed dimension as declared; a free dimension takes any length. A list of the right length
    is no array (it passed, and failed the component receiving it)."""
    body_wrench = _body_wrench()
    assert body_wrench(np.zeros(3), np.zeros(3)).first_invalid() is None
    assert body_wrench([0.0, 1.0, 2.0], np.zeros(3)).first_invalid() == (
        "force", "must be a numpy array of float64, got list [0.0, 1.0, 2.0]")
    assert body_wrench(np.zeros(3), np.zeros((3, 1))).first_invalid() == (
        "torque", "must have shape (3,), got (3, 1)")
    assert body_wrench(np.zeros(4), np.zeros(3)).first_nonfinite() is None  # (finiteness alone)
    from cosim.messages import _first_bad_shape  # (new with the rule)

    assert Patch(np.zeros((5, 3))).first_invalid() is None
    assert Patch(np.zeros((5, 2))).first_invalid() == ("h", "must have shape (n, 3), got (5, 2)")
    assert _first_bad_shape(Patch(np.zeros(3))) == ("h", "must have shape (n, 3), got (3,)")


@pytest.mark.parametrize(("cls", "rule"), [
    ("NoDataclass", f"its Params must be a dataclass class (decorate it with @dataclass(frozen=True)); "
                    f"got class {HERE}.NoDataclass.Params"),
    ("ListInputs", "its inputs must be a dict of port name -> Port(MessageType), got a list (['inp'])"),
    ("FloatPort", "its input 'inp' carries class builtins.float, not a message type (a Message subclass "
                  "decorated with @message)"),
])
def test_a_component_class_breaking_the_contract_is_refused_naming_the_rule(capsys, cls, rule):
    """Each was an internal error; now resolve refuses the class, and ``cosim components`` says so."""
    with pytest.raises(UnknownComponentType) as caught:
        resolve(f"{HERE}:{cls}")
    assert str(caught.value) == f"component type '{HERE}:{cls}': {rule}"
    assert main(["components", f"{HERE}:{cls}"]) == 2
    assert one_error_line(capsys.readouterr().err) == f"error: cosim components: {caught.value!s}"


def test_the_example_of_the_component_module_runs():
    """The docstring's Counter is built and stepped (it named Scalar, which exists nowhere)."""
    text = cosim.component.__doc__ or ""
    block = re.search(r"::\n\n((?:    .*\n|\n)+)", text)
    assert block is not None
    code = "\n".join(line[4:] for line in block.group(1).splitlines())
    space: dict = {}
    exec(compile(code, "cosim/component.py (docstring)", "exec"), space)
    counter = space["Counter"]("counter")
    outputs = counter.step(0, 1_000_000, {"x": Number(2.0)})
    assert type(outputs["total"]) is Number and outputs["total"].value == 2.0


@pytest.mark.parametrize(("kind", "given", "said"), [
    ("RigidBody", {"shape": "cube"}, "shape: must be one of 'disk', 'sphere' (got 'cube')"),
    ("SolidGround", {"restitution": 2.0}, "restitution: must be <= 1 (got 2)"),
    ("WaterCoupler", {"rho": -1.0}, "rho: must be > 0 kg/m^3 (got -1)"),
    ("RigidBody", {"radius": -1.0}, "radius: must be > 0 m (got -1)"),
    ("RigidBody", {"tilt_deg": math.inf}, "tilt_deg: must be finite (got inf)"),
    ("RigidBody", {"tilt_deg": math.nan}, "tilt_deg: must be finite (got nan)"),
    ("WaterCoupler", {"c_l": -math.inf}, "c_l: must be finite (got -inf)"),
], ids=["shape", "restitution", "rho", "radius", "tilt-inf", "tilt-nan", "c_l-inf"])
def test_params_built_in_code_keep_the_rules_a_scene_is_held_to(kind, given, said):
    """Built in code, a disk's shape "cube" made a sphere, a restitution of 2 and a water density of -1
    were taken, and a radius of -1 was refused for the rod it made of the thickness: each field's own
    rule is now said, as a scene is told it."""
    from components.coupler import WaterCoupler
    from components.ground import SolidGround
    from components.rigid_body import RigidBody

    cls = {"RigidBody": RigidBody, "SolidGround": SolidGround, "WaterCoupler": WaterCoupler}[kind]
    with pytest.raises(ValueError, match="^" + re.escape(said)):
        cls("c", cls.Params(**given))


class BoundBreaks(Lift):
    def max_stable_step(self) -> float:
        raise ValueError("bound broke")


class CauseBreaks(Lift):
    def stable_step_cause(self) -> str:
        raise ValueError("cause broke")


class AnswersBreaks(Lift):
    def answers(self) -> dict[str, str]:
        raise ValueError("answers broke")


class NeededBreaks(Lift):
    def needed_outputs(self) -> dict[str, str]:
        raise KeyError("wrench")


class AgeBreaks(Component):
    """Reads the body's height; asked how old its input may be, it raises."""

    inputs: ClassVar[dict[str, Port]] = {"body": Port(BodyState, required=True)}
    outputs: ClassVar[dict[str, Port]] = {"height": Port(Number)}

    def input_max_age(self, port: str) -> tuple[float, str] | None:
        raise ValueError("age\nbroke")

    def _step_impl(self, t: float, dt: float, inputs: dict) -> dict:
        return {"height": Number(float(inputs["body"].position[2]))}


@pytest.mark.parametrize(("cls", "extra", "edge", "said"), [
    ("BoundBreaks", "", "", "components.push: its max_stable_step() failed (ValueError: bound broke)"),
    ("CauseBreaks", "", "", "components.push: its stable_step_cause() failed (ValueError: cause broke)"),
    ("NeededBreaks", "", "", "components.push: its needed_outputs() failed (KeyError: 'wrench')"),
    ("AnswersBreaks", "", "", "components.push: its answers() failed (ValueError: answers broke)"),
    ("Lift", f"gauge: {{type: \"{HERE}:AgeBreaks\"}}", "- stone.state -> gauge.body",
     "components.gauge: its input_max_age('body') failed (ValueError: age\\nbroke)"),  # (one line)
])
def test_a_users_hook_failing_as_the_scene_loads_is_said_on_its_key(tmp_path, capsys, cls, extra, edge, said):
    """The scene's checks ask each component its stable step, what sets it, the outputs it needs
    consumed and how old an input may be; a user's hook raising there was an internal error of cosim's,
    the component unnamed, exit 1. It is said on the component's key, exit 2, as a failing setup is."""
    scene = tmp_path / "h.yaml"
    scene.write_text(ON_A_BODY.format(push=f"{HERE}:{cls}", extra=extra, edge=edge))
    assert main(["validate", str(scene)]) == 2
    assert one_error_line(capsys.readouterr().err) == f"error: {scene}: {said}"


@message
class Report(Message):
    """A user's report of every scalar kind and an int32 array."""

    count: int
    stretched: bool
    label: str
    idx: Annotated[np.ndarray, Array("int32", (None,))]


class Reporter(Component):
    """Publishes a Report; ``wrong`` names the field given a value of another kind than its own."""

    @dataclass(frozen=True)
    class Params:
        wrong: str = param("", doc="the field given a wrong value (none: every field right)")

    outputs: ClassVar[dict[str, Port]] = {"report": Port(Report)}

    def _step_impl(self, t: float, dt: float, inputs: dict) -> dict:
        values = {"count": 1, "stretched": True, "label": "a", "idx": np.zeros(2, np.int32)}
        wrong = self.params.wrong
        if wrong == "count":
            values["count"] = 1.5
        elif wrong == "huge":
            values["count"] = 2 ** 70
        elif wrong == "stretched":
            values["stretched"] = "no"
        elif wrong == "label":
            values["label"] = 5
        elif wrong == "idx":
            values["idx"] = np.zeros(2)
        elif wrong == "numpy":  # numpy's own scalars are right, and an int64 array whose values fit int32
            values.update(count=np.int64(3), stretched=np.bool_(False), idx=np.array([1, -2], np.int64))
        elif wrong == "bool":
            values["count"] = True
        elif wrong == "wide":
            values["idx"] = np.array([2 ** 40, -1], np.int64)
        return {"report": Report(**values)}


class ListPush(Component):
    """A push whose force is a list, not an array."""

    outputs: ClassVar[dict[str, Port]] = {"wrench": Port(_body_wrench())}

    def _step_impl(self, t: float, dt: float, inputs: dict) -> dict:
        return {"wrench": _body_wrench()([0.0, 0.0, 0.1], np.zeros(3))}


@pytest.mark.parametrize(("wrong", "said"), [
    # recorded as 1 while its receivers were given 1.5, and a replay said identical
    ("count", "output 'report' field 'count': must be an int (a whole number), got float 1.5"),
    ("huge", "output 'report' field 'count': must fit in 64 bits (-2^63 to 2^63 - 1), got "
             "1180591620717411303424"),  # an internal ProtoError, naming no component
    ("stretched", "output 'report' field 'stretched': must be true or false (a bool), got str 'no'"),  # recorded true
    ("label", "output 'report' field 'label': must be a str, got int 5"),
    ("idx", "output 'report' field 'idx': must be an array of int32, got an array of float64"),  # internal error
    ("numpy", None),
    # recorded as 1 while its receivers had True (and no decoder takes a bool for an int)
    ("bool", "output 'report' field 'count': must be an int (a whole number), got bool True"),
    # cast by the codecs, 2**40 was recorded as 0
    ("wide", "output 'report' field 'idx': must be an array of int32, got an array of int64 holding values "
             "beyond int32's range"),
])
def test_an_output_field_of_another_kind_is_the_components_failure(tmp_path, capsys, wrong, said):
    """A field given a value of another kind than its own fails the component that published it,
    naming its output and field, before the recording writes it as something else than its receivers
    were given (or fails naming no component); numpy's integers and bools are ints and bools."""
    scene = tmp_path / "r.yaml"
    scene.write_text(f'dt: 0.001\nuntil: 0.003\ncomponents:\n  rep: {{type: "{HERE}:Reporter", wrong: "{wrong}"}}\n')
    code = main(["run", str(scene), "-q", "-o", str(tmp_path / "r.mcap")])
    err = capsys.readouterr().err
    if said is None:
        assert code == 0, err
        return
    assert code == 1 and one_error_line(err) == f"error: component 'rep' failed at t = 0 s: {said}"


def test_a_list_in_an_array_field_is_the_publishers_failure_not_its_receivers(tmp_path, capsys):
    """A force given as a list: the push fails naming its field (the body receiving it failed, with
    "AttributeError: 'list' object has no attribute 'tolist'")."""
    scene = tmp_path / "l.yaml"
    scene.write_text(ON_A_BODY.format(push=f"{HERE}:ListPush", extra="", edge=""))
    assert main(["run", str(scene), "-q", "--no-record"]) == 1
    assert one_error_line(capsys.readouterr().err) == (
        "error: component 'push' failed at t = 0 s: output 'wrench' field 'force': must be a numpy array of "
        "float64, got list [0.0, 0.0, 0.1]")


class Forgetful(Component):
    """Counts its steps; its set_state fails with ``fault``."""

    @dataclass(frozen=True)
    class Params:
        fault: str = param("key", doc="key: a KeyError, else a RuntimeError")

    outputs: ClassVar[dict[str, Port]] = {"count": Port(Number)}

    def setup(self) -> None:
        self.count = 0

    def _step_impl(self, t: float, dt: float, inputs: dict) -> dict:
        self.count += 1
        return {"count": Number(float(self.count))}

    def get_state(self) -> dict:
        return {"count": self.count}

    def set_state(self, state: dict) -> None:
        if self.params.fault == "key":
            self.count = state["counter"]  # the user's own slip
        raise RuntimeError("cannot restore")


@pytest.mark.parametrize(("fault", "code", "said"), [
    ("key", 2, "cannot restart from the checkpoint at 0.01 s: it holds no 'counter' for component 'c', whose "
               "set_state reads it (a component or setting changed by --set, or a set_state reading what its "
               "get_state does not write?)"),
    ("runtime", 1, "component 'c' failed at t = 0.01 s: restoring its saved state failed: RuntimeError: cannot "
                   "restore"),
])
def test_a_set_state_that_fails_is_said_on_its_component(tmp_path, capsys, fault, code, said):
    """A restart whose component's own set_state raises: a KeyError (as a ValueError or a TypeError)
    is the state's not being one it takes, said naming the component (it named none, and blamed
    --set alone); any other error is the component's failure at the checkpoint's time (a
    RuntimeError was an internal error)."""
    scene = tmp_path / "f.yaml"
    scene.write_text("name: f\ndt: 0.001\nuntil: 0.02\ncomponents:\n"
                     f'  c: {{type: "{HERE}:Forgetful", fault: {fault}}}\nrecord: {{checkpoint_every: 0.01}}\n')
    recording = tmp_path / "f.mcap"
    assert main(["run", str(scene), "-q", "-o", str(recording)]) == 0
    capsys.readouterr()
    assert main(["replay", str(recording), "--from", "0.01", "-q", "-o", str(tmp_path / "g.mcap")]) == code
    where = f"{recording}: " if code == 2 else ""
    assert one_error_line(capsys.readouterr().err) == f"error: {where}{said}"


def test_a_key_error_without_a_key_is_said_too():
    """A set_state raising a bare KeyError: still said naming the component (it raised IndexError in
    the saying, a traceback)."""
    from cosim.errors import StateRestoreError

    assert str(StateRestoreError("c", KeyError())) == "component 'c' cannot take the state it holds: KeyError: "
